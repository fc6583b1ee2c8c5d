"""Hard fields: an adversarial generator of admissible scenarios (``shoal campaign --kind hard``).

The campaign's own fields (fields.py) keep a base scenario's formation, gains and straight path
and scatter obstacles near the desired tracks; the rules of shoal fit them well (199 of 200
settle). Other generators, measured, find more: leaders trapped by their own detour,
crowds deadlocked, livelocks by the goal. This generator draws the cases that hurt, each field
from scratch and every one admissible — the loader is the judge, as for the campaign's fields:

- 4–10 agents in any of shoal's shapes (shapes.py), 1.2–3 m apart, 2-D or 3-D, with the
  sparsest nearest-slots graph that passes Assumptions 1 and 2;
- gains and dt across their range: α 0.3–3, β 1–6 (above the leader's speed: |f| < β),
  dt 0.005–0.05 s; sensing and trigger radii from the largest obstacle up;
- a multi-leg route of 2–4 legs with sharp turns and reversals (the next leg turns by up to
  180°), at 0.3–1.0 m/s and below β;
- reshapes: up to two, among them rotations by π (every follower's slot across the formation)
  and scales up to 2;
- obstacles in clusters, their edges 2ρ + 0.01–0.3 m apart (just wider than the filter's guard
  circles allow), placed on the leader's own legs (it must go round), on a follower's desired
  track, and near the goal slots, 3–8 obstacles in all;
- 40 s of slack after the route, so a field that does not arrive is not merely out of time.

A candidate obstacle the loader refuses is drawn again (at most ``TRIES`` times, then the field
has fewer); a field whose skeleton it refuses (reshaped slots closer than the separation, say)
is drawn again from the next sub-seed. ``DetourWarning`` is admissible (the leader goes round);
``BetaWarning`` is not drawn; ``SpeedCapWarning`` is (those fields are what a slow robot meets). The
same (seed, dim) always gives the same field, byte for byte;
its ``source`` is the YAML that reproduces it with ``shoal simulate``.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import yaml

from shoal.bus.types import SafetyLayer
from shoal.geometry.path import path_position
from shoal.tools.campaign.fields import FieldError, plant_option, unicycle_fields, unicycle_for
from shoal.tools.campaign.shapes import SHAPES, offsets, sparsest_graph
from shoal.world.errors import ScenarioWarning, SpeedCapWarning, WorldError
from shoal.world.loader import parse_scenario, scenario_from_dict
from shoal.world.plant import KINEMATICS, MUJOCO
from shoal.world.scenario import Scenario

# The campaign's sets of hard fields (``shoal campaign --kind hard``), by dimension.
HARD_MODES = {"hard/2d": 2, "hard/3d": 3}
SLACK = 40.0  # s after the route's end: time to arrive
TRIES = 60  # candidates per obstacle before it is given up
SKELETONS = 50  # sub-seeds tried for a skeleton the loader accepts
RHO = 0.2  # m: the safety margin ρ of every hard field (the loader's default)
_TAG = 0x4A8D  # keeps this generator's random streams apart from fields.py's


def hard_field(
    seed: int,
    dim: int = 2,
    *,
    boundary_layer: float = 0.0,
    unicycles: bool = False,
    robots: dict[str, Any] | None = None,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> Scenario:
    """Hard field number ``seed`` in ``dim`` dimensions (2 or 3). ``boundary_layer`` K > 0:
    the same field with the optional boundary layer φ = K·β·dt (sat(e/φ) in place of the
    paper's sign(e)); the field drawn does not depend on it. ``unicycles`` (2-D only): every
    agent a unicycle (fields.py's ``unicycle_for``, headings drawn per field); the field is the
    one drawn for single integrators unless its skeleton does not admit them. ``robots``: the
    field's ``dynamics:`` section for a physics plant (fields.py ``robots_section``), and
    ``layer`` the safety layer its "Reproduce:" line names, neither of which changes the field
    drawn either."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    for sub in range(SKELETONS):
        rng = np.random.default_rng([seed, dim, sub, _TAG])
        data = _skeleton(rng, seed, dim, unicycles)
        if data is None:
            continue
        data["obstacles"] = _obstacles(data, rng)
        if boundary_layer > 0:
            c = data["control"]
            c["boundary_layer"] = _round(boundary_layer * c["beta"] * data["dt"])
        if robots is not None:
            data["dynamics"] = robots
        text = _header(seed, dim, robots is not None, layer) + yaml.safe_dump(
            data, sort_keys=False, width=100
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScenarioWarning)
            return parse_scenario(text, default_name=data["name"])
    raise FieldError(f"hard field {seed} ({dim}-D): no skeleton the loader accepts")


def _header(
    seed: int, dim: int, physics: bool = False, layer: SafetyLayer = SafetyLayer.REFEREE
) -> str:
    plant = plant_option(MUJOCO if physics else KINEMATICS, layer)
    return (
        "# A hard field of `shoal campaign --kind hard` (tools/campaign/hard.py): "
        f"seed {seed}, {dim}-D.\n# Admissible: every load-time check passes.\n"
        f"# Reproduce: shoal simulate{plant} THIS_FILE\n"
    )


def _round(x: float) -> float:
    return float(round(x, 4))


def _skeleton(
    rng: np.random.Generator, seed: int, dim: int, unicycles: bool = False
) -> dict[str, Any] | None:
    """Everything but the obstacles, or None if the loader refuses it."""
    n = int(rng.integers(4, 11))
    shape = str(rng.choice(SHAPES))
    spacing = float(rng.uniform(1.2, 3.0))
    slots = offsets(shape, n, spacing, dim)
    dt = _round(float(rng.choice([0.005, 0.01, 0.02, 0.05])) * float(rng.uniform(0.8, 1.0)))
    speed = float(rng.uniform(0.3, 1.0))
    beta = float(rng.uniform(max(1.0, 1.25 * speed), 6.0))
    alpha = float(rng.uniform(0.3, 3.0))
    sensing = float(rng.uniform(4.0, 7.0))
    route, moving = _route(rng, dim, speed)
    reshapes = _reshapes(rng, moving)
    data: dict[str, Any] = {
        "name": f"hard{dim}d-{seed}",
        "dim": dim,
        "seed": seed,
        "dt": dt,
        "duration": _round(moving + SLACK),
        "agent_radius": 0.05,
        "control": {
            "alpha": _round(alpha),
            "beta": _round(beta),
            "sensing_radius": _round(sensing),
            "trigger_radius": _round(sensing - 1.0),
            "safety_margin": RHO,
        },
        "graph": {"directed": False, "edges": []},
        "agents": [{"offset": [float(x) for x in row]} for row in slots],
        "initial_noise": _round(float(rng.uniform(0.0, 0.5))),
        "leader": {"waypoints": route, "speed": _round(speed)},
        "reshape": reshapes,
    }
    try:
        data["graph"]["edges"] = [list(e) for e in sparsest_graph(data, slots)]
        if unicycles:
            bare = scenario_from_dict(data)
            data.update(unicycle_fields(bare, seed, unicycle_for(bare)))
        with warnings.catch_warnings():
            warnings.simplefilter("error", ScenarioWarning)
            # drawn all the same: the fields where the cap cuts the law are what is measured
            warnings.simplefilter("ignore", SpeedCapWarning)
            scenario_from_dict(data)
    except (WorldError, ScenarioWarning):
        return None
    return data


def _route(rng: np.random.Generator, dim: int, speed: float) -> tuple[list[list[float]], float]:
    """2–4 legs of 6–18 m, each turning from the last by up to 180° (reversals included), in
    the horizontal plane (3-D: climbing a little); and the time the leader takes, s."""
    point = np.zeros(dim)
    heading = 0.0
    points = [point.copy()]
    length = 0.0
    for leg in range(int(rng.integers(2, 5))):
        if leg:
            heading += float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.3, 1.0)) * math.pi
        step = float(rng.uniform(6.0, 18.0))
        move = np.zeros(dim)
        move[0], move[1] = step * math.cos(heading), step * math.sin(heading)
        if dim == 3:
            move[2] = float(rng.uniform(-0.2, 0.2)) * step
        point = point + move
        points.append(point.copy())
        length += float(np.linalg.norm(move))
    return [[_round(float(x)) for x in p] for p in points], length / speed


