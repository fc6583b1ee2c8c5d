"""The campaign's report: per set of fields, then every field that collided or lagged.

One JSON-able dict (:func:`report`) and the text a person reads (:func:`render`). Distances in m,
times in s; a set is the inside fields, or the fields breaking one assumption, each with the
filter or (``SET/paper``) without.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shoal.bus.types import SafetyLayer
from shoal.tools.campaign.fields import BREACHES, REFUSED, plant_option
from shoal.tools.campaign.hard import HARD_MODES
from shoal.tools.campaign.runner import Outcome
from shoal.world.arrival import CAUSES
from shoal.world.plant import KINEMATICS


def _quantiles(values: Iterable[float]) -> dict[str, float | None]:
    v = np.asarray([x for x in values if math.isfinite(x)])
    if not v.size:
        return {"min": None, "p01": None, "p05": None, "p50": None}
    q = np.quantile(v, [0.01, 0.05, 0.5])
    return {"min": float(v.min()), "p01": float(q[0]), "p05": float(q[1]), "p50": float(q[2])}


def _least(values: Iterable[float]) -> float | None:
    finite = [x for x in values if math.isfinite(x)]
    return min(finite) if finite else None


def summarize_set(outcomes: Sequence[Outcome]) -> dict[str, Any]:
    """The figures of one set of fields (all inside, or all breaking the same thing)."""
    ran = [o for o in outcomes if o.error is None]
    bounded = [o for o in ran if math.isfinite(o.convergence_bound) and o.convergence_bound > 0]
    ratios = [
        o.convergence_time / o.convergence_bound for o in bounded if o.convergence_time is not None
    ]
    causes = Counter(o.not_arrived for o in ran if not o.arrived)
    physics = any(o.plant != KINEMATICS for o in ran)
    reach = any(o.reach_brakes is not None for o in ran)
    return {
        "fields": len(ran),
        "not_drawn": len(outcomes) - len(ran),
        "collided": sum(o.collided for o in ran),
        # the engine does not say which kind a collision was
        "obstacle_collided": None if physics else sum(o.obstacle_collisions > 0 for o in ran),
        "agent_collided": None if physics else sum(o.agent_collisions > 0 for o in ran),
        "collisions": sum(o.collisions for o in ran),
        "min_clearance": _quantiles(o.min_clearance for o in ran),
        "min_interagent_distance": _quantiles(o.min_interagent_distance for o in ran),
        "guard_margin": _least(o.guard_margin for o in ran),
        "separation_margin": _least(o.separation_margin for o in ran),
        "converged": sum(o.convergence_time is not None for o in ran),
        "unbounded": len(ran) - len(bounded),  # Theorem 1 gives no bound (|f| ≥ β)
        "converged_within_bound": sum(r <= 1.0 for r in ratios),
        "max_time_over_bound": max(ratios) if ratios else None,
        "settled_at_end": sum(o.final_formation_error <= o.tolerance for o in ran),
        "contracted": sum(o.sigma > 1.0 for o in ran),
        "a3_broken_by_contraction": sum(o.a3_contracted for o in ran),
        "a2_broken_in_run": sum(o.assumption2_violations > 0 for o in ran),
        "omega_episodes": sum(o.omega_episodes for o in ran),
        "filter_activity": float(np.mean([o.filter_activity for o in ran])) if ran else 0.0,
        "at_speed_limit": float(np.mean([o.at_speed_limit for o in ran])) if ran else 0.0,
        "stalled_fields": sum(o.stalls > 0 for o in ran),
        "stalls": sum(o.stalls for o in ran),
        "longest_stall": max((o.longest_stall for o in ran), default=0.0),
        "leader_reached": sum(o.leader_reached for o in ran),
        "arrived": sum(o.arrived for o in ran),
        "arrival_rate": sum(o.arrived for o in ran) / len(ran) if ran else None,
        "not_arrived": {c: causes[c] for c in CAUSES if causes[c]},
        "livelocked_fields": sum(o.livelocks > 0 for o in ran),
        "longest_livelock": max((o.longest_livelock for o in ran), default=0.0),
        "cpu_s": round(sum(o.seconds for o in ran), 2),
        **(engine_figures(ran) if physics else {}),
        **(layer_figures(ran) if physics or reach else {}),
    }


def engine_figures(ran: Sequence[Outcome]) -> dict[str, Any]:
    """A set's figures on robots with mass: the plant and presets; engine contacts (fields
    with any, all, the deepest, m ≤ 0); fields that entered the guard (guard margin < 0) or the
    separation band (separation margin < 0), the worst depths being ``guard_margin`` and
    ``separation_margin``; tracking error, m/s: the medians over fields of each run's median
    and 99th percentile (over its agent-ticks), and the largest anywhere."""
    return {
        "plant": ", ".join(sorted({o.plant for o in ran})),
        "dynamics": ", ".join(sorted({p for o in ran for p in o.dynamics.split(", ") if p})),
        "engine_contact_fields": sum(o.engine_contacts > 0 for o in ran),
        "engine_contacts": sum(o.engine_contacts for o in ran),
        "engine_deepest_contact": min((o.engine_deepest_contact for o in ran), default=0.0),
        "entered_guard": sum(o.guard_margin < 0 for o in ran),
        "entered_separation": sum(o.separation_margin < 0 for o in ran),
        "tracking_error_p50": _median(o.tracking_error_p50 for o in ran),
        "tracking_error_p99": _median(o.tracking_error_p99 for o in ran),
        "tracking_error_max": max(_finite(o.tracking_error_max for o in ran), default=None),
    }


def layer_figures(ran: Sequence[Outcome]) -> dict[str, Any]:
    """A set's figures for the price of its safety layer, where robots have mass or the reach
    layer ran: the layer(s); the reach layer's counts (None under the referee): robot-ticks
    told to stop and the fields with any, agent-ticks slowed (sums), the largest margin any
    certified step needed, m; and the time to goal, s: the median and the largest arrival time
    over the fields that arrived (None: none did)."""
    reached = [o for o in ran if o.reach_brakes is not None]
    times = [o.arrival_time for o in ran if o.arrived and o.arrival_time is not None]
    return {
        "safety_layer": ", ".join(sorted({o.safety_layer for o in ran})),
        "reach_brakes": sum(o.reach_brakes or 0 for o in reached) if reached else None,
        "reach_brake_fields": sum(bool(o.reach_brakes) for o in reached) if reached else None,
        "reach_slowed": sum(o.reach_slowed or 0 for o in reached) if reached else None,
        "reach_largest_margin": max(_finite(o.reach_largest_margin for o in reached), default=None),
        "arrival_time_p50": _median(times),
        "arrival_time_max": max(times, default=None),
    }


def _finite(values: Iterable[float | None]) -> list[float]:
    return [x for x in values if x is not None and math.isfinite(x)]


def _median(values: Iterable[float | None]) -> float | None:
    finite = _finite(values)
    return float(np.median(finite)) if finite else None


def report(outcomes: Sequence[Outcome], wall: float, jobs: int) -> dict[str, Any]:
    """The campaign as one JSON-able dict: per set, then every field that collided, then every
    safe one that lagged (:attr:`Outcome.lagged`).

    ``wall`` s for the whole campaign on ``jobs`` processes; each set's ``cpu_s`` is the CPU
    time its fields took (drawing, simulating, measuring), which a loaded machine inflates less.
    """
    sets: dict[str, Any] = {}
    modes = ("inside", *BREACHES, *HARD_MODES)
    for mode, safety in itertools.product(modes, ("filter", "paper")):
        name = mode if safety == "filter" else f"{mode}/paper"
        chosen = [o for o in outcomes if o.set_name == name]
        if chosen:
            sets[name] = summarize_set(chosen)
            sets[name]["safety"] = safety
            if mode in BREACHES:
                b = BREACHES[mode]
                sets[name]["breaks"] = b.assumption
                sets[name]["static"] = b.static
    failures = [
        {"set": o.set_name, "seed": o.seed, "name": o.name, "obstacle_collisions":
         o.obstacle_collisions, "agent_collisions": o.agent_collisions,
         "min_clearance": o.min_clearance, "min_interagent_distance": o.min_interagent_distance,
         "rerun": ("campaign --rerun" if o.mode in REFUSED else "simulate")
         + plant_option(o.plant, SafetyLayer(o.safety_layer)), "safety": o.safety,
         **({} if o.plant == KINEMATICS else {  # the engine does not split them by kind
             "obstacle_collisions": None, "agent_collisions": None,
             "collisions": o.engine_collisions, "engine_contacts": o.engine_contacts,
             "engine_deepest_contact": o.engine_deepest_contact,
             "guard_margin": o.guard_margin, "separation_margin": o.separation_margin}),
         **({} if o.reach_brakes is None else {
             "safety_layer": o.safety_layer, "reach_brakes": o.reach_brakes,
             "reach_slowed": o.reach_slowed, "reach_largest_margin": o.reach_largest_margin})}
        for o in outcomes if o.error is None and o.collided
    ]  # fmt: skip
    lagging = [
        {"set": o.set_name, "seed": o.seed, "name": o.name, "arrived": o.arrived,
         "not_arrived": o.not_arrived, "arrival_time": o.arrival_time,
         "leader_shortfall": o.leader_shortfall, "slot_distance": o.slot_distance,
         "stalls": o.stalls, "longest_stall": o.longest_stall, "livelocks": o.livelocks,
         "longest_livelock": o.longest_livelock,
         "final_formation_error": o.final_formation_error, "tolerance": o.tolerance,
         "settled": o.final_formation_error <= o.tolerance, "leader_reached": o.leader_reached,
         "safety": o.safety}
        for o in outcomes if o.error is None and not o.collided and o.lagged
    ]  # fmt: skip
    errors = [{"set": o.set_name, "seed": o.seed, "error": o.error} for o in outcomes if o.error]
    return {
        "fields": len(outcomes),
        "jobs": jobs,
        "wall_s": round(wall, 2),
        "fields_per_s": round(len(outcomes) / wall, 2) if wall > 0 else None,
        "cpu_s_per_field": round(sum(o.seconds for o in outcomes) / max(1, len(outcomes)), 3),
        "sets": sets,
        "failures": failures,
        "lagging": lagging,
        "errors": errors,
    }


# Lagging fields listed in the text report; --json lists every one.
LAGGING_SHOWN = 20


def _num(value: Any, digits: int = 3) -> str:
    return "—" if value is None else f"{value:.{digits}f}"


def _int(value: int | None) -> str:
    return "—" if value is None else str(value)


def _seconds(value: float | None) -> str:
    return "—" if value is None else f"{value:.2f} s"


def _rate(part: int, whole: int) -> str:
    return f"{part}/{whole} ({100 * part / whole:.1f} %)" if whole else "—"


# What every column of :func:`render`'s tables means, in the order they are printed.
COLUMNS = (
    ("fields", "fields run in the set"),
    ("collided", "fields with a contact: an overlap deeper than the contact slack, "
     "between ticks too"),
    ("obstacle, agent", "of those, fields with an agent-obstacle / agent-agent contact"),
    ("clearance min, p01, p05, p50", "least distance from an obstacle's edge over all fields, "
     "and its percentiles over fields, m"),
    ("separation min", "least distance between two agents in any field, m"),
    ("guard margin, sep. margin", "least clearance − ρ and least separation − 2R, m (≥ 0 "
     "under the filter's theorem)"),
    ("converged", "fields whose formation error came within the tolerance at some tick"),
    ("≤ bound", "of those, within the Theorem 1 bound; max t/bound: the worst ratio"),
    ("settled", "fields within the tolerance at the last tick"),
    ("σ > 1", "fields where Algorithm 1 contracted the formation"),
    ("A3 by σ", "fields where that contraction brought a desired distance to ≤ 2 r_max "
     "(Assumption 3 under the agreed σ)"),
    ("A2 in run", "fields where, at some tick, an evading agent and all its neighbours evaded "
     "together (Assumption 2 as the paper states it)"),
    ("Ω episodes", "evasive episodes (Algorithm 2), summed over fields"),
    ("filter active", "share of agent-ticks the safety filter changed the command"),
    ("stalled, stalls, longest", "fields / episodes where an agent was held still by the "
     "filter > 0.5 s, and the longest"),
    ("livelocked, longest", "fields where an agent moved without getting closer to its slot "
     "for 10 s, and the longest such stretch"),
    ("leader at goal", "fields whose leader ended within R of its last waypoint"),
    ("arrived", "leader home and every follower within R of its slot, to the end"),
)  # fmt: skip


# The columns of the robots-with-mass table (a physics campaign's only).
ENGINE_COLUMNS = (
    ("engine contacts, fields", "contact onsets the engine reported, and the fields with any"),
    ("deepest", "the deepest penetration in any of them, m"),
    ("in guard, in sep. band", "fields whose guard margin / separation margin went below 0"),
    ("tracking p50, p99, max", "|achieved − commanded| velocity of a point per agent-tick, "
     "m/s: medians over fields of each run's p50 and p99, the largest anywhere"),
)  # fmt: skip


# The columns of the safety layer's price table (robots with mass, or the reach layer).
LAYER_COLUMNS = (
    ("layer", "what stood between the commands and the robots' motion (--safety-layer)"),
    ("brakes, fields", "reach: robot-ticks told to stop (their bounds did not hold), summed, "
     "and the fields with any"),
    ("slowed", "reach: agent-ticks whose speed its braking cap lowered, summed"),
    ("largest margin", "reach: the most any certified step needed, m"),
    ("arrival p50, max", "time to goal of the fields that arrived: median and largest, s"),
)  # fmt: skip


def legend(columns: tuple[tuple[str, str], ...] = COLUMNS) -> str:
    """The columns of :func:`render`'s tables, one line each."""
    width = max(len(name) for name, _ in columns)
    return "\n".join(f"  {name:<{width}}  {what}" for name, what in columns)


