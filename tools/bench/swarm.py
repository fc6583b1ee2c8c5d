"""``shoal bench``: lockstep ticks/s against the bare-bus floor, start-up time, realtime latency
and memory per agent, all measured in one invocation on this machine.

For each formation size the floor (tools/bench/floor.py: the same processes and message pattern,
no control math) runs first and the real lockstep run right after, each with its own router,
so both see the same machine. Hypervisor steal during each measurement is read from /proc/stat
and reported with it: on a shared 2-core VM it can swing results 2-5x.
"""

from __future__ import annotations

import json
import statistics
import tempfile
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from shoal.bus.types import Clock
from shoal.tools.bench.formations import bench_scenario
from shoal.tools.procs.cpu import CpuWindow, swarm_processes
from shoal.tools.procs.launch import RunPlan, RunResult, free_port, launch
from shoal.tools.procs.swarm import Swarm
from shoal.world.loader import load_scenario


@dataclass(frozen=True)
class Steal:
    """CPU time stolen by the hypervisor between two readings of /proc/stat (fraction)."""

    before: tuple[int, ...]

    @classmethod
    def start(cls) -> Steal:
        return cls(_cpu_times())

    def fraction(self) -> float:
        now = _cpu_times()
        delta = [b - a for a, b in zip(self.before, now, strict=True)]
        total = sum(delta)
        return round(delta[7] / total, 3) if total and len(delta) > 7 else 0.0


def _cpu_times() -> tuple[int, ...]:
    with open("/proc/stat") as f:
        return tuple(int(x) for x in f.readline().split()[1:])


def measure_floor(
    n: int, ticks: int, timeout: float = 120.0, *, period: float = 0.0
) -> dict[str, Any]:
    """The floor pattern of ``n`` agents for ``ticks`` ticks: lockstep, or realtime at one tick
    per ``period`` s (then with its latency and missed deadlines, tools/bench/floor.py)."""
    run, endpoint = f"floor-{uuid.uuid4().hex[:8]}", f"tcp/127.0.0.1:{free_port()}"
    common = ["--run", run, "--connect", endpoint]
    steal = Steal.start()
    with Swarm() as swarm:
        listen = ["router", "--listen", endpoint]
        router = swarm.spawn("router", "router", listen, ready_pipe=True)
        swarm.wait_ready(router, timeout)
        listeners = [
            swarm.spawn(role, "logger", ["floor", "listener", "--role", role, *common],
                        ready_pipe=True)
            for role in ("logger", "monitor")
        ]  # fmt: skip
        world = swarm.spawn(
            "floor world",
            "world",
            [
                "floor",
                "world",
                "--agents",
                str(n),
                "--ticks",
                str(ticks),
                "--period",
                repr(period),
                *common,
            ],
            ready_pipe=True,
        )
        for i in range(1, n + 1):
            args = ["floor", "agent", "--agents", str(n), "--id", str(i), *common]
            swarm.spawn(f"floor agent {i}", "agent", args)
        for child in listeners:
            swarm.wait_ready(child, timeout)
        cpu = CpuWindow(lambda: swarm_processes(swarm))
        swarm.wait_ready(world, timeout, prefix="ready floor ticking")
        cpu.open()
        result = json.loads(swarm.wait_ready(world, timeout + ticks * period, prefix="{"))
        cpu.close(ticks)
        swarm.expect_exit({"world", "agent", "logger"}, timeout=10.0)
    realtime = ("latency_p50_ms", "latency_p99_ms", "missed_deadlines") if period > 0 else ()
    return {
        "ticks_per_s": round(result["ticks_per_s"], 1),
        "steal": steal.fraction(),
        "cpu_us_per_tick": cpu.figures,
        **{k: result[k] for k in realtime},  # a lockstep floor has no deadline to miss
    }


@dataclass(frozen=True)
class FloorAndRun:
    """One floor measurement and one lockstep run of the same size, back to back."""

    floor: dict[str, Any]
    run: RunResult
    steal_run: float

    @property
    def ratio(self) -> float:
        return float(self.floor["ticks_per_s"]) / float(self.run.summary["ticks_per_s"])


def _pair(
    n: int, ticks: int, work: Path, *, floor_first: bool, tag: str, say: Callable[[str], None]
) -> FloorAndRun:
    def floor() -> dict[str, Any]:
        say(f"{n} agents: floor{tag}")
        return measure_floor(n, ticks)

    def run() -> tuple[RunResult, float]:
        say(f"{n} agents: lockstep run{tag}")
        steal = Steal.start()
        result = measure_run(n, ticks, work)
        return result, steal.fraction()

    if floor_first:
        f = floor()
        real, steal = run()
    else:
        real, steal = run()
        f = floor()
    return FloorAndRun(f, real, steal)