def _reshapes(rng: np.random.Generator, moving: float) -> list[dict[str, float]]:
    """Up to two reshapes during the route: half of them a rotation by π."""
    out = []
    times = sorted(float(t) for t in rng.uniform(0.1, 0.9, size=int(rng.integers(0, 3))) * moving)
    for at in times:
        rotate = math.pi if rng.random() < 0.5 else float(rng.uniform(-math.pi, math.pi))
        scale = 1.0 if rng.random() < 0.5 else float(rng.uniform(1.0, 2.0))
        out.append({"at": _round(at), "rotate": rotate, "scale": _round(scale)})
    return out


def _obstacles(data: dict[str, Any], rng: np.random.Generator) -> list[dict[str, Any]]:
    """3–8 obstacles in clusters: each cluster seeded on the leader's leg, a follower's desired
    track or a goal slot; its other members just beyond the guard circles' reach (2ρ + a bit,
    edge to edge) from one already placed. Each candidate is kept only if the loader accepts
    the field with it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        bare = scenario_from_dict({**data, "obstacles": []})
    dim = bare.dim
    placed: list[dict[str, Any]] = []
    want = int(rng.integers(3, 9))
    while len(placed) < want:
        size = min(want - len(placed), int(rng.integers(1, 4)))
        anchor = _anchor(bare, rng)
        cluster: list[dict[str, Any]] = []
        for _ in range(size):
            for _try in range(TRIES):
                radius = float(rng.uniform(0.3, 1.2))
                if cluster:
                    other = cluster[int(rng.integers(len(cluster)))]
                    gap = 2 * RHO + float(rng.uniform(0.01, 0.3))
                    away = _direction(rng, dim)
                    centre = np.asarray(other["centre"]) + away * (other["radius"] + gap + radius)
                else:
                    centre = anchor + _direction(rng, dim) * float(rng.uniform(0.0, 1.0))
                candidate = {"centre": [_round(float(x)) for x in centre], "radius": _round(radius)}
                if _admissible(data, [*placed, *cluster, candidate]):
                    cluster.append(candidate)
                    break
            else:
                break  # this cluster is as full as it gets
        if not cluster:
            break  # nothing fits near this anchor: fewer obstacles
        placed += cluster
    return placed


def _anchor(s: Scenario, rng: np.random.Generator) -> Any:
    """Where a cluster starts: on the leader's route (a third of the time), on a follower's
    desired track at a random time, or by a follower's goal slot."""
    moving = s.duration - SLACK
    pick = rng.random()
    t = float(rng.uniform(0.15, 1.0)) * moving
    leader = path_position(s.path, t)
    if pick < 1 / 3:
        return leader
    i = int(rng.integers(1, s.n))
    if pick < 2 / 3:
        return leader + s.offsets[i]  # the unrotated slot: near the track, not exactly on it
    return path_position(s.path, s.duration) + s.offsets[i] * float(rng.uniform(1.5, 3.0))


def _direction(rng: np.random.Generator, dim: int) -> Any:
    v = rng.normal(size=dim)
    if dim == 3:
        v[2] *= 0.3  # mostly horizontal: clusters across the way, not above it
    return v / np.linalg.norm(v)


def _admissible(data: dict[str, Any], obstacles: list[dict[str, Any]]) -> bool:
    """The loader accepts the field with these obstacles (``DetourWarning`` allowed,
    ``BetaWarning`` not: it has no obstacle to blame and the skeleton already passed)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScenarioWarning)
            scenario_from_dict({**data, "obstacles": obstacles})
    except WorldError:
        return False
    return True
