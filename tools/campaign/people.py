"""The people campaign: random fields with pedestrians crossing the formation's path
(`shoal campaign --people N`, docs/campaign.md and docs/people.md).

Each field is an inside field of the obstacle campaign (tools/campaign/fields.py) with N people
added after CrowdNav's circle-crossing test: they start spread round a circle whose centre is a
point of the leader's path, each heading for the opposite point of it, and the circle's radius
is what they walk until the formation reaches that point, so people and robots meet there.
A person is ``reactive`` (social force, giving way to robots and each other: world/movers.py)
or ``blind`` (a constant velocity through the circle's centre and on, seeing nobody). The
same field is also run without its people, for the time to goal it would have taken.

Judged: every contact between an agent and a person, by fault (world/contacts.py: the agent
moved towards the person during it, or stood or moved away); collisions of any other kind;
success (the leader at its goal and the formation settled at the end); the time to goal
against the field without people; the filter's activity and stalls.
"""

from __future__ import annotations

import dataclasses
import math
import time
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import yaml

from shoal.geometry.path import path_position
from shoal.geometry.vectors import segment_distance
from shoal.tools.campaign.fields import FieldOptions, make_field, makes_unicycles
from shoal.tools.simulator import simulate
from shoal.world.contacts import Contact, contacts
from shoal.world.errors import ScenarioError, WorldError
from shoal.world.loader import parse_scenario
from shoal.world.metrics import formation_errors, summarize
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory

PERSON_RADIUS = 0.3  # m, CrowdNav's
MODELS = ("reactive", "blind")


@dataclass(frozen=True)
class PeopleOptions:
    """count people per field walking at ``speed`` m/s (preferred; u_max 1.3× for reactive
    people; blind ones walk at exactly that speed, their u_max); ``agent_speed``: the robots'
    speed limit, m/s (the base's, if it sets one, is replaced: it must beat u_max); ``extra``:
    seconds added to every field for the formation to finish after the crowd; ``tries``:
    draws per field."""

    count: int = 5
    speed: float = 1.0
    model: str = "reactive"
    agent_speed: float = 3.0
    extra: float = 5.0
    tries: int = 200


@dataclass(frozen=True)
class PeopleTask:
    base: str
    base_name: str
    seed: int
    fields: FieldOptions
    people: PeopleOptions


@dataclass(frozen=True)
class PeopleOutcome:
    """One field with people. Times in s (None: never at goal), distances in m."""

    seed: int
    name: str
    contacts: tuple[dict[str, Any], ...] = ()
    agent_at_fault: int = 0
    obstacle_at_fault: int = 0
    other_collisions: int = 0  # agent–agent and agent–standing obstacle
    min_person_clearance: float = math.inf
    success: bool = False
    static_success: bool = False
    time_to_goal: float | None = None
    static_time: float | None = None
    filter_activity: float = 0.0
    stalls: int = 0
    longest_stall: float = 0.0
    seconds: float = 0.0
    dt: float = 0.0  # the field's tick (unicycles may run a finer one than the base's)
    error: str | None = None
    source: str = field(default="", repr=False)


def add_people(base: Scenario, seed: int, fields: FieldOptions, opts: PeopleOptions) -> Scenario:
    """Inside field ``seed`` around ``base`` with ``opts.count`` people crossing its path; the
    same inputs always give the same field, and its ``source`` reproduces it."""
    if makes_unicycles(base, fields):  # made, and ticked, for the robots' speed limit
        fields = dataclasses.replace(fields, speed_limit=opts.agent_speed)
    plain = make_field(base, seed, "inside", fields)
    data = yaml.safe_load(plain.source)
    data["duration"] = float(data["duration"]) + opts.extra
    data["control"]["speed_limit"] = opts.agent_speed
    rng = np.random.default_rng([seed, zlib.crc32(f"people-{opts.model}".encode())])
    moving = plain.duration - fields.tail
    for _ in range(opts.tries):
        people = _draw_crowd(plain, moving, rng, opts)
        if people is None:
            continue
        data["obstacles"] = [*data.get("obstacles", []), *people]
        text = _header(plain, seed, opts) + yaml.safe_dump(data, sort_keys=False)
        try:
            return parse_scenario(text)
        except ScenarioError:
            data["obstacles"] = data["obstacles"][: len(data["obstacles"]) - len(people)]
    raise WorldError(f"{plain.name}: no crowd of {opts.count} fitted in {opts.tries} tries")


