"""Campaign fields as real swarms (``shoal campaign --swarm N``): each of the first N inside
fields runs as a distributed ``shoal run`` — router, world, logger, one OS process per agent —
in lockstep (then it must equal the reference simulator bit for bit) or in realtime (where the
world's safety layer, not the reference, is what keeps it safe)."""

from __future__ import annotations

import math
import statistics
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.campaign.fields import FieldOptions, make_field
from shoal.tools.campaign.people import PeopleOptions, add_people
from shoal.tools.log.reader import read_trajectory
from shoal.tools.procs.launch import RunPlan, fresh_run_id, launch
from shoal.tools.simulator import simulate
from shoal.world.scenario import Scenario


@dataclass(frozen=True)
class Faults:
    """What goes wrong on the bus in every swarm: each agent's outgoing messages held back
    ``delay_ms`` ± ``jitter_ms``, ``drop_rate`` of the states it hears thrown away."""

    delay_ms: float = 0.0
    jitter_ms: float = 0.0
    drop_rate: float = 0.0


@dataclass(frozen=True)
class Swarming:
    """How each field runs as a swarm: its ``clock``, the robots' safety ``layer`` (None: the
    clock's default), the bus's ``faults``, and with ``people`` its crowd."""

    clock: Clock
    speed: float = 1.0  # realtime: simulated seconds per wall-clock second
    layer: SafetyLayer | None = None
    faults: Faults = Faults()
    people: PeopleOptions | None = None


def run_swarms(
    base: Scenario,
    seed: int,
    count: int,
    options: FieldOptions,
    how: Swarming,
    done: Callable[[dict[str, Any]], None] = lambda _row: None,
) -> list[dict[str, Any]]:
    """One row of figures per field, in seed order (``done`` is called with each); with
    ``how.people``, each field has its crowd (tools/campaign/people.py)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="shoal-swarm-") as tmp:
        for k in range(count):
            if how.people is None:
                field = make_field(base, seed + k, "inside", options)
            else:
                field = add_people(base, seed + k, options, how.people)
            out = Path(tmp) / f"{field.name}.mcap"
            result = launch(
                RunPlan(
                    scenario=field, out=out, run_id=fresh_run_id(), clock=how.clock,
                    speed=how.speed, safety_layer=how.layer, delay_ms=how.faults.delay_ms,
                    jitter_ms=how.faults.jitter_ms, drop_rate=how.faults.drop_rate,
                    drop_seed=seed + k,
                )
            )  # fmt: skip
            s = result.summary
            row = {
                "name": field.name,
                "collisions": s["collisions"],
                "min_clearance": s["min_clearance"],
                "min_interagent_distance": s["min_interagent_distance"],
                "rho": field.control.safety_margin,
                "separation": field.separation,
                "filter_activity": s["filter_activity"],
                "actuator_corrections": s["actuator_corrections"],
                "safety_layer": s.get("safety_layer"),
                "layer_standing": s.get("layer_standing"),
                "referee_would_correct": s.get("referee_would_correct"),
                "referee_largest_change": s.get("referee_largest_change"),
                "arrived": s.get("arrived"),
                "arrival_time": s.get("arrival_time"),
                "not_arrived": s.get("not_arrived"),  # why not: "out of time", "deadlock", …
                "missed_deadlines": s["missed_deadlines"],
                "lost": list(result.lost),
                "agent_at_fault": s.get("agent_at_fault", 0),
                "obstacle_at_fault": s.get("obstacle_at_fault", 0),
                "min_mover_clearance": s.get("min_mover_clearance"),
                "exact": _exact(out, field) if how.clock == Clock.LOCKSTEP else None,
            }
            rows.append(row)
            done(row)
    return rows


def _exact(log: Path, field: Scenario) -> bool:
    """Whether the run's log equals the reference bit for bit; a log with a gap does not."""
    try:
        return read_trajectory(log, dt=field.dt, lookahead=field.lookaheads).equals(simulate(field))
    except ValueError:  # ticks missing or twice (tools/log/reader.py)
        return False


def swarm_report(
    rows: list[dict[str, Any]], clock: str, layer: SafetyLayer | None = None
) -> dict[str, Any]:
    """The swarm campaign in one JSON-able dict."""
    clear = [r["min_clearance"] for r in rows if r["min_clearance"] is not None]
    return {
        "clock": clock,
        "fields": len(rows),
        "collided": sum(r["collisions"] > 0 for r in rows),
        "min_clearance": min(clear, default=math.inf),
        "min_interagent_distance": min((r["min_interagent_distance"] for r in rows), default=0.0),
        "below_guard": sum(
            r["min_clearance"] is not None and r["min_clearance"] < r["rho"] - 1e-9 for r in rows
        ),
        "below_separation": sum(
            r["min_interagent_distance"] < r["separation"] - 1e-9 for r in rows
        ),
        "actuator_corrections": sum(r["actuator_corrections"] for r in rows),
        "safety_layer": str(SafetyLayer.of(layer, Clock(clock))),
        "layer_standing": sum(r.get("layer_standing") or 0 for r in rows),
        "referee_would_correct": sum(r["referee_would_correct"] or 0 for r in rows),
        "referee_largest_change": max(
            (r["referee_largest_change"] or 0.0 for r in rows), default=0.0
        ),
        "arrived": sum(bool(r["arrived"]) for r in rows),
        "arrival_time_p50": _median(r.get("arrival_time") for r in rows if r["arrived"]),
        "missed_deadlines": sum(r["missed_deadlines"] for r in rows),
        "inexact": sum(r["exact"] is False for r in rows),
        "lost_agents": sum(len(r["lost"]) for r in rows),
        "agent_at_fault": sum(r["agent_at_fault"] for r in rows),
        "obstacle_at_fault": sum(r["obstacle_at_fault"] for r in rows),
        "rows": rows,
    }


def _median(values: Iterable[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return statistics.median(known) if known else None


def render_swarms(rep: dict[str, Any]) -> str:
    return (
        f"{rep['fields']} inside fields as distributed swarms ({rep['clock']}): "
        f"{rep['collided']} collided; min clearance {rep['min_clearance']:.3f} m "
        f"({rep['below_guard']} fields below ρ), min separation "
        f"{rep['min_interagent_distance']:.3f} m ({rep['below_separation']} below 2R); "
        + (
            f"referee: {rep['actuator_corrections']} commands corrected"
            if rep["safety_layer"] == SafetyLayer.REFEREE
            else (
                f"each robot's own layer: {rep['actuator_corrections']} commands changed, "
                f"{rep['layer_standing']} robot-ticks standing for a snapshot"
                if rep["safety_layer"] == SafetyLayer.ONBOARD
                else "no safety layer"
            )
            + f" (no referee: it would have changed {rep['referee_would_correct']} "
            f"commands, by up to {rep['referee_largest_change']:.3f} m/s)"
        )
        + f", missed deadlines {rep['missed_deadlines']}; {rep['arrived']} arrived"
        + (
            f" (median time to goal {rep['arrival_time_p50']:.2f} s)"
            if rep.get("arrival_time_p50") is not None
            else ""
        )
        + (f", {rep['inexact']} not bit-exact" if rep["clock"] == Clock.LOCKSTEP else "")
        + (f", {rep['lost_agents']} agent processes lost" if rep["lost_agents"] else "")
        + (
            f"; contacts with people: {rep['agent_at_fault']} agent at fault, "
            f"{rep['obstacle_at_fault']} person at fault"
            if any(r["min_mover_clearance"] is not None for r in rep["rows"])
            else ""
        )
    )
