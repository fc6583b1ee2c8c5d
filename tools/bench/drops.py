"""Formation error against the fraction of neighbour messages lost.

Each rate gets one realtime run of the whole swarm (``shoal run --clock realtime --drop-rate P``, a
router of its own), and the error is read back from the run's log, so the figures are the world's
ground truth, not what the agents believed. The steady-state error is the formation error of
:func:`shoal.world.metrics.formation_errors` (worst follower, per-coordinate), over the ticks from
``settle`` seconds on: the transient from the scattered start is excluded, the effect of the lost
messages is what remains. Its median is the figure to compare (a realtime run on a shared machine
has CPU stalls, during which the world's watchdog holds starved agents still while the leader moves
on: they show in the p95 and the max, which are reported beside it together with the run's missed
deadlines and stale holds, so a reader can tell load from loss).

``shoal bench --drops 0,0.05,0.2`` prints the figures as JSON;
tests/integration/test_faults.py asserts a bound on a shorter run of the same function.
"""

from __future__ import annotations

import tempfile
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from shoal.bus.types import Clock
from shoal.tools.log.reader import read_trajectory
from shoal.tools.procs.launch import RunPlan, launch
from shoal.world.loader import load_scenario
from shoal.world.metrics import formation_errors


@dataclass(frozen=True)
class DropRow:
    """The figures of one run at one drop rate (errors in m)."""

    rate: float
    median: float
    p95: float
    max: float
    final: float
    injected: int  # neighbour states thrown away, summed over agents
    offered: int  # neighbour states that arrived, summed over agents
    age_p99: int | None  # worst agent's p99 age of the states it acted on, ticks
    age_max: int | None
    stale_edges: int  # edge-ticks dropped because the latest state was > MAX_AGE ticks old
    missed_deadlines: int
    stale_holds: int
    ticks_per_s: float
    collisions: int

    def as_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def steady_errors(scenario: str | Path, log: Path, settle: float) -> Any:
    """The worst follower's formation error (m) at every tick from ``settle`` s on."""
    scn = load_scenario(scenario)
    traj = read_trajectory(log, dt=scn.dt, lookahead=scn.lookaheads)
    worst = formation_errors(scn, traj).max(axis=1)
    return worst[round(settle / scn.dt) :]


def measure(
    scenario: str,
    rate: float,
    *,
    speed: float,
    settle: float,
    seed: int,
    workdir: Path,
) -> DropRow:
    """One realtime run of ``scenario`` (a built-in name or an absolute path) at drop ``rate``."""
    scn = load_scenario(scenario)
    out = workdir / f"drops-{rate:g}-{uuid.uuid4().hex[:6]}.mcap"
    plan = RunPlan(
        scenario=scn,
        out=out,
        run_id=f"drops-{uuid.uuid4().hex[:8]}",
        clock=Clock.REALTIME,
        speed=speed,
        drop_rate=rate,
        drop_seed=seed,
    )
    result = launch(plan)
    errors = steady_errors(scenario, out, settle)
    stats = list(result.agent_reports.values())  # each agent's figures (bus/report.py)
    p99s = [a for s in stats if (a := s.get("age_p99")) is not None]
    maxes = [a for s in stats if (a := s.get("age_max")) is not None]
    summary = result.summary
    return DropRow(
        rate=rate,
        median=round(float(np.median(errors)), 4),
        p95=round(float(np.percentile(errors, 95)), 4),
        max=round(float(errors.max()), 4),
        final=round(float(summary["final_formation_error"]), 4),
        injected=sum(s.get("injected_drops") or 0 for s in stats),
        offered=sum(s.get("states_heard") or 0 for s in stats),
        age_p99=max(p99s, default=None),
        age_max=max(maxes, default=None),
        stale_edges=sum(s.get("stale_edges") or 0 for s in stats),
        missed_deadlines=int(summary["missed_deadlines"]),
        stale_holds=int(summary["stale_holds"]),
        ticks_per_s=float(summary["ticks_per_s"]),
        collisions=int(summary["collisions"]),
    )


def bench_drops(
    rates: Sequence[float],
    *,
    scenario: str = "sinusoid",
    speed: float = 1.0,
    settle: float = 10.0,
    seed: int = 0,
    repeats: int = 1,
    say: Callable[[str], None] = lambda _s: None,
) -> dict[str, Any]:
    """Every rate ``repeats`` times. A repeat is a whole sweep over the rates, so a burst of
    machine load lands on neighbouring runs of different rates, not on every run of one rate."""
    rows: list[DropRow] = []
    with tempfile.TemporaryDirectory(prefix="shoal-drops-") as tmp:
        for r in range(repeats):
            for rate in rates:
                say(f"drop rate {rate:g}: run {r + 1} of {repeats}")
                rows.append(
                    measure(
                        scenario, rate, speed=speed, settle=settle, seed=seed + r, workdir=Path(tmp)
                    )
                )
    return {
        "scenario": scenario,
        "speed": speed,
        "settle_s": settle,
        "tolerance": load_scenario(scenario).tolerance,
        "runs": [row.as_dict() for row in rows],
    }