def without_people(s: Scenario) -> Scenario:
    """The same field with its moving obstacles taken out (the static-field comparison)."""
    data = yaml.safe_load(s.source)
    data["obstacles"] = [o for o in data.get("obstacles", []) if "moves" not in o]
    return parse_scenario(yaml.safe_dump(data, sort_keys=False), default_name=f"{s.name}-static")


def _header(plain: Scenario, seed: int, opts: PeopleOptions) -> str:
    return (
        f"# A field of `shoal campaign --people {opts.count} --people-speed {opts.speed:g} "
        f"--people-model {opts.model}` (tools/campaign/people.py), seed {seed}.\n"
        f"# {plain.name} with people crossing the formation's path.\n"
        "# Reproduce: shoal simulate THIS_FILE\n"
    )


def _draw_crowd(
    s: Scenario, moving: float, rng: np.random.Generator, opts: PeopleOptions
) -> list[dict[str, Any]] | None:
    """One crowd for field ``s`` (None if it does not fit): a meeting time and point on the
    leader's path, a circle round it that people walk in the time until then, one person per
    random angle (apart by their bodies), each to the opposite point, ±0.5 m."""
    dim, rho = s.dim, s.control.safety_margin
    meet = float(rng.uniform(min(3.0, moving / 2), moving))
    centre = path_position(s.path, meet)
    radius = max(opts.speed * meet, 3.0)
    starts: list[np.ndarray] = []
    goals: list[np.ndarray] = []
    people: list[dict[str, Any]] = []
    slots = _final_slots(s)
    for _ in range(opts.count):
        for _ in range(50):
            angle = float(rng.uniform(0.0, 2.0 * math.pi))
            way = np.zeros(dim)
            way[:2] = math.cos(angle), math.sin(angle)
            start = centre + radius * way + rng.uniform(-0.5, 0.5, size=dim) * _plane(dim)
            goal = centre - radius * way + rng.uniform(-0.5, 0.5, size=dim) * _plane(dim)
            walk = opts.speed * s.duration  # how far a blind walker goes in the run
            if _fits(
                s,
                start,
                goal,
                starts,
                goals,
                slots,
                rho,
                blind=walk if opts.model == "blind" else 0.0,
            ):
                break
        else:
            return None
        starts.append(start)
        goals.append(goal)
        where, to = [round(float(x), 3) for x in start], [round(float(x), 3) for x in goal]
        if opts.model == "blind":  # straight on at constant velocity, through the circle and on
            heading = (goal - start) / np.linalg.norm(goal - start)
            velocity = [round(float(x), 6) for x in opts.speed * heading]
            moves: dict[str, Any] = {"kind": "drift", "velocity": velocity}
        else:
            moves = {"kind": "person", "goals": [to], "speed": opts.speed}
        people.append({"centre": where, "radius": PERSON_RADIUS, "moves": moves})
    return people


def _plane(dim: int) -> np.ndarray:
    """Jitter only in the ground plane (people walk on the floor in 3-D too)."""
    out = np.ones(dim)
    out[2:] = 0.0
    return out


def _final_slots(s: Scenario) -> np.ndarray:
    return np.asarray([path_position(s.path, s.duration) + np.asarray(a.offset) for a in s.agents])


def _fits(
    s: Scenario,
    start: np.ndarray,
    goal: np.ndarray,
    starts: list[np.ndarray],
    goals: list[np.ndarray],
    slots: np.ndarray,
    rho: float,
    *,
    blind: float,
) -> bool:
    """Apart from the agents' starts and final slots by a guard and a metre (the formation can
    start and settle), from the other people by their bodies and 0.2 m, from standing obstacles;
    a blind walker's straight line, ``blind`` m long from its start, misses every standing
    obstacle too."""
    keep = PERSON_RADIUS + rho + 1.0
    if np.linalg.norm(s.initial_positions - start, axis=1).min() <= keep:
        return False
    if np.linalg.norm(slots - goal, axis=1).min() <= keep:
        return False
    for other in (*starts, *goals):
        if (
            min(np.linalg.norm(other - start), np.linalg.norm(other - goal))
            <= 2 * PERSON_RADIUS + 0.2
        ):
            return False
    for o in s.standing:
        c = np.asarray(o.centre)
        room = o.radius + PERSON_RADIUS + 0.2
        if min(np.linalg.norm(c - start), np.linalg.norm(c - goal)) <= room:
            return False
        if blind:
            far = start + (goal - start) * (blind / float(np.linalg.norm(goal - start)))
            if segment_distance(c, start, far) <= room:
                return False
    return True


