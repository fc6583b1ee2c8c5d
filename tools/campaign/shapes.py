"""New scenarios from a formation's shape: ``shoal scenarios new`` (docs/scenarios.md).

A formation of N agents — the leader (agent 1, offset 0) and N − 1 followers — in one of
:data:`SHAPES`, ``spacing`` metres between neighbouring slots, follows a straight waypoint path
along +x. Its graph links every agent to its nearest slots, as few as pass Assumptions 1 and 2
(the leader reaches everyone, and no single evading follower cuts anyone off). Obstacles, if
asked for, are drawn by the campaign's generator (fields.py) so the scenario lies
inside every load-time check. The result is scenario YAML with comments, parsed by the loader
before it is returned: what this writes, ``shoal run`` accepts.

Offsets are in metres in the formation's frame: x along the direction of travel (followers
behind the leader have x < 0), y to the left, z up (3-D). Agents keep z = 0 in 3-D but for the
``grid``, whose second layer flies ``spacing`` higher, so the 3-D shapes are truly 3-D.
"""

from __future__ import annotations

import itertools
import math
import warnings
from typing import Any

import numpy as np
import yaml

from shoal.geometry.vectors import FloatArray
from shoal.tools.campaign.fields import FieldOptions, make_field, unicycle_for
from shoal.world.assumptions import check_graph
from shoal.world.errors import AssumptionError, ScenarioWarning, WorldError
from shoal.world.loader import CONTROL_DEFAULTS, parse_scenario, scenario_from_dict

SHAPES = ("wedge", "line", "column", "grid", "circle")
# s: after the leader stops, time for the formation to close up (the campaign's tail is 5 s).
TAIL = 8.0


class ShapeError(WorldError):
    """The options cannot make a scenario; the message says which and why."""


def offsets(shape: str, n: int, spacing: float, dim: int = 2) -> FloatArray:
    """(n, dim) slots of ``shape``, the leader's (row 0) at the origin, m."""
    if shape not in SHAPES:
        raise ShapeError(f"unknown shape {shape!r} (one of {', '.join(SHAPES)})")
    if n < 2:
        raise ShapeError(f"a formation needs at least 2 agents, got {n}")
    if not spacing > 0:
        raise ShapeError(f"spacing must be > 0 m, got {spacing}")
    if shape == "grid":
        return np.round(_grid(n, spacing, dim), 6)
    out = np.zeros((n, dim))
    if shape == "circle":  # followers on a ring round the leader, ``spacing`` apart
        chord = spacing / (2.0 * math.sin(math.pi / (n - 1))) if n > 2 else spacing
        ring = max(spacing, chord)
        for k in range(1, n):
            phi = math.pi + 2.0 * math.pi * (k - 1) / (n - 1)  # the first one straight behind
            out[k, :2] = (ring * math.cos(phi), ring * math.sin(phi))
        return np.round(out, 6)
    for k in range(1, n):
        rank, side = (k + 1) // 2, 1.0 if k % 2 else -1.0  # 1, 1, 2, 2, …; left, right, …
        if shape == "wedge":  # a V opening backwards
            out[k, :2] = (-spacing * rank, side * spacing * rank)
        elif shape == "line":  # abreast, the leader in the middle
            out[k, :2] = (0.0, side * spacing * rank)
        else:  # column: single file behind the leader
            out[k, 0] = -spacing * k
    return np.round(out, 6)


def _grid(n: int, spacing: float, dim: int) -> FloatArray:
    """Rows of ``cols`` abreast, one behind the other; in 3-D, two layers."""
    layers = 2 if dim == 3 and n >= 4 else 1
    per_layer = math.ceil(n / layers)
    cols = math.ceil(math.sqrt(per_layer))
    slots = []
    for layer, row, col in itertools.product(range(layers), range(per_layer), range(cols)):
        y = (col - (cols - 1) / 2.0) * spacing
        slot = [-row * spacing, y] + ([layer * spacing] if dim == 3 else [])
        slots.append(slot)
    # The leader at the front row's middle (nearest y = 0); the others by distance from it.
    front = min(range(cols), key=lambda c: (abs(c - (cols - 1) / 2.0), c))
    leader = np.asarray(slots[front], dtype=np.float64)
    chosen = sorted(slots, key=lambda p: (float(np.linalg.norm(np.asarray(p) - leader)), p))[:n]
    return np.asarray(chosen, dtype=np.float64) - leader


def nearest_graph(slots: FloatArray, k: int) -> list[tuple[int, int]]:
    """Undirected edges (1-based ids) from every agent to its ``k`` nearest slots (ties by id)."""
    n = slots.shape[0]
    edges: set[tuple[int, int]] = set()
    for i in range(n):
        dist = [(float(np.linalg.norm(slots[i] - slots[j])), j) for j in range(n) if j != i]
        for _, j in sorted(dist)[:k]:
            edges.add((min(i, j) + 1, max(i, j) + 1))
    return sorted(edges)


