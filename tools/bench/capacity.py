"""Realtime capacity (``shoal bench --capacity``): at each tick rate, the largest formation that
runs ``seconds`` on the wall clock with no missed deadline and a p99 command latency under one
period, beside the same figure for the bare floor pattern (tools/bench/floor.py) at the same
rate, measured in the same invocation.

Sizes are tried up a ladder, the floor and the run at each size one after the other; each stops
at its first failing size (a larger formation costs more per tick on the same two cores), and
its capacity is the last size before that (None if the smallest already fails). Every trial is
reported with its figures, passed or not.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from shoal.tools.bench.swarm import measure_floor, measure_run

LADDER = (5, 10, 20, 30, 50, 75, 100)
RATES = (10.0, 50.0, 100.0)
SECONDS = 30.0
FIGURES = ("missed_deadlines", "latency_p50_ms", "latency_p99_ms", "ticks_per_s")


def keeps_up(
    figures: dict[str, Any], period_ms: float, *, agent_ticks: int = 0, max_miss_rate: float = 0.0
) -> bool:
    """The p99 command latency under one period, and no deadline missed — or, with a
    ``max_miss_rate`` > 0, missed deadlines at most that fraction of the ``agent_ticks``."""
    p99 = figures.get("latency_p99_ms")
    missed = figures.get("missed_deadlines")
    if p99 is None or not p99 < period_ms or not isinstance(missed, int):
        return False
    return missed <= max_miss_rate * agent_ticks if max_miss_rate > 0 else missed == 0


def capacity(
    rates: Sequence[float] = RATES,
    ladder: Sequence[int] = LADDER,
    seconds: float = SECONDS,
    *,
    max_miss_rate: float = 0.0,
    say: Callable[[str], None] = lambda _s: None,
) -> list[dict[str, Any]]:
    """One row per rate: ``floor`` and ``ours`` (the capacities) and every ``trial``; a size
    keeps up as :func:`keeps_up` says, with ``max_miss_rate`` of its agent-ticks."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="shoal-capacity-") as tmp:
        for rate in rates:
            work = Path(tmp) / f"{rate:g}-hz"  # each run's log under its own name
            work.mkdir()
            period = 1.0 / rate
            ticks = max(1, round(seconds * rate))
            row: dict[str, Any] = {
                "rate_hz": rate,
                "seconds": ticks * period,
                "max_miss_rate": max_miss_rate,
            }
            best: dict[str, int | None] = {"floor": None, "ours": None}
            going = {"floor": True, "ours": True}
            trials = []
            for n in ladder:
                if not any(going.values()):
                    break
                trial: dict[str, Any] = {"agents": n}
                for side in ("floor", "ours"):
                    if not going[side]:
                        continue
                    say(
                        f"{rate:g} Hz, {n} agents: {'floor' if side == 'floor' else 'realtime run'}"
                    )
                    if side == "floor":
                        figures = measure_floor(n, ticks, period=period)
                    else:
                        run = measure_run(n, ticks, work, clock="realtime", dt=period)
                        figures = run.summary
                    trial[side] = {k: figures.get(k) for k in FIGURES}
                    trial[side]["keeps_up"] = ok = keeps_up(
                        figures, period * 1e3, agent_ticks=n * ticks, max_miss_rate=max_miss_rate
                    )
                    verdict = "keeps up" if ok else "falls behind"
                    say(f"  {verdict}: {figures.get('missed_deadlines')} missed, "
                        f"p99 {figures.get('latency_p99_ms')} ms")  # fmt: skip
                    if ok:
                        best[side] = n
                    else:
                        going[side] = False
                trials.append(trial)
            rows.append({**row, **best, "trials": trials})
    return rows