def time_to_goal(s: Scenario, traj: Trajectory) -> float | None:
    """s: the first time the leader is within tolerance of its path's end and every follower
    within tolerance of its slot (None if never)."""
    worst = formation_errors(s, traj).max(axis=1)
    end = path_position(s.path, s.duration)
    leader = np.linalg.norm(traj.positions[:-1, 0] - end, axis=1)
    at = np.flatnonzero((leader <= s.tolerance) & (worst <= s.tolerance))
    return float(at[0] * s.dt) if at.size else None


def run_people_task(task: PeopleTask) -> PeopleOutcome:
    """Draw one field with people, run it and its static twin (in a worker process)."""
    started = time.process_time()
    base = parse_scenario(task.base, default_name=task.base_name)
    try:
        crowded = add_people(base, task.seed, task.fields, task.people)
    except WorldError as exc:
        return PeopleOutcome(task.seed, "", error=str(exc))
    traj = simulate(crowded)
    summary = summarize(crowded, traj)
    calm = without_people(crowded)
    calm_traj = simulate(calm)
    calm_summary = summarize(calm, calm_traj)
    touches = contacts(crowded, traj)
    success = summary.leader_shortfall <= crowded.tolerance and (
        summary.final_formation_error <= crowded.tolerance
    )
    outcome = PeopleOutcome(
        seed=task.seed,
        name=crowded.name,
        contacts=tuple(_contact_row(c) for c in touches),
        agent_at_fault=summary.agent_at_fault,
        obstacle_at_fault=summary.obstacle_at_fault,
        other_collisions=summary.collisions - summary.agent_at_fault,
        min_person_clearance=summary.min_mover_clearance or math.inf,
        success=success,
        static_success=calm_summary.leader_shortfall <= calm.tolerance
        and calm_summary.final_formation_error <= calm.tolerance,
        time_to_goal=time_to_goal(crowded, traj),
        static_time=time_to_goal(calm, calm_traj),
        filter_activity=summary.filter_activity,
        stalls=summary.stalls,
        longest_stall=summary.longest_stall,
        seconds=time.process_time() - started,
        dt=crowded.dt,
    )
    if touches or not success or summary.collisions:
        outcome = dataclasses.replace(outcome, source=crowded.source)
    return outcome


def _contact_row(c: Contact) -> dict[str, Any]:
    return {
        "agent": c.agent, "obstacle": c.obstacle, "tick": c.start, "ticks": c.ticks,
        "closest": c.closest, "approach": c.approach, "fault": c.fault,
    }  # fmt: skip


def people_report(
    outcomes: list[PeopleOutcome], opts: PeopleOptions, wall: float, jobs: int
) -> dict[str, Any]:
    """The people campaign as one JSON-able dict, every contact listed with its fault."""
    ran = [o for o in outcomes if o.error is None]
    ratios = [
        o.time_to_goal / o.static_time
        for o in ran
        if o.time_to_goal is not None and o.static_time not in (None, 0.0)
    ]
    return {
        "people": opts.count,
        "speed": opts.speed,
        "model": opts.model,
        "agent_speed": opts.agent_speed,
        "fields": len(ran),
        "not_drawn": len(outcomes) - len(ran),
        "agent_at_fault": sum(o.agent_at_fault for o in ran),
        "obstacle_at_fault": sum(o.obstacle_at_fault for o in ran),
        "fields_with_contact": sum(bool(o.contacts) for o in ran),
        "other_collisions": sum(o.other_collisions for o in ran),
        "min_person_clearance": min((o.min_person_clearance for o in ran), default=None),
        "success": sum(o.success for o in ran),
        "static_success": sum(o.static_success for o in ran),
        "time_ratio": _spread(ratios),
        "never_at_goal": sum(o.time_to_goal is None for o in ran),
        "filter_activity": float(np.mean([o.filter_activity for o in ran])) if ran else 0.0,
        "stalled_fields": sum(o.stalls > 0 for o in ran),
        "stalls": sum(o.stalls for o in ran),
        "longest_stall": max((o.longest_stall for o in ran), default=0.0),
        "wall_s": round(wall, 2),
        "jobs": jobs,
        "cpu_s_per_field": round(sum(o.seconds for o in outcomes) / max(1, len(outcomes)), 3),
        "dt": sorted({o.dt for o in ran}),
        "contacts": [{"seed": o.seed, "name": o.name, **c} for o in ran for c in o.contacts],
        "unsuccessful": [o.seed for o in ran if not o.success],
        "errors": [{"seed": o.seed, "error": o.error} for o in outcomes if o.error],
    }