def new_scenario(
    *,
    shape: str,
    agents: int,
    spacing: float = 3.0,
    dim: int = 2,
    length: float = 30.0,
    speed: float = 1.0,
    obstacles: int = 0,
    seed: int = 0,
    name: str | None = None,
    kinematics: str = "single",
) -> str:
    """Scenario YAML for a ``shape`` of ``agents`` agents crossing ``length`` m at ``speed``
    m/s, with ``obstacles`` obstacles drawn inside the assumptions from ``seed``;
    ``kinematics`` "unicycle": unicycles facing along the path (the campaign's
    :func:`~shoal.tools.campaign.fields.unicycle_for` figures)."""
    if dim not in (2, 3):
        raise ShapeError(f"dim must be 2 or 3, got {dim}")
    if kinematics == "unicycle" and dim != 2:
        raise ShapeError(f"unicycles drive in the plane: dim must be 2, got {dim}")
    if not length > 0 or not speed > 0:
        raise ShapeError(f"length and speed must be > 0, got {length} m and {speed} m/s")
    if obstacles < 0:
        raise ShapeError(f"obstacles must be ≥ 0, got {obstacles}")
    slots = offsets(shape, agents, spacing, dim)
    data: dict[str, Any] = {
        **({"name": name} if name else {}),  # else the file's name names it (loader)
        "description": f"{agents} agents in a {shape} {spacing:g} m apart cross {length:g} m"
        + (f" past {obstacles} obstacles" if obstacles else ""),
        "dim": dim,
        "seed": seed,
        "dt": 0.01,
        "duration": round(length / speed + TAIL, 6),
        "agent_radius": 0.05,
        "control": dict(CONTROL_DEFAULTS),  # the loader's, written out to edit
        "graph": {"directed": False, "edges": []},
        "agents": [{"offset": [float(x) for x in row]} for row in slots],
        "initial_noise": 0.0,
        "leader": {"waypoints": [[0.0] * dim, [length] + [0.0] * (dim - 1)], "speed": speed},
    }
    data["graph"]["edges"] = [list(e) for e in sparsest_graph(data, slots)]
    if kinematics == "unicycle":
        robot = unicycle_for(scenario_from_dict(data))
        figures = {f: getattr(robot, f) for f in ("lookahead", "max_speed", "max_turn_rate")}
        data["kinematics"] = {"model": "unicycle", **figures}
    if obstacles:
        data["obstacles"] = _obstacles(data, obstacles, seed, length)
    body = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    text = _header(shape, agents, obstacles) + body
    parse_scenario(
        text, default_name=f"{shape}-{agents}"
    )  # what this writes, the loader accepts (raises otherwise)
    return text


def sparsest_graph(data: dict[str, Any], slots: FloatArray) -> list[tuple[int, int]]:
    """The sparsest nearest-slots graph that passes Assumptions 1 and 2 for the scenario
    ``data`` (its graph replaced), or the complete graph, which passes both. Other refusals of
    the loader propagate; its warnings are left to the caller's own load of the result."""
    n = slots.shape[0]
    for k in range(2, n):
        edges = nearest_graph(slots, k)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ScenarioWarning)
                check_graph(scenario_from_dict({**data, "graph": {"edges": edges}}))
        except AssumptionError:
            continue
        return edges
    return list(itertools.combinations(range(1, n + 1), 2))


def _obstacles(data: dict[str, Any], count: int, seed: int, length: float) -> list[Any]:
    base = scenario_from_dict(data)
    opts = FieldOptions(length=length, count=(count, count), tail=TAIL, initial_noise=0.0)
    try:
        field = make_field(base, seed, "inside", opts)
    except WorldError as exc:
        raise ShapeError(
            f"could not place {count} obstacles inside the assumptions ({exc}); "
            "try fewer, a longer --length or another --seed"
        ) from None
    return [{"centre": list(o.centre), "radius": o.radius} for o in field.obstacles]


def _header(shape: str, agents: int, obstacles: int) -> str:
    lines = [
        f"# A {shape} of {agents} agents, made by `shoal scenarios new`.",
        "# Agent 1 leads along the waypoints; offsets are slots relative to the leader, x along",
        "# the direction of travel. The graph links each agent to its nearest slots, as few as",
        "# pass Assumptions 1 and 2 (every agent reaches the leader; no single evading follower",
        "# cuts anyone off). In a run, the paper's Assumption 2 taken literally can still fail",
        "# for some ticks (an evading agent whose neighbours all evade at once): the summary",
        "# counts them as 'Assumption 2 in the run'; the safety filter keeps everyone safe.",
    ]
    if obstacles:
        lines.append(
            "# Obstacles drawn like the campaign's inside fields: every load-time check passes."
        )
    lines.append("# Run it: shoal run THIS_FILE    Check it: shoal simulate THIS_FILE")
    return "\n".join(lines) + "\n"