def _engine_table(rep: dict[str, Any]) -> list[str]:
    """On robots with mass: per set, the presets, the engine's contacts, the fields that
    entered the guard or the separation band (the depths are the safety table's margins), and
    how well the robots tracked their commands. Nothing for the kinematic plant."""
    sets = {mode: s for mode, s in rep["sets"].items() if "engine_contacts" in s}
    if not sets:
        return []
    rows = [
        f"{'set':<12} {'robots':<16} {'engine contacts':>15} {'fields':>6} {'deepest':>8}   "
        f"{'in guard':>8} {'in sep. band':>12}   {'tracking p50':>12} {'p99':>6} {'max':>6}"
    ]
    for mode, s in sets.items():
        rows.append(
            f"{mode:<12} {s['dynamics']:<16} {s['engine_contacts']:>15} "
            f"{s['engine_contact_fields']:>6} {_num(s['engine_deepest_contact'], 4):>8}   "
            f"{s['entered_guard']:>8} {s['entered_separation']:>12}   "
            f"{_num(s['tracking_error_p50']):>12} {_num(s['tracking_error_p99'], 2):>6} "
            f"{_num(s['tracking_error_max'], 2):>6}"
        )
    return [*rows, ""]


def _layer_table(rep: dict[str, Any]) -> list[str]:
    """Per set, the safety layer's price: the reach layer's brakes, slowed ticks and largest
    margin beside the time to goal (to set against the referee's, and against the engine's
    contacts and margins above). Nothing for a kinematic campaign with the referee."""
    sets = {mode: s for mode, s in rep["sets"].items() if "safety_layer" in s}
    if not sets:
        return []
    rows = [
        f"{'set':<12} {'layer':<8} {'brakes':>7} {'fields':>6} {'slowed':>8} "
        f"{'largest margin':>14}   {'arrived':>18} {'arrival p50':>11} {'max':>8}"
    ]
    for mode, s in sets.items():
        rows.append(
            f"{mode:<12} {s['safety_layer']:<8} {_int(s['reach_brakes']):>7} "
            f"{_int(s['reach_brake_fields']):>6} {_int(s['reach_slowed']):>8} "
            f"{_num(s['reach_largest_margin']):>14}   {_rate(s['arrived'], s['fields']):>18} "
            f"{_seconds(s['arrival_time_p50']):>11} {_seconds(s['arrival_time_max']):>8}"
        )
    return [*rows, ""]