def _spread(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"p50": None, "p95": None, "max": None}
    q = np.quantile(np.asarray(values), [0.5, 0.95])
    return {"p50": float(q[0]), "p95": float(q[1]), "max": float(max(values))}


CONTACTS_SHOWN = 30


def render_people(rep: dict[str, Any]) -> str:
    fields = max(rep["fields"], 1)
    ratio = rep["time_ratio"]

    def num(x: float | None, digits: int = 3) -> str:
        return "—" if x is None else f"{x:.{digits}f}"

    lines = [
        f"{rep['fields']} fields, {rep['people']} {rep['model']} people at "
        f"{rep['speed']:g} m/s each, robots ≤ {rep['agent_speed']:g} m/s",
        f"contacts with people   {rep['agent_at_fault']} agent at fault, "
        f"{rep['obstacle_at_fault']} person at fault ({rep['fields_with_contact']} fields); "
        f"other collisions {rep['other_collisions']}",
        f"least clearance        {num(rep['min_person_clearance'])} m to a person's edge",
        f"success                {rep['success']} of {rep['fields']} "
        f"({100 * rep['success'] / fields:.1f} %; without the people "
        f"{rep['static_success']})",
        f"time to goal / static  p50 {num(ratio['p50'], 2)}, p95 {num(ratio['p95'], 2)}, "
        f"max {num(ratio['max'], 2)} ({rep['never_at_goal']} never at goal)",
        f"safety filter          active {100 * rep['filter_activity']:.2f} % of agent-ticks, "
        f"{rep['stalls']} stalls in {rep['stalled_fields']} fields "
        f"(longest {rep['longest_stall']:.2f} s)",
        f"{rep['fields']} fields on {rep['jobs']} processes in {rep['wall_s']:.1f} s "
        f"({rep['cpu_s_per_field']} CPU s per field, with its static twin)",
    ]
    if rep.get("kinematics") == "unicycle":
        ticks = ", ".join(f"{dt:g}" for dt in rep["dt"])
        lines.insert(
            1,
            f"robots                 unicycles, dt {ticks} s (a contact: the body's "
            "reach about its point's chord; fault: the point moved towards the person)",
        )
    if rep["contacts"]:
        lines.append("contacts (fault: agent = it moved towards the person):")
    for c in rep["contacts"][:CONTACTS_SHOWN]:
        lines.append(
            f"  seed {c['seed']:>6}: agent {c['agent']} – obstacle {c['obstacle']} at tick "
            f"{c['tick']} for {c['ticks']} ticks, closest {c['closest']:.3f} m, fault "
            f"{c['fault']}"
        )
    if len(rep["contacts"]) > CONTACTS_SHOWN:
        lines.append(f"  … and {len(rep['contacts']) - CONTACTS_SHOWN} more (--json lists all)")
    if rep["unsuccessful"]:
        shown = ", ".join(map(str, rep["unsuccessful"][:20]))
        more = " …" if len(rep["unsuccessful"]) > 20 else ""
        lines.append(f"unsuccessful seeds: {shown}{more}")
    for e in rep["errors"]:
        lines.append(f"not drawn: seed {e['seed']}: {e['error']}")
    return "\n".join(lines)
