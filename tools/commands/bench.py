"""``shoal bench``: performance figures next to their floor, measured in the same run."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from shoal.bus.runtime import exit_on_signals
from shoal.tools.bench.capacity import LADDER, RATES, SECONDS, capacity
from shoal.tools.bench.drops import bench_drops
from shoal.tools.bench.filter import bench_filter
from shoal.tools.bench.swarm import bench as run_bench
from shoal.tools.bench.table import render_bench, render_filter, render_rows
from shoal.tools.extras import require
from shoal.tools.procs.swarm import SUPERVISOR_GRACE_S, ChildFailed

_SIZES = "5,10,20,50"


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of tables.")
@click.option("--sizes", default=_SIZES, help="Formation sizes, comma-separated.")
@click.option("--ticks", default=400, help="Ticks per lockstep run (halved above 20 agents).")
@click.option(
    "--out", type=click.Path(dir_okay=False, path_type=Path), help="Also write the JSON here."
)
@click.option(
    "--drops",
    help="Instead: the steady-state formation error of realtime runs at these fractions of "
    "lost neighbour messages, e.g. 0,0.05,0.2 (tools/bench/drops.py).",
)
@click.option("--scenario", default="sinusoid", help="--drops: the scenario to run.")
@click.option("--speed", default=1.0, help="--drops: simulated seconds per wall-clock second.")
@click.option("--settle", default=10.0, help="--drops: seconds excluded as the transient.")
@click.option(
    "--repeats",
    type=click.IntRange(min=1),
    default=1,
    help="Lockstep: floor/run pairs per size, in alternating order, reported as medians with "
    "every pair's ratio; --drops: sweeps over the rates.",
)
@click.option(
    "--filter",
    "filter_only",
    is_flag=True,
    help="Only the safety filter's CPU per agent-tick, beside the reference simulator's.",
)
@click.option(
    "--physics",
    "physics_only",
    is_flag=True,
    help="Instead: the physics plant's CPU per simulated second at --sizes robots (default "
    "5,20,50), holonomic and wheeled, beside the kinematic plant's (the physics extra).",
)
@click.option(
    "--capacity",
    "capacity_only",
    is_flag=True,
    help="Instead: at each --rates, the largest formation on --ladder that runs --seconds "
    "with no missed deadline and p99 command latency under one period, beside the floor's.",
)
@click.option(
    "--rates",
    "capacity_rates",
    default=",".join(f"{r:g}" for r in RATES),
    help="--capacity: ticks per second.",
)
@click.option(
    "--ladder", default=",".join(map(str, LADDER)), help="--capacity: formation sizes to try."
)
@click.option("--seconds", default=SECONDS, help="--capacity: wall-clock seconds per trial.")
@click.option(
    "--max-miss-rate",
    type=click.FloatRange(0.0, 1.0, max_open=True),
    default=0.0,
    help="--capacity: a size keeps up with missed deadlines up to this fraction of its "
    "agent-ticks (default 0: none at all).",
)
def bench(
    as_json: bool,
    sizes: str,
    ticks: int,
    out: Path | None,
    drops: str | None,
    scenario: str,
    speed: float,
    settle: float,
    repeats: int,
    filter_only: bool,
    physics_only: bool,
    capacity_only: bool,
    capacity_rates: str,
    ladder: str,
    seconds: float,
    max_miss_rate: float,
) -> None:
    """Measure lockstep ticks/s against a bare Zenoh exchange of the same message pattern
    (with each kind of process's CPU per tick in both), the time until every agent is up,
    realtime command latency and memory per agent process; or, with --drops, the formation
    error against the fraction of lost neighbour messages.

    Prints tables, each figure beside its floor and every column explained (--json: one JSON
    object with every figure); progress goes to stderr.
    """
    exit_on_signals(grace=SUPERVISOR_GRACE_S)
    if capacity_only:
        hz = _numbers(capacity_rates, float, "--rates")
        steps = _numbers(ladder, int, "--ladder")
        if min(hz) <= 0 or seconds <= 0:
            raise click.BadParameter("rates and --seconds must be > 0", param_hint="--rates")
        if min(steps) < 2:
            raise click.BadParameter("every size needs a leader and a follower (≥ 2)",
                                     param_hint="--ladder")  # fmt: skip
        try:
            rows = capacity(hz, sorted(set(steps)), seconds, max_miss_rate=max_miss_rate, say=_say)
        except ChildFailed as exc:
            raise click.ClickException(str(exc)) from None
        _emit({"realtime_capacity": rows}, out, as_json,
              lambda r: render_rows("realtime capacity", r["realtime_capacity"]))  # fmt: skip
        return
    if filter_only:
        _emit(bench_filter(), out, as_json, render_filter)
        return
    if physics_only:
        require("physics", "shoal bench --physics")
        from shoal.tools.bench.physics import SIZES, bench_physics, render_physics

        chosen = SIZES if sizes == _SIZES else tuple(_numbers(sizes, int, "--sizes"))
        _emit(bench_physics(chosen, say=_say), out, as_json, render_physics)
        return
    if drops is not None:
        try:
            rates = [float(s) for s in drops.split(",") if s.strip()]
        except ValueError:
            raise click.BadParameter(f"{drops!r} is not a list of fractions") from None
        if not rates or not all(0 <= r < 1 for r in rates):
            raise click.BadParameter("every drop rate must be in [0, 1)", param_hint="--drops")
        try:
            result = bench_drops(
                rates, scenario=scenario, speed=speed, settle=settle, repeats=repeats, say=_say
            )
        except ChildFailed as exc:
            raise click.ClickException(str(exc)) from None
        _emit(result, out, as_json, lambda r: render_rows(
            f"formation error against lost messages ({r['scenario']}, tolerance "
            f"{r['tolerance']:.3g} m, after {r['settle_s']:g} s)", r["runs"]))  # fmt: skip
        return
    try:
        numbers = [int(s) for s in sizes.split(",") if s.strip()]
    except ValueError:
        raise click.BadParameter(f"{sizes!r} is not a comma-separated list of integers") from None
    if not numbers or min(numbers) < 2:
        raise click.BadParameter("every size needs a leader and a follower (≥ 2)")
    try:
        result = run_bench(numbers, ticks, repeats=repeats, say=_say)
    except ChildFailed as exc:
        raise click.ClickException(str(exc)) from None
    _say("the safety filter, per agent-tick")
    result["safety_filter"] = bench_filter()
    _emit(result, out, as_json, render_bench)


def _numbers(text: str, kind: type[int] | type[float], hint: str) -> list[Any]:
    try:
        values = [kind(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise click.BadParameter(
            f"{text!r} is not a comma-separated list", param_hint=hint
        ) from None
    if not values:
        raise click.BadParameter("give at least one value", param_hint=hint)
    return values


def _say(text: str) -> None:
    click.echo(text, err=True)


def _emit(
    result: dict[str, Any],
    out: Path | None,
    as_json: bool,
    shown: Callable[[dict[str, Any]], str],
) -> None:
    text = json.dumps(result, indent=2)
    if out is not None:
        out.write_text(text + "\n")
    click.echo(text if as_json else shown(result))