def render(rep: dict[str, Any]) -> str:
    """Three tables a person reads: safety, convergence, liveness; then the fields to look at."""
    safety = [
        f"{'set':<12} {'fields':>6} {'collided':>8} {'obstacle':>8} {'agent':>5}   "
        f"{'clearance min':>13} {'p01':>7} {'p05':>7} {'p50':>7}   {'separation min':>14}   "
        f"{'guard margin':>12} {'sep. margin':>11}"
    ]
    runs = [
        f"{'set':<12} {'converged':>9} {'≤ bound':>7} {'max t/bound':>11} {'settled':>7}   "
        f"{'σ > 1':>5} {'A3 by σ':>7} {'A2 in run':>9} {'Ω episodes':>10}"
    ]
    liveness = [
        f"{'set':<12} {'filter active':>13} {'stalled':>7} {'stalls':>6} {'longest':>8}   "
        f"{'livelocked':>10} {'longest':>8}   {'leader at goal':>14}   {'arrived':>18}"
    ]
    for mode, s in rep["sets"].items():
        clr = s["min_clearance"]
        safety.append(
            f"{mode:<12} {s['fields']:>6} {s['collided']:>8} {_int(s['obstacle_collided']):>8} "
            f"{_int(s['agent_collided']):>5}   {_num(clr['min']):>13} {_num(clr['p01']):>7} "
            f"{_num(clr['p05']):>7} {_num(clr['p50']):>7}   "
            f"{_num(s['min_interagent_distance']['min']):>14}   "
            f"{_num(s['guard_margin'], 4):>12} {_num(s['separation_margin'], 4):>11}"
        )
        runs.append(
            f"{mode:<12} {s['converged']:>9} {s['converged_within_bound']:>7} "
            f"{_num(s['max_time_over_bound']):>11} {s['settled_at_end']:>7}   "
            f"{s['contracted']:>5} {s['a3_broken_by_contraction']:>7} "
            f"{s['a2_broken_in_run']:>9} {s['omega_episodes']:>10}"
        )
        liveness.append(
            f"{mode:<12} {100 * s['filter_activity']:>12.2f}% {s['stalled_fields']:>7} "
            f"{s['stalls']:>6} {s['longest_stall']:>7.2f}s   {s['livelocked_fields']:>10} "
            f"{s['longest_livelock']:>7.2f}s   {s['leader_reached']:>14}   "
            f"{_rate(s['arrived'], s['fields']):>18}"
        )
    lines = [*safety, "", *runs, "", *liveness, "", *_engine_table(rep), *_layer_table(rep)]
    for mode, s in rep["sets"].items():
        if mode in BREACHES and s["safety"] == "filter":
            lines.append(f"{mode:<12} breaks {s['breaks']}: {BREACHES[mode].what}")
    notes = "R: separation/2, the arrival tolerance; distances over whole steps (docs/campaign.md)"
    if any(mode.endswith("/paper") for mode in rep["sets"]):
        notes += "; /paper: the same fields, filter off"
    if any(mode in HARD_MODES for mode in rep["sets"]):
        notes += "; hard/2d, hard/3d: the adversarial generator's fields (--kind hard)"
    if rep.get("kinematics") == "unicycle":
        capped = ", ".join(
            f"{mode} {100 * s.get('at_speed_limit', 0.0):.2f} %" for mode, s in rep["sets"].items()
        )
        notes += (
            "; every agent a unicycle (contacts: the body's reach about its point's chord; the "
            f"point at its speed cap, where the law is cut, in {capped} of agent-ticks)"
        )
    if rep.get("boundary_layer"):
        notes += (
            f"; every field with the boundary layer φ = {rep['boundary_layer']:g}·β·dt, "
            "sat(e/φ) in place of the paper's sign(e)"
        )
    lines.extend(["columns:", legend()])
    if rep.get("plant", KINEMATICS) != KINEMATICS:
        lines.append(legend(ENGINE_COLUMNS))
        latency = rep.get("latency")
        notes += (
            f"; robots with mass: {rep['plant']} ({rep['dynamics']}"
            + ("" if latency is None else f", latency {1000 * latency:g} ms")
            + "): collisions, clearances and margins are the engine's, at every physics step, "
            "not split by kind; the filter's theorem is for robots that move as commanded"
        )
    if any("safety_layer" in s for s in rep["sets"].values()):
        lines.append(legend(LAYER_COLUMNS))
    if rep.get("safety_layer") == SafetyLayer.REACH:
        notes += (
            "; every field through the reach layer (--safety-layer reach): each step certified "
            "from what the robot can reach given its dynamics"
        )
    lines.append(notes)
    lines.append(
        f"{rep['fields']} fields on {rep['jobs']} processes in {rep['wall_s']:.1f} s "
        f"({rep['fields_per_s']} fields/s; {rep['cpu_s_per_field']} CPU s per field)"
    )
    if rep["lagging"]:
        files = [g["file"] for g in rep["lagging"] if g.get("file")]
        where = f"kept in {Path(files[0]).parent}" if files else "--save-lagging DIR keeps them"
        lines.append(f"{len(rep['lagging'])} safe fields to look at ({where}):")
    for g in rep["lagging"][:LAGGING_SHOWN]:
        lines.append(f"  {g['set']:<12} seed {g['seed']:>6}: {'; '.join(_lag(g))}")
    if len(rep["lagging"]) > LAGGING_SHOWN:
        lines.append(f"  … and {len(rep['lagging']) - LAGGING_SHOWN} more (--json lists all)")
    for e in rep["errors"]:
        lines.append(f"not drawn: {e['set']} seed {e['seed']}: {e['error']}")
    return "\n".join(lines)


def _lag(g: dict[str, Any]) -> list[str]:
    """What a lagging field went through, most telling first."""
    what = []
    if not g["arrived"]:
        cause = g["not_arrived"]
        leader = f"leader {g['leader_shortfall']:.2f} m short"
        follower = f"a follower {g['slot_distance']:.2f} m off its slot"
        shown = {"leader trapped": leader, "out of time": f"{leader}, {follower}"}
        what.append(f"not arrived: {cause} ({shown.get(cause, follower)})")
    if g["livelocks"]:
        what.append(f"{g['livelocks']} livelocks, longest {g['longest_livelock']:.2f} s")
    if g["stalls"]:
        what.append(f"{g['stalls']} stalls, longest {g['longest_stall']:.2f} s")
    if not g["settled"]:
        what.append(f"not settled (error {g['final_formation_error']:.3f} m)")
    if not g["leader_reached"] and g["arrived"]:
        what.append("leader short of its goal")
    return what
