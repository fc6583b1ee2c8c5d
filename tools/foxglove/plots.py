"""The scalar channels for Foxglove's Plot panel: formation error, distances, clearance, σ, Ω,
the safety filter's activity, and (in the exported views) how each agent tracked its command.

Each message has ``tick``, ``t`` (simulated seconds, for a Plot whose x axis is a message path)
and a headline ``value``; ``agents`` (or ``edges``) break it down, to be picked out in a Plot
path with a filter such as ``.agents[:]{id==3}.value``. The numbers come from world/metrics.py
(the same functions as the run's summary), applied to the tick records as the world logged them.

The schemas are shoal's own (``shoal.*``), in the subset of JSON Schema Foxglove's decoder reads:
objects with typed properties, arrays of numbers or objects, no nulls; so a channel that would
have nothing to say (clearance without obstacles, the filter's activity where there is no
filter) is not written at all: :func:`topics_of` names the channels a scenario has.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from shoal.bus.messages import PlantRecord, TickRecord
from shoal.bus.types import Safety
from shoal.tools.foxglove.msgs import Json
from shoal.world.metrics import clearances, formation_errors, pair_distances
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory
from shoal.world.unicycle import Lookahead

DIGITS = 6  # µm: finer than any distance the run resolves, and short JSON

FORMATION_ERROR = "/shoal/metrics/formation_error"
DISTANCE = "/shoal/metrics/distance"
CLEARANCE = "/shoal/metrics/clearance"
SIGMA = "/shoal/metrics/sigma"
OMEGA = "/shoal/metrics/omega"
FILTER = "/shoal/metrics/filter"
TRACKING = "/shoal/metrics/tracking"  # exported views only: it needs the next tick's positions
PLANT = "/shoal/plant"  # exported views of a physics run only (the log's plant records)


def _number(description: str) -> Json:
    return {"type": "number", "description": description}


def _integer(description: str) -> Json:
    return {"type": "integer", "description": description}


def _schema(name: str, description: str, item: Json | None = None, **fields: Json) -> Json:
    props: Json = {
        "tick": _integer("tick k of the run"),
        "t": _number("simulated time k·dt, s"),
        **fields,
    }
    if item is not None:
        props["agents"] = {"type": "array", "items": _object(item), "description": "per agent"}
    return {"title": name, "description": description, **_object(props)}


def _object(props: Json) -> Json:
    return {"type": "object", "properties": props, "required": list(props)}


SCHEMAS: dict[str, Json] = {
    "shoal.FormationError": _schema(
        "shoal.FormationError",
        "Formation error ‖s_i − s_1 − R(θ_i)δ_i/σ_i‖_∞ of the followers (world/metrics.py)",
        {"id": _integer("follower id"), "value": _number("its formation error, m")},
        value=_number("largest formation error over the followers, m"),
        tolerance=_number("convergence tolerance of the scenario, m"),
    ),
    "shoal.Distance": _schema(
        "shoal.Distance",
        "Distances between agents' centres",
        value=_number("smallest distance over every pair of agents, m"),
        limit=_number("two agents closer than this collide (2 × agent_radius), m"),
        closest=_object({"a": _integer("agent id"), "b": _integer("agent id")}),
        edges={
            "type": "array",
            "items": _object(
                {
                    "a": _integer("agent id"),
                    "b": _integer("agent id"),
                    "value": _number("distance between the edge's ends, m"),
                }
            ),
            "description": "per edge of the sensing graph",
        },
    ),
    "shoal.Clearance": _schema(
        "shoal.Clearance",
        "Distance from agents' centres to obstacles' edges",
        {
            "id": _integer("agent id"),
            "value": _number("its clearance to the nearest obstacle, m"),
            "obstacle": _integer("that obstacle's index (0-based, scenario order)"),
        },
        value=_number("smallest clearance over every agent and obstacle, m"),
        limit=_number("an agent this close to an obstacle collides (agent_radius), m"),
    ),
    "shoal.Sigma": _schema(
        "shoal.Sigma",
        "Contraction factor σ (Algorithm 1) and rotation θ each agent applies",
        {
            "id": _integer("agent id"),
            "value": _number("σ applied"),
            "bid": _number("σ bid announced (Algorithm 1)"),
            "theta": _number("rotation θ applied, rad"),
        },
        value=_number("largest σ applied"),
    ),
    "shoal.Omega": _schema(
        "shoal.Omega",
        "Evasion flags Ω_i (Algorithm 2)",
        {"id": _integer("agent id"), "value": _integer("1 while evading (Ω_i), else 0")},
        value=_integer("number of agents evading"),
        alive=_integer("number of agents whose process is up"),
    ),
    "shoal.Filter": _schema(
        "shoal.Filter",
        "Safety filter activity: the agents whose filter changed their nominal command this "
        "tick (docs/safety.md)",
        {"id": _integer("agent id"), "value": _integer("1 if its filter changed its command")},
        value=_integer("number of agents whose filter changed their command"),
        fraction=_number("that number over all agents (its mean is the summary's filter_activity)"),
    ),
    "shoal.Tracking": _schema(
        "shoal.Tracking",
        "Commanded against achieved velocity: each agent's point over the tick, as its plant "
        "moved it (the world's kinematics exactly; robots with mass lag: docs/physics.md)",
        {
            "id": _integer("agent id"),
            "value": _number("|achieved − commanded| velocity, m/s"),
            "commanded": _number("commanded speed, m/s"),
            "achieved": _number("achieved speed over the tick, m/s"),
        },
        value=_number("largest |achieved − commanded| velocity over the agents, m/s"),
    ),
    "shoal.Plant": _schema(
        "shoal.Plant",
        "A physics plant's robots as the engine moved them, at the tick's end (docs/physics.md)",
        {
            "id": _integer("agent id"),
            "value": _number("its body's speed, m/s"),
            "turn_rate": _number("its yaw rate, rad/s (0 in 3-D)"),
            "contacts": _integer("contacts the engine reported for it during the tick"),
            "motors": {
                "type": "array",
                "items": _object(
                    {
                        "index": _integer("the motor's index on the robot (left, right; x, y, z)"),
                        "speed": _number("its joint's speed: a wheel's rad/s, a slide's m/s"),
                        "effort": _number("what it applied: N·m or N"),
                    }
                ),
                "description": "the robot's motors",
            },
        },
        value=_integer("contacts the engine reported during the tick"),
    ),
}

TOPICS = {
    FORMATION_ERROR: "shoal.FormationError",
    DISTANCE: "shoal.Distance",
    CLEARANCE: "shoal.Clearance",
    SIGMA: "shoal.Sigma",
    OMEGA: "shoal.Omega",
    FILTER: "shoal.Filter",
}


def topics_of(scenario: Scenario) -> dict[str, str]:
    """The scalar channels ``scenario``'s runs have (topic → schema name): no distance for a
    lone agent, no clearance without obstacles, no filter activity without the filter."""
    absent = {
        DISTANCE: scenario.n < 2,
        CLEARANCE: not scenario.obstacles,
        FILTER: scenario.control.safety != Safety.FILTER,
    }
    return {t: name for t, name in TOPICS.items() if not absent.get(t, False)}


def trajectory_of(
    records: Sequence[TickRecord], dt: float, lookahead: Lookahead | None = None
) -> Trajectory:
    """The records as a Trajectory (world/metrics.py's input); the row after the last record is
    integrated as the world does."""
    return Trajectory.from_records(records, dt, lookahead)


def plots(scenario: Scenario, records: Sequence[TickRecord]) -> list[dict[str, Json]]:
    """For each record, its message on every scalar topic (topic → message)."""
    if not records:
        return []
    s, traj = scenario, trajectory_of(records, scenario.dt, scenario.lookaheads)
    rows = len(records)
    errors = _rounded(formation_errors(s, traj) if s.n > 1 else np.zeros((rows, 0)))
    pairs = _rounded(pair_distances(traj)[:-1]) if s.n > 1 else None
    clear = clearances(s, traj)[:-1] if s.obstacles else None
    nearest = clear.argmin(axis=2).tolist() if clear is not None else None
    clear_m = _rounded(clear.min(axis=2)) if clear is not None else None
    pair_list = list(itertools.combinations(range(s.n), 2))  # pair_distances' column order
    index = {pair: k for k, pair in enumerate(pair_list)}
    edge_columns = [index[min(a, b) - 1, max(a, b) - 1] for a, b in s.edges]
    tolerance = round(s.tolerance, DIGITS)
    filtering = s.control.safety == Safety.FILTER
    out = []
    for k, r in enumerate(records):
        head = {"tick": r.tick, "t": round(r.tick * s.dt, DIGITS)}
        msgs: dict[str, Json] = {
            FORMATION_ERROR: {
                **head,
                "value": max(errors[k], default=0.0),
                "tolerance": tolerance,
                "agents": [{"id": i + 2, "value": e} for i, e in enumerate(errors[k])],
            },
            SIGMA: {
                **head,
                "value": max(r.sigma),
                "agents": [
                    {"id": i + 1, "value": sig, "bid": bid, "theta": round(th, DIGITS)}
                    for i, (sig, bid, th) in enumerate(zip(r.sigma, r.bid, r.theta, strict=True))
                ],
            },
            OMEGA: {
                **head,
                "value": sum(r.omega),
                "alive": sum(r.alive),
                "agents": [{"id": i + 1, "value": int(w)} for i, w in enumerate(r.omega)],
            },
        }
        if filtering:
            acted = sum(r.filtered)
            msgs[FILTER] = {
                **head,
                "value": acted,
                "fraction": round(acted / s.n, DIGITS),
                "agents": [{"id": i + 1, "value": int(f)} for i, f in enumerate(r.filtered)],
            }
        if pairs is not None:
            row = pairs[k]
            closest = min(range(len(row)), key=row.__getitem__)
            a, b = pair_list[closest]
            msgs[DISTANCE] = {
                **head,
                "value": row[closest],
                "limit": 2 * s.agent_radius,
                "closest": {"a": a + 1, "b": b + 1},
                "edges": [
                    {"a": ea, "b": eb, "value": row[c]}
                    for (ea, eb), c in zip(s.edges, edge_columns, strict=True)
                ],
            }
        if clear_m is not None and nearest is not None:
            msgs[CLEARANCE] = {
                **head,
                "value": min(clear_m[k]),
                "limit": s.agent_radius,
                "agents": [
                    {"id": i + 1, "value": c, "obstacle": o}
                    for i, (c, o) in enumerate(zip(clear_m[k], nearest[k], strict=True))
                ],
            }
        out.append(msgs)
    return out


def _rounded(a: Any) -> list[list[float]]:
    """Rows of plain floats rounded to µm, all at once (numpy), for the JSON."""
    return list(np.round(np.asarray(a, dtype=np.float64), DIGITS).tolist())


def tracking(
    scenario: Scenario, records: Sequence[TickRecord], after: Sequence[Sequence[float]] | None
) -> list[Json]:
    """For each of ``records`` (consecutive ticks), its message on :data:`TRACKING`: each
    agent's achieved velocity over the tick, from where the next record has it (``after``: the
    positions of the tick after the last, None at the run's end: integrated from its command
    as the log's readers do) against the one commanded."""
    dt = scenario.dt
    start = np.asarray([r.positions for r in records], dtype=np.float64)
    commanded = np.asarray([r.velocities for r in records], dtype=np.float64)
    last = start[-1] + dt * commanded[-1] if after is None else np.asarray(after, dtype=np.float64)
    achieved = (np.concatenate([start[1:], last[None]]) - start) / dt
    gap = _rounded(np.linalg.norm(achieved - commanded, axis=-1))
    asked = _rounded(np.linalg.norm(commanded, axis=-1))
    got = _rounded(np.linalg.norm(achieved, axis=-1))
    return [
        {
            "tick": r.tick,
            "t": round(r.tick * dt, DIGITS),
            "value": max(gap[k]),
            "agents": [
                {"id": i + 1, "value": e, "commanded": c, "achieved": a}
                for i, (e, c, a) in enumerate(zip(gap[k], asked[k], got[k], strict=True))
            ],
        }
        for k, r in enumerate(records)
    ]


def plant_message(scenario: Scenario, r: PlantRecord) -> Json:
    """A physics plant's record of a tick on :data:`PLANT`: each robot's speed, yaw rate,
    contacts and motors (a wheeled robot's two, a base's one per axis, in agent order)."""
    s = scenario
    ell = s.lookaheads
    counts = [2 if ell is not None and ell[i] > 0 else s.dim for i in range(s.n)]
    starts = list(itertools.accumulate(counts, initial=0))
    touched = [0] * s.n
    for agent, other, _depth in r.contacts:
        for who in {int(agent), int(other)}:
            if 1 <= who <= s.n:
                touched[who - 1] += 1
    speeds = _rounded([np.linalg.norm(np.asarray(r.velocities), axis=-1)])[0]
    turns = [round(x, DIGITS) for x in r.turn_rates] or [0.0] * s.n
    agents = []
    for i in range(s.n):
        span = range(starts[i], starts[i + 1])
        motors = [
            {"index": j - starts[i], "speed": round(r.motor_speeds[j], DIGITS),
             "effort": round(r.motor_efforts[j], DIGITS)}
            for j in span if j < len(r.motor_speeds)
        ]  # fmt: skip
        agents.append({"id": i + 1, "value": speeds[i], "turn_rate": turns[i],
                       "contacts": touched[i], "motors": motors})  # fmt: skip
    return {"tick": r.tick, "t": round(r.tick * s.dt, DIGITS), "value": len(r.contacts),
            "agents": agents}  # fmt: skip
