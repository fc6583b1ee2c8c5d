"""Scenario files: YAML in, a validated :class:`~shoal.world.scenario.Scenario` out.

Every problem raises :class:`~shoal.world.errors.ScenarioError` naming the field (``control.beta``,
``agents[2].offset``); a broken paper assumption raises
:class:`~shoal.world.errors.AssumptionError`.
Unknown fields are refused, so a typo never silently falls back to a default. The file format is
documented in docs/scenarios.md.
"""

from __future__ import annotations

import io
import math
import re
import reprlib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from shoal.bus.types import PathSpec, Reshape, Safety, Sinusoid, Vector, Waypoints
from shoal.geometry.vectors import dot, norm
from shoal.world.assumptions import check_assumptions
from shoal.world.dynamics import setup as dynamics_setup
from shoal.world.errors import ScenarioError
from shoal.world.movers import Drift, Motion, Person, Route
from shoal.world.scenario import AgentSetup, Control, Obstacle, RobotSetup, Scenario, Unicycle

_TOP = {
    "name", "description", "dim", "seed", "dt", "duration", "agent_radius", "tolerance_factor",
    "control", "graph", "agents", "initial_noise", "leader", "obstacles", "reshape", "kinematics",
    "position_error", "robots", "dynamics",
}  # fmt: skip
# No length, time or gain in a scenario is larger: squares and sums stay far from overflow.
_LARGEST = 1e9
_MOST_STEPS = 10_000_000
# "[" and "{" nested deeper than this are refused before PyYAML sees them: its scanner takes
# quadratic time in the nesting (2,000 levels: seconds), and its composer would overflow the
# stack a few hundred levels down anyway. A scenario nests three deep.
_DEEPEST_FLOW = 100
_FLOW = re.compile(r"[\[\]{}]")
CONTROL_DEFAULTS: dict[str, float] = {
    "alpha": 1.0,
    "beta": 2.0,
    "sensing_radius": 5.0,
    "trigger_radius": 4.0,
    "epsilon": 0.05,
    "safety_margin": 0.2,
    "heading_tau": 0.5,
    "sigma_max": 8.0,
    "boundary_layer": 0.0,
}


def builtin_names() -> list[str]:
    """Names of the scenarios shipped with shoal."""
    files = resources.files("shoal.world.scenarios")
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".yaml"))


def load_scenario(name_or_path: str | Path) -> Scenario:
    """A built-in scenario by name, or a scenario file by path."""
    path = Path(name_or_path)
    if str(name_or_path) in builtin_names() and not path.exists():
        text = resources.files("shoal.world.scenarios").joinpath(f"{name_or_path}.yaml").read_text()
        return parse_scenario(text)
    if not path.is_file():
        known = ", ".join(builtin_names())
        raise ScenarioError(
            "scenario", f"no file {str(path)!r} and no built-in of that name ({known})"
        )
    return parse_scenario(
        path.read_text(encoding="utf-8"), default_name=path.stem, source_name=str(path)
    )


def parse_scenario(
    text: str, *, default_name: str = "scenario", source_name: str | None = None
) -> Scenario:
    """Parse and validate YAML text; ``source_name`` (the file) names where a YAML syntax
    error is."""
    if _flow_depth(text) > _DEEPEST_FLOW:
        raise ScenarioError("yaml", f"not valid YAML: [ or {{ nested over {_DEEPEST_FLOW} deep")
    stream: str | io.StringIO = text
    if source_name is not None:  # PyYAML's marks name a stream by its `name`
        stream = io.StringIO(text)
        stream.name = source_name
    try:
        data = yaml.safe_load(stream)
    except yaml.YAMLError as exc:
        raise ScenarioError("yaml", f"not valid YAML: {exc}") from None
    except (ValueError, AttributeError, IndexError, KeyError, TypeError, OverflowError) as exc:
        # PyYAML's own constructors on a bad scalar: an integer too long to convert, and with
        # an explicit tag, "!!int" (IndexError, ValueError), "!!bool" (KeyError), "!!timestamp"
        # (AttributeError, ValueError) on text that is not one.
        raise ScenarioError("yaml", f"not valid YAML: {type(exc).__name__}: {exc}") from None
    except RecursionError:  # PyYAML recurses per level: "[[[[…" a few hundred deep
        raise ScenarioError("yaml", "not valid YAML: nested too deeply") from None
    if not isinstance(data, Mapping):
        raise ScenarioError("scenario", "the file must hold a mapping of fields")
    return scenario_from_dict(data, source=text, default_name=default_name)