def _row(n: int, ticks: int, pairs: list[FloorAndRun]) -> dict[str, Any]:
    """A size's figures: with one pair, that pair's; with more, the medians, the pair whose
    ratio is the median for the CPU per tick, and every pair's ratio."""
    median = sorted(pairs, key=lambda p: p.ratio)[(len(pairs) - 1) // 2]
    floor_tps = statistics.median(p.floor["ticks_per_s"] for p in pairs)
    ours = statistics.median(p.run.summary["ticks_per_s"] for p in pairs)
    row: dict[str, Any] = {
        "agents": n,
        "ticks": ticks,
        "floor_ticks_per_s": floor_tps,
        "lockstep_ticks_per_s": ours,
        "floor_over_lockstep": round(statistics.median(p.ratio for p in pairs), 3),
        "latency_p50_ms": statistics.median(p.run.summary["latency_p50_ms"] for p in pairs),
        "latency_p99_ms": statistics.median(p.run.summary["latency_p99_ms"] for p in pairs),
        "steal_floor": max(p.floor["steal"] for p in pairs),
        "steal_lockstep": max(p.steal_run for p in pairs),
        "cpu_us_per_tick": {
            "floor": median.floor["cpu_us_per_tick"],
            "lockstep": median.run.cpu_us_per_tick,
        },
    }
    if len(pairs) > 1:
        row["pairs"] = [
            {
                "floor_ticks_per_s": p.floor["ticks_per_s"],
                "lockstep_ticks_per_s": p.run.summary["ticks_per_s"],
                "floor_over_lockstep": round(p.ratio, 3),
                "steal": max(p.floor["steal"], p.steal_run),
            }
            for p in pairs
        ]
    return row


def measure_run(
    n: int, ticks: int, workdir: Path, *, clock: str = "lockstep", dt: float = 0.01
) -> RunResult:
    run_id = uuid.uuid4().hex[:8]
    path = workdir / f"bench-{n}.yaml"
    path.write_text(yaml.safe_dump(bench_scenario(n, ticks, dt)))
    plan = RunPlan(
        scenario=load_scenario(path),
        out=workdir / f"bench-{n}-{clock}-{run_id}.mcap",
        run_id=f"bench-{run_id}",
        clock=Clock(clock),
        measure_cpu=True,
    )
    return launch(plan)


def bench(
    sizes: Sequence[int],
    ticks: int,
    *,
    repeats: int = 1,
    say: Callable[[str], None] = lambda _s: None,
) -> dict[str, Any]:
    """Every figure of the benchmark, as one JSON-able dict.

    ``repeats`` > 1 measures each size as that many floor/run pairs, the order alternating
    (floor first, then run first, ...), and reports the median of each figure and every pair's
    ratio: on a shared VM one pair's ratio moves by a third from one minute to the next."""
    rows, rss, pss, startup = [], [], [], {}
    with tempfile.TemporaryDirectory(prefix="shoal-bench-") as tmp:
        work = Path(tmp)
        for n in sizes:
            t = ticks if n <= 20 else max(ticks // 2, 50)
            pairs = []
            for r in range(repeats):
                tag = f" (pair {r + 1} of {repeats})" if repeats > 1 else ""
                pair = _pair(n, t, work, floor_first=r % 2 == 0, tag=tag, say=say)
                pairs.append(pair)
                rss += pair.run.agent_peak_rss_mb
                pss += pair.run.agent_pss_mb
            rows.append(_row(n, t, pairs))
            startup[str(n)] = statistics.median(p.run.startup_s for p in pairs)
        say("5 agents: realtime run")
        rt = measure_run(5, ticks, work, clock="realtime")
    return {
        "lockstep": rows,
        "startup_s": startup,
        "realtime_5_agents": {
            k: rt.summary[k]
            for k in ("latency_p50_ms", "latency_p99_ms", "missed_deadlines", "ticks_per_s")
        },
        "agent_peak_rss_mb": {
            "max": round(max(rss), 1) if rss else None,
            "median": round(statistics.median(rss), 1) if rss else None,
            "processes": len(rss),
        },
        # PSS: shared pages (the interpreter, numpy, zenoh's library) counted once among the
        # agents that share them — what one more agent really costs.
        "agent_pss_mb": {
            "max": round(max(pss), 1) if pss else None,
            "median": round(statistics.median(pss), 1) if pss else None,
            "processes": len(pss),
        },
    }