def _flow_depth(text: str) -> int:
    """How deep "[" and "{" nest, quotes and comments not told apart (an upper bound)."""
    depth = deepest = 0
    for bracket in _FLOW.finditer(text):
        if bracket.group() in "[{":
            depth += 1
            deepest = max(deepest, depth)
        else:
            depth = max(depth - 1, 0)
    return deepest


def scenario_from_dict(
    data: Mapping[str, Any], *, source: str = "", default_name: str = "scenario"
) -> Scenario:
    """Validate a mapping (as parsed from YAML) into a Scenario."""
    _no_unknown(data, _TOP, "")
    dim = _integer(data.get("dim", 2), "dim")
    if dim not in (2, 3):
        raise ScenarioError("dim", f"must be 2 or 3, got {dim}")
    unicycle = _kinematics(data.get("kinematics"), dim)
    dt = _positive(data.get("dt", 0.01), "dt")
    duration = _positive(data.get("duration", 20.0), "duration")
    if duration < dt:
        raise ScenarioError("duration", f"{duration} s is shorter than one step dt = {dt} s")
    if duration / dt > _MOST_STEPS:
        raise ScenarioError(
            "duration", f"{duration} s at dt = {dt} s is more than {_MOST_STEPS:,} steps"
        )
    seed = _integer(data.get("seed", 0), "seed")
    if seed < 0:
        raise ScenarioError("seed", f"must be ≥ 0, got {seed}")
    path = _path(data.get("leader"), dim)
    agents = _agents(
        data.get("agents"), dim, path, seed, data.get("initial_noise", 0.0), unicycle is not None
    )
    wheeled = [a for a in agents if not a.single]
    if wheeled and unicycle is None:
        raise ScenarioError(
            f"agents[{wheeled[0].agent_id - 1}].kinematics",
            "is unicycle, but the scenario's kinematics section gives no unicycle (model: "
            "unicycle with its lookahead and limits)",
        )
    if unicycle is not None and not wheeled:
        unicycle = None  # every agent overridden to a single integrator
    directed, edges = _graph(data.get("graph"), len(agents))
    scenario = Scenario(
        name=_string(data.get("name", default_name), "name"),
        description=_string(data.get("description", ""), "description"),
        dim=dim,
        dt=dt,
        duration=duration,
        seed=seed,
        agents=agents,
        directed=directed,
        edges=edges,
        path=path,
        obstacles=read_obstacles(data.get("obstacles", []), dim),
        reshapes=_reshapes(data.get("reshape", []), dt, duration),
        control=_control(data.get("control", {})),
        agent_radius=_non_negative(data.get("agent_radius", 0.05), "agent_radius"),
        tolerance_factor=_positive(data.get("tolerance_factor", 10.0), "tolerance_factor"),
        source=source,
        unicycle=unicycle,
        position_error=_non_negative(data.get("position_error", 0.0), "position_error"),
        robots=_robots(data.get("robots"), len(agents)),
        dynamics=dynamics_setup(data.get("dynamics")),
    )
    scenario.robot_dynamics()  # a preset that fits no agent is named now, at load
    check_assumptions(scenario)
    return scenario


# -- fields -------------------------------------------------------------------------------------


class _Shown(reprlib.Repr):
    """A value as an error message shows it: short, and safe for any value YAML can make (a
    list nested 900 deep, an integer of 4,000 digits) where repr() raises or runs on."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxstring, self.maxother = 3, 60, 60

    def repr_int(self, x: int, level: int) -> str:
        if abs(x) >= 10**30:
            return f"an integer of {x.bit_length()} bits"
        return super().repr_int(x, level)


_shown = _Shown().repr


def _no_unknown(data: Mapping[str, Any], known: set[str], where: str) -> None:
    for key in data:
        if key not in known:
            field = f"{where}.{key}" if where else str(key)
            raise ScenarioError(
                field, f"unknown field (expected one of {', '.join(sorted(known))})"
            )


def _missing(field: str, kind: str) -> ScenarioError:
    """The error for a field the file does not give (absent, or a key with nothing after it)."""
    return ScenarioError(field, f"missing (or empty): {kind} is needed here")


def _number(value: Any, field: str) -> float:
    if value is None:
        raise _missing(field, "a number")
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ScenarioError(field, f"must be a number, got {_shown(value)}")
    if isinstance(value, int) and abs(value) > _LARGEST:
        raise ScenarioError(field, f"must be within ±{_LARGEST:g}, got a larger integer")
    if not math.isfinite(value):
        raise ScenarioError(field, f"must be finite, got {_shown(value)}")
    if abs(value) > _LARGEST:
        raise ScenarioError(field, f"must be within ±{_LARGEST:g}, got {_shown(value)}")
    return float(value)


def _positive(value: Any, field: str) -> float:
    x = _number(value, field)
    if x <= 0:
        raise ScenarioError(field, f"must be > 0, got {x}")
    return x


def _non_negative(value: Any, field: str) -> float:
    x = _number(value, field)
    if x < 0:
        raise ScenarioError(field, f"must be ≥ 0, got {x}")
    return x + 0.0  # -0.0 becomes 0.0: numpy's uniform(-s, s) refuses s = -0.0


def _integer(value: Any, field: str) -> int:
    if value is None:
        raise _missing(field, "an integer")
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScenarioError(field, f"must be an integer, got {_shown(value)}")
    if abs(value) >= 2**63:  # YAML's 1:0:0:… (base 60) makes any size; str() refuses 4,300 digits
        raise ScenarioError(field, f"must be within ±2^63, got {_shown(value)}")
    return value


def _string(value: Any, field: str) -> str:
    if not isinstance(value, str):
        raise ScenarioError(field, f"must be a string, got {_shown(value)}")
    return value


def _vector(value: Any, field: str, dim: int) -> Vector:
    if value is None:
        raise _missing(field, f"a list of {dim} numbers")
    if not isinstance(value, list | tuple) or len(value) != dim:
        raise ScenarioError(field, f"must be a list of {dim} numbers, got {_shown(value)}")
    return tuple(_number(v, f"{field}[{k}]") for k, v in enumerate(value))


def _mapping(value: Any, field: str) -> Mapping[str, Any]:
    if value is None:
        raise _missing(field, "a mapping")
    if not isinstance(value, Mapping):
        raise ScenarioError(field, f"must be a mapping, got {_shown(value)}")
    return value


def _list(value: Any, field: str) -> list[Any]:
    if value is None:
        raise _missing(field, "a list")
    if not isinstance(value, list):
        raise ScenarioError(field, f"must be a list, got {_shown(value)}")
    return value


# -- sections -----------------------------------------------------------------------------------


_SAFETY_MODES = tuple(Safety)


_UNICYCLE = ("lookahead", "max_speed", "max_turn_rate")
_WHEELS = ("wheel_radius", "axle", "max_wheel_speed")


_ROS_NAME = re.compile(r"/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")
ROS_DISTROS = ("humble", "jazzy", "kilted", "rolling")
ROS_POSES = ("odom", "pose")


def _robots(value: Any, n: int) -> RobotSetup | None:
    """``robots``: the ROS 2 robots the agents are (docs/ros2.md): ``namespaces`` (one per
    agent, in id order, each a ROS 2 name such as ``tb3_1`` or ``/lab/tb3_1``), ``domain``
    (0–232), ``connect`` (the router's endpoints), ``distro``, ``pose`` (odom or pose) and
    ``pose_timeout`` (s), each optional."""
    if value is None:
        return None
    data = _mapping(value, "robots")
    keys = {"namespaces", "domain", "connect", "distro", "pose", "pose_timeout"}
    _no_unknown(data, keys, "robots")
    namespaces = None
    if "namespaces" in data:
        given = _list(data["namespaces"], "robots.namespaces")
        if len(given) != n:
            raise ScenarioError("robots.namespaces", f"needs one per agent ({n}), got {len(given)}")
        for k, name in enumerate(given, start=1):
            if not isinstance(name, str) or not _ROS_NAME.fullmatch(name):
                raise ScenarioError(
                    f"robots.namespaces (agent {k})",
                    f"must be a ROS 2 name (letters, digits, _, /; no leading digit), got "
                    f"{_shown(name)}",
                )
        named = ["/" + name.strip("/") for name in given]
        twice = next((x for x in named if named.count(x) > 1), None)
        if twice is not None:
            raise ScenarioError("robots.namespaces", f"{twice} is given to two agents")
        namespaces = tuple(named)
    domain = None
    if "domain" in data:
        domain = _integer(data["domain"], "robots.domain")
        if not 0 <= domain <= 232:
            raise ScenarioError("robots.domain", f"a ROS 2 domain id is 0–232, got {domain}")
    connect: tuple[str, ...] = ()
    if "connect" in data:
        raw = data["connect"]
        items = [raw] if isinstance(raw, str) else _list(raw, "robots.connect")
        for item in items:
            if not isinstance(item, str) or "/" not in item:
                raise ScenarioError(
                    "robots.connect",
                    f"an endpoint is a string such as tcp/192.168.1.2:7447, got {_shown(item)}",
                )
        connect = tuple(items)
    choices = {}
    for key, allowed in (("distro", ROS_DISTROS), ("pose", ROS_POSES)):
        if key in data and data[key] not in allowed:
            raise ScenarioError(
                f"robots.{key}", f"must be one of {', '.join(allowed)}, got {_shown(data[key])}"
            )
        choices[key] = data.get(key)
    timeout = data.get("pose_timeout")
    return RobotSetup(
        namespaces=namespaces,
        domain=domain,
        connect=connect,
        distro=choices["distro"],
        pose=choices["pose"],
        pose_timeout=None if timeout is None else _positive(timeout, "robots.pose_timeout"),
    )


def _kinematics(value: Any, dim: int) -> Unicycle | None:
    """``kinematics``: absent or ``{model: single}`` for the paper's single integrators;
    ``{model: unicycle, lookahead, max_speed, max_turn_rate}`` (and optionally all three of
    ``wheel_radius``, ``axle``, ``max_wheel_speed``) for unicycles."""
    if value is None:
        return None
    data = _mapping(value, "kinematics")
    _no_unknown(data, {"model", *_UNICYCLE, *_WHEELS}, "kinematics")
    model = data.get("model", "single")
    if model not in ("single", "unicycle"):
        raise ScenarioError("kinematics.model", f"must be single or unicycle, got {_shown(model)}")
    given = sorted(k for k in (*_UNICYCLE, *_WHEELS) if k in data)
    if model == "single":
        if given:
            raise ScenarioError(f"kinematics.{given[0]}", "is for model: unicycle")
        return None
    if dim != 2:
        raise ScenarioError(
            "kinematics.model", f"unicycles drive in the plane: dim must be 2, got {dim}"
        )
    for key in _UNICYCLE:
        if key not in data:
            raise _missing(f"kinematics.{key}", "a positive number")
    wheels = [k for k in _WHEELS if k in data]
    if wheels and len(wheels) != len(_WHEELS):
        missing = next(k for k in _WHEELS if k not in data)
        raise _missing(f"kinematics.{missing}", "with the other wheel figures, a positive number")
    return Unicycle(**{k: _positive(data[k], f"kinematics.{k}") for k in (*_UNICYCLE, *wheels)})


def _control(value: Any) -> Control:
    data = dict(_mapping(value, "control"))
    _no_unknown(data, {*CONTROL_DEFAULTS, "safety", "speed_limit", "separation"}, "control")
    safety = data.pop("safety", Safety.FILTER)
    if safety not in _SAFETY_MODES:
        raise ScenarioError(
            "control.safety", f"must be one of {', '.join(_SAFETY_MODES)}, got {_shown(safety)}"
        )
    speed_limit = data.pop("speed_limit", None)
    if speed_limit is not None:
        speed_limit = _positive(speed_limit, "control.speed_limit")
    separation = data.pop("separation", None)
    if separation is not None:
        separation = _positive(separation, "control.separation")
    merged = {**CONTROL_DEFAULTS, **data}
    for key in ("alpha", "beta", "sensing_radius", "trigger_radius", "epsilon", "sigma_max"):
        _positive(merged[key], f"control.{key}")
    for key in ("safety_margin", "heading_tau", "boundary_layer"):
        _non_negative(merged[key], f"control.{key}")
    c = Control(
        **{k: float(v) for k, v in merged.items()},
        safety=Safety(safety),
        speed_limit=speed_limit,
        separation=separation,
    )
    if c.trigger_radius >= c.sensing_radius:
        raise ScenarioError(
            "control.trigger_radius",
            f"d̄ = {c.trigger_radius} must be < the sensing radius d = {c.sensing_radius} (11)",
        )
    if c.sigma_max < 1:
        raise ScenarioError("control.sigma_max", f"must be ≥ 1, got {c.sigma_max}")
    return c


def _path(value: Any, dim: int) -> PathSpec:
    data = _mapping(value, "leader")
    if ("waypoints" in data) == ("sinusoid" in data):
        raise ScenarioError(
            "leader", "give exactly one of 'waypoints' (with 'speed') or 'sinusoid'"
        )
    if "waypoints" in data:
        _no_unknown(data, {"waypoints", "speed"}, "leader")
        raw = _list(data["waypoints"], "leader.waypoints")
        if len(raw) < 1:
            raise ScenarioError("leader.waypoints", "needs at least one waypoint")
        points = tuple(_vector(p, f"leader.waypoints[{k}]", dim) for k, p in enumerate(raw))
        return Waypoints(points=points, speed=_positive(data.get("speed"), "leader.speed"))
    _no_unknown(data, {"sinusoid"}, "leader")
    s = _mapping(data["sinusoid"], "leader.sinusoid")
    _no_unknown(
        s, {"start", "direction", "normal", "speed", "amplitude", "period"}, "leader.sinusoid"
    )
    where = "leader.sinusoid"
    direction = np.asarray(_vector(s.get("direction"), f"{where}.direction", dim))
    if norm(direction) == 0:
        raise ScenarioError(f"{where}.direction", "must not be zero")
    direction = direction / norm(direction)
    if "normal" in s:
        normal = np.asarray(_vector(s["normal"], f"{where}.normal", dim))
    else:  # the direction turned +90° in the xy-plane; along z, the x axis
        normal = np.zeros(dim)
        normal[:2] = (-direction[1], direction[0])
        if norm(normal) < 1e-9:
            normal[0] = 1.0
    normal = normal - dot(normal, direction) * direction
    if norm(normal) < 1e-9:
        raise ScenarioError(f"{where}.normal", "must not be parallel to the direction")
    normal = normal / norm(normal)
    return Sinusoid(
        start=_vector(s.get("start"), f"{where}.start", dim),
        direction=tuple(float(x) for x in direction),
        normal=tuple(float(x) for x in normal),
        speed=_non_negative(s.get("speed"), f"{where}.speed"),
        amplitude=_non_negative(s.get("amplitude"), f"{where}.amplitude"),
        period=_positive(s.get("period"), f"{where}.period"),
    )


def _agents(
    value: Any, dim: int, path: PathSpec, seed: int, noise: Any, unicycles: bool
) -> tuple[AgentSetup, ...]:
    """``agents``; each a unicycle when ``unicycles`` (the scenario's kinematics say so) unless
    its own ``kinematics: single`` makes it holonomic (and ``kinematics: unicycle`` the other
    way round, which then needs the scenario's unicycle figures)."""
    raw = _list(value, "agents")
    if len(raw) < 2:
        raise ScenarioError("agents", "needs a leader and at least one follower")
    spread = _non_negative(noise, "initial_noise")
    start = np.asarray(path.points[0] if isinstance(path, Waypoints) else path.start)
    rng = np.random.default_rng(seed)
    agents = []
    for k, item in enumerate(raw):
        where = f"agents[{k}]"
        entry = _mapping(item, where)
        _no_unknown(entry, {"offset", "initial", "heading", "kinematics"}, where)
        offset = _vector(entry.get("offset"), f"{where}.offset", dim)
        jitter = rng.uniform(-spread, spread, size=dim)  # drawn for every agent: stable streams
        if k == 0:
            if any(offset):
                raise ScenarioError(f"{where}.offset", "the leader (agent 1) has offset zero")
            initial = tuple(float(x) for x in start)
            if "initial" in entry and not np.allclose(
                _vector(entry["initial"], f"{where}.initial", dim), start
            ):
                raise ScenarioError(f"{where}.initial", "the leader starts where its path starts")
        elif "initial" in entry:
            initial = _vector(entry["initial"], f"{where}.initial", dim)
        else:
            initial = tuple(float(x) for x in start + np.asarray(offset) + jitter)
        given = k > 0 and "initial" in entry
        heading = _number(entry.get("heading", 0.0), f"{where}.heading")
        if not -2 * math.pi <= heading <= 2 * math.pi:
            raise ScenarioError(f"{where}.heading", f"{heading} rad is outside [−2π, 2π]")
        model = entry.get("kinematics")
        if model is not None and model not in ("single", "unicycle"):
            raise ScenarioError(
                f"{where}.kinematics", f"must be single or unicycle, got {_shown(model)}"
            )
        spec = AgentSetup(
            agent_id=k + 1, initial=initial, offset=offset, given_initial=given, heading=heading,
            single=model == "single" or (model is None and not unicycles),
        )  # fmt: skip
        agents.append(spec)
    return tuple(agents)


def _graph(value: Any, n: int) -> tuple[bool, tuple[tuple[int, int], ...]]:
    data = _mapping(value, "graph")
    _no_unknown(data, {"directed", "edges"}, "graph")
    directed = data.get("directed", False)
    if not isinstance(directed, bool):
        raise ScenarioError("graph.directed", f"must be true or false, got {_shown(directed)}")
    edges = []
    for k, e in enumerate(_list(data.get("edges"), "graph.edges")):
        where = f"graph.edges[{k}]"
        if not isinstance(e, list | tuple) or len(e) != 2:
            raise ScenarioError(where, f"must be a pair of agent ids, got {_shown(e)}")
        i, j = (_integer(x, where) for x in e)
        for x in (i, j):
            if not 1 <= x <= n:
                raise ScenarioError(where, f"agent {x} does not exist (ids are 1..{n})")
        if i == j:
            raise ScenarioError(where, f"a self-loop on agent {i}")
        edges.append((i, j))
    return directed, tuple(edges)


def read_obstacles(value: Any, dim: int) -> tuple[Obstacle, ...]:
    """The ``obstacles`` list of a scenario, each entry validated on its own (how they sit
    against each other and the agents is :mod:`~shoal.world.assumptions`'s)."""
    out = []
    for k, item in enumerate(_list(value, "obstacles")):
        where = f"obstacles[{k}]"
        entry = _mapping(item, where)
        _no_unknown(entry, {"centre", "radius", "moves"}, where)
        out.append(
            Obstacle(
                centre=_vector(entry.get("centre"), f"{where}.centre", dim),
                radius=_positive(entry.get("radius"), f"{where}.radius"),
                motion=_motion(entry["moves"], f"{where}.moves", dim) if "moves" in entry else None,
            )
        )
    return tuple(out)


MOTION_KINDS = ("drift", "route", "person")


def _flag(value: Any, field: str) -> bool:
    if not isinstance(value, bool):
        raise ScenarioError(field, f"must be true or false, got {_shown(value)}")
    return value


def _points(value: Any, field: str, dim: int) -> tuple[Vector, ...]:
    items = _list(value, field)
    if not items:
        raise ScenarioError(field, "must list at least one point")
    return tuple(_vector(p, f"{field}[{k}]", dim) for k, p in enumerate(items))


def _motion(value: Any, where: str, dim: int) -> Motion:
    """``moves:`` of an obstacle (docs/people.md): {kind: drift, velocity}, {kind: route,
    waypoints, speed, loop}, or {kind: person, goals, speed, u_max, reactive, loop}."""
    entry = _mapping(value, where)
    kind = entry.get("kind")
    if kind not in MOTION_KINDS:
        raise ScenarioError(f"{where}.kind", f"must be one of {', '.join(MOTION_KINDS)}, "
                            f"got {_shown(kind)}")  # fmt: skip
    if kind == "drift":
        _no_unknown(entry, {"kind", "velocity"}, where)
        return Drift(_vector(entry.get("velocity"), f"{where}.velocity", dim))
    if kind == "route":
        _no_unknown(entry, {"kind", "waypoints", "speed", "loop"}, where)
        return Route(
            waypoints=_points(entry.get("waypoints"), f"{where}.waypoints", dim),
            speed=_positive(entry.get("speed"), f"{where}.speed"),
            loop=_flag(entry.get("loop", False), f"{where}.loop"),
        )
    _no_unknown(entry, {"kind", "goals", "speed", "u_max", "reactive", "loop"}, where)
    speed = _positive(entry.get("speed", PERSON_SPEED), f"{where}.speed")
    u_max = _positive(entry.get("u_max", PERSON_CAP * speed), f"{where}.u_max")
    if u_max < speed:
        raise ScenarioError(
            f"{where}.u_max", f"{u_max} m/s is below the preferred speed {speed} m/s"
        )
    return Person(
        goals=_points(entry.get("goals"), f"{where}.goals", dim),
        speed=speed,
        u_max=u_max,
        reactive=_flag(entry.get("reactive", True), f"{where}.reactive"),
        loop=_flag(entry.get("loop", False), f"{where}.loop"),
    )


PERSON_SPEED = 1.0  # m/s: a person's preferred walking speed unless given (CrowdNav's 1 m/s)
PERSON_CAP = 1.3  # u_max unless given: this times the preferred speed (Helbing et al.: 1.3)


def _reshapes(value: Any, dt: float, duration: float) -> tuple[Reshape, ...]:
    out: list[Reshape] = []
    for k, item in enumerate(_list(value, "reshape")):
        where = f"reshape[{k}]"
        entry = _mapping(item, where)
        _no_unknown(entry, {"at", "scale", "rotate"}, where)
        at = _non_negative(entry.get("at"), f"{where}.at")
        if at > duration:
            raise ScenarioError(f"{where}.at", f"{at} s is after the end of the run ({duration} s)")
        tick = round(at / dt)
        if out and tick < out[-1].tick:
            raise ScenarioError(f"{where}.at", "reshapes must be listed in time order")
        out.append(
            Reshape(
                tick=tick,
                scale=_positive(entry.get("scale", 1.0), f"{where}.scale"),
                rotate=_number(entry.get("rotate", 0.0), f"{where}.rotate"),
            )
        )
    return tuple(out)
