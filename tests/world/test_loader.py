"""The scenario loader: field-named errors, the paper's Assumptions 1-4, the |f| < β warning."""

from __future__ import annotations

import contextlib
import copy
import itertools
import math
import re
import warnings
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from shoal.bus.types import Waypoints
from shoal.world.assumptions import cap_needed
from shoal.world.errors import (
    AssumptionError,
    BetaWarning,
    DetourWarning,
    ScenarioError,
    SpeedCapWarning,
)
from shoal.world.loader import builtin_names, load_scenario, parse_scenario, scenario_from_dict

DELETE = object()


def base() -> dict[str, Any]:
    """A fresh minimal valid 2-D scenario: four agents, no cut vertex, one obstacle clear of all."""
    return {
        "dt": 0.01,
        "duration": 25.0,
        "seed": 0,
        "control": {"beta": 2.0, "sensing_radius": 5.0, "trigger_radius": 4.0},
        "graph": {"edges": [[1, 2], [1, 3], [2, 3], [2, 4], [3, 4]]},
        "agents": [{"offset": o} for o in ([0, 0], [-3, 3], [-3, -3], [-6, 0])],
        "leader": {"waypoints": [[0, 0], [20, 0]], "speed": 1.0},
        "obstacles": [{"centre": [10, 4], "radius": 1.0}],
    }


def base3d() -> dict[str, Any]:
    d = base()
    d["dim"] = 3
    for a in d["agents"]:
        a["offset"] = [*a["offset"], 0]
    d["leader"]["waypoints"] = [[0, 0, 0], [20, 0, 0]]
    d["obstacles"] = [{"centre": [10, 4, 1], "radius": 1.0}]
    return d


def sinusoid(**kw: Any) -> dict[str, Any]:
    d = base()
    d["leader"] = {
        "sinusoid": {"start": [0, 0], "direction": [1, 0], "speed": 1.0, "amplitude": 2.0,
                     "period": 10.0, **kw}
    }  # fmt: skip
    return d


def edit(path: str, value: Any, d: dict[str, Any] | None = None) -> dict[str, Any]:
    """A copy of ``d`` (default: base()) with the dotted ``path`` ("agents.2.offset") set."""
    d = copy.deepcopy(base() if d is None else d)
    *parents, last = [int(k) if k.isdigit() else k for k in path.split(".")]
    node: Any = d
    for k in parents:
        node = node[k]
    if value is DELETE:
        del node[last]
    else:
        node[last] = value
    return d


def graph(*edges: list[int], directed: bool = False) -> dict[str, Any]:
    return edit("graph", {"directed": directed, "edges": list(edges)})


# -- built-ins and the base ---------------------------------------------------------------------

KNOWN_SIZES = {
    "default": (5, 2),
    "obstacles": (5, 4),
    "passage": (5, 2),
    "sinusoid": (5, 0),
    "crossing": (5, 5),
}


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_loads_cleanly(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = load_scenario(name)
    raw = yaml.safe_load(
        resources.files("shoal.world.scenarios").joinpath(f"{name}.yaml").read_text()
    )
    assert (s.n, len(s.obstacles)) == (len(raw["agents"]), len(raw.get("obstacles", [])))
    assert (s.n, len(s.obstacles)) == KNOWN_SIZES.get(name, (s.n, len(s.obstacles)))
    assert s.name == name and set(KNOWN_SIZES) <= set(builtin_names())


def test_base_2d_3d_and_file_load(tmp_path: Any) -> None:
    s = scenario_from_dict(base())
    assert (s.n, s.dim, len(s.obstacles), s.directed) == (4, 2, 1, False)
    assert np.array_equal(s.initial_positions, s.offsets)  # no noise: start + offset
    f = tmp_path / "mine.yaml"
    f.write_text(yaml.safe_dump(base()))
    assert load_scenario(f).name == "mine"
    assert load_scenario(str(f)).n == 4
    s3 = scenario_from_dict(base3d())
    assert s3.dim == 3 and s3.initial_positions.shape == (4, 3) == s3.offsets.shape


# -- Assumptions 1-4 ----------------------------------------------------------------------------


ASSUMPTION_CASES = {  # number, scenario, field, problem
    "1-undirected-disconnected": (1, graph([1, 2], [1, 3], [2, 3]), "graph.edges",
        "the graph is not connected: 4 apart$"),
    "1-directed-wrong-way": (1, graph([1, 2], [1, 3], [2, 4], [3, 4], directed=True),
        "graph.edges", "no directed path from the leader to follower.s. 2, 3, 4$"),
    "1-directed-one-missing": (1, graph([2, 1], [3, 1], [2, 4], [3, 4], directed=True),
        "graph.edges", "no directed path from the leader to follower.s. 4$"),
    "2-chain-cut-vertex": (2, graph([1, 2], [2, 3], [3, 4]), "graph.edges",
        "while agent 2 evades .* agent.s. 3, 4 have no path to the leader"),
    "2-directed-cut-vertex": (2, graph([2, 1], [3, 1], [4, 2], directed=True), "graph.edges",
        "while agent 2 evades .* agent.s. 4 have no path"),
    "3-offsets-too-close": (3, edit("agents.2.offset", [-3, 2]), "agents[2].offset",
        "agents 2 and 3 are meant to be 1 m apart, not more than 2 r_max = 2 m"),
    "3-after-contraction": (3, edit("reshape", [{"at": 5.0, "scale": 3.0}]), "agents[",
        ".* not more than 2 r_max = 2 m"),
    "4-leg-through": (4, edit("obstacles", [{"centre": [10, 0.5], "radius": 1.0}]),
        "leader.waypoints[0]", "the leg from waypoint 0 passes inside obstacles\\[0\\] by 0.5 m"),
    "4-leg-within-margin": (4, edit("obstacles", [{"centre": [10, 1.1], "radius": 1.0}]),
        "leader.waypoints[0]", "the leg .* 0.1 m .* within the safety margin 0.2 m$"),
    "4-second-leg": (4, edit("leader.waypoints", [[0, 0], [20, 0], [20, 20]], edit("obstacles", [
        {"centre": [20.5, 12], "radius": 1.0}])), "leader.waypoints[1]", "the leg from waypoint 1"),
    "4-sinusoid": (4, edit("obstacles", [{"centre": [2.5, 2.0], "radius": 0.5}], sinusoid()),
        "leader.sinusoid", "the path passes inside obstacles.0. by 0.5 m"),
}  # fmt: skip


def _paper(data: dict[str, Any]) -> dict[str, Any]:
    return {**data, "control": {**data.get("control", {}), "safety": "paper"}}


@pytest.mark.parametrize("case", ASSUMPTION_CASES)
def test_each_assumption_is_named(case: str) -> None:
    number, data, field, message = ASSUMPTION_CASES[case]
    # "agents[": which pair trips first after a contraction is not pinned
    where = r"agents\[\d\]\.offset" if field == "agents[" else re.escape(field)
    pattern = f"^{where}: Assumption {number} violated: {message}"
    with pytest.raises(AssumptionError, match=pattern) as info:
        scenario_from_dict(_paper(data) if field.startswith("leader.waypoints") else data)
    assert info.value.assumption == number and re.fullmatch(where, info.value.field)


@pytest.mark.parametrize(
    "case", [c for c in ASSUMPTION_CASES if "waypoints" in ASSUMPTION_CASES[c][2]]
)
def test_with_the_filter_a_waypoint_leg_through_an_obstacle_is_a_detour_warning(case: str) -> None:
    _number, data, _field, message = ASSUMPTION_CASES[case]
    with pytest.warns(DetourWarning, match=f"{message.rstrip('$')}.*the leader will go round it"):
        scenario_from_dict(data)


def test_directed_graph_where_leader_reaches_all_loads() -> None:
    # 2 and 3 sense the leader, 4 senses both
    s = scenario_from_dict(graph([2, 1], [3, 1], [4, 2], [4, 3], directed=True))
    assert s.directed and s.adjacency[1, 0] == 1 and s.adjacency[0, 1] == 0


# a chain (follower 2 cuts 3, 4 off), slots 0.5 m apart, a trigger radius inside the guard
ONLY_WITH_OBSTACLES = [("graph.edges", [[1, 2], [2, 3], [3, 4]]), ("agents.2.offset", [-3, 2.5]),
                       ("control.trigger_radius", 0.5)]  # fmt: skip


@pytest.mark.parametrize(("path", "value"), ONLY_WITH_OBSTACLES)
def test_obstacle_only_checks_skipped_without_obstacles(path: str, value: Any) -> None:
    data = edit(path, value)
    with pytest.raises(ScenarioError):
        scenario_from_dict(data)
    assert scenario_from_dict(edit("obstacles", DELETE, data)).obstacles == ()
    assert scenario_from_dict(edit("obstacles", [], data)).obstacles == ()


# -- |f| < β -------------------------------------------------------------------------------------


BETA_CASES = {
    "equal": (edit("leader.speed", 2.0), True),
    "above": (edit("leader.speed", 3.0), True),
    "sinusoid-wave": (sinusoid(amplitude=3.0, period=5.0), True),  # 2π·3/5 = 3.8 m/s across
    "just-below": (edit("leader.speed", 1.99), False),
    "diagonal": (edit("leader", {"waypoints": [[0, 0], [20, 20]], "speed": 2.5}), False),  # 1.77
    "sinusoid": (sinusoid(), False),  # 1 m/s along, 1.26 m/s across
}


@pytest.mark.parametrize("case", BETA_CASES)
def test_beta_warning_only_when_leader_as_fast_as_beta(case: str) -> None:
    data, warns = BETA_CASES[case]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert scenario_from_dict(data).n == 4  # loads either way
    assert [w.category for w in caught] == ([BetaWarning] if warns else [])
    if warns:
        with pytest.warns(BetaWarning, match=r"not below β = 2\.0 m/s; Theorem 1"):
            scenario_from_dict(data)


# -- room under the speed limit for the capped law ----------------------------------------------

# base(): f = (1, 0), β = 2: √((1 + 2)² + 2²)·1/3 = 1.202 m/s
SPEED_CAP_CASES = {
    "below": (edit("control.speed_limit", 1.19), True),
    "above": (edit("control.speed_limit", 1.21), False),
    "derived": (base(), False),  # the theorem's own cap, (d − r − ρ)/dt, is far above
    "3-d": (edit("control.speed_limit", 1.37, base3d()), True),  # √(9 + 4 + 4)/3 = 1.374
    # a sinusoid's f = (1, 1.257·cos): at its peak √(3² + 3.257²)·1.257/3.257 = 1.709 m/s
    "sinusoid-below": (edit("control.speed_limit", 1.70, sinusoid()), True),
    "sinusoid-above": (edit("control.speed_limit", 1.71, sinusoid()), False),
    "paper-law": (  # the paper's law alone: no filter, no cap to cut it
        edit("control", {**base()["control"], "safety": "paper", "speed_limit": 1.0}),
        False,
    ),
}


def _capped_law_closes(f: Any, beta: float, cap: float) -> bool:
    """Whether the nominal f − β·s, scaled down to ``cap``, moves every coordinate of the error
    against its sign s_c faster than the leader drifts it, for every sign pattern s."""
    for signs in itertools.product((-1.0, 1.0), repeat=len(f)):
        s = np.asarray(signs)
        nominal = f - beta * s
        scale = min(1.0, cap / float(np.linalg.norm(nominal)))
        rate = scale * nominal - f  # de/dt, e the follower's error
        if np.any(rate * s >= 0):
            return False
    return True


def test_the_cap_needed_is_the_least_under_which_every_coordinate_closes() -> None:
    """For f and β drawn at random: under cap_needed·(1 + 1e-9) the capped law closes every
    coordinate for every sign pattern; under cap_needed·(1 − 1e-3) one is left open."""
    rng = np.random.default_rng(31)
    for _ in range(300):
        dim = int(rng.integers(2, 4))
        beta = float(rng.uniform(0.05, 3.0))
        f = rng.uniform(-0.95, 0.95, size=dim) * beta  # |f_c| < β, as Theorem 1 has it
        path = Waypoints(points=((0.0,) * dim, tuple(10.0 * f)), speed=float(np.linalg.norm(f)))
        need = cap_needed(path, beta)
        assert _capped_law_closes(f, beta, need * (1 + 1e-9)), (f, beta)
        assert not _capped_law_closes(f, beta, need * (1 - 1e-3)), (f, beta)


@pytest.mark.parametrize("case", SPEED_CAP_CASES)
def test_speed_cap_warning_when_the_cap_can_cut_the_sign_term(case: str) -> None:
    data, warns = SPEED_CAP_CASES[case]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario_from_dict(data)
    assert [w.category for w in caught] == ([SpeedCapWarning] if warns else [])
    if warns:
        assert "closes every coordinate of a follower's error" in str(caught[0].message)


def test_the_unicycle_speed_cap_warning_names_the_point_cap() -> None:
    data = edit("kinematics", {"model": "unicycle", "lookahead": 0.1, "max_speed": 0.2,
                               "max_turn_rate": 2.0})  # fmt: skip
    data = edit("control.beta", 0.3, data)
    data = edit("leader.speed", 0.2, data)  # needs √(0.5² + 0.3²)·0.2/0.5 = 0.233 m/s
    data = edit("agent_radius", 0.05, data)
    with pytest.warns(SpeedCapWarning, match=r"cap in every direction\) is below 0\.2332"):
        s = scenario_from_dict(data)
    assert s.unicycle is not None
    assert s.unicycle.any_direction(s.dt) < cap_needed(s.path, s.control.beta) < s.speed_limit


# -- field errors -------------------------------------------------------------------------------

FIELD_CASES = [
    (edit("durration", 30.0), "durration", "unknown field .expected one of agent_radius"),
    (edit("control.alpah", 1.0), "control.alpah", "unknown field .expected one of alpha, beta"),
    (edit("agents.1.ofset", [1, 1]), "agents[1].ofset", "unknown field"),
    (edit("dt", "fast"), "dt", "must be a number, got 'fast'"),
    (edit("duration", True), "duration", "must be a number, got True"),
    (edit("control.beta", False), "control.beta", "must be a number, got False"),
    (edit("seed", 1.5), "seed", "must be an integer, got 1.5"),
    (edit("dim", 4), "dim", "must be 2 or 3, got 4"),
    (edit("dt", math.nan), "dt", "must be finite, got nan"),
    (edit("control.beta", math.inf), "control.beta", "must be finite, got inf"),
    (edit("agents.2.offset", [0, -math.inf]), "agents[2].offset[1]", "must be finite"),
    (edit("dt", 0), "dt", "must be > 0, got 0.0"),
    (edit("dt", -0.1), "dt", "must be > 0, got -0.1"),
    (edit("control.alpha", 0.0), "control.alpha", "must be > 0"),
    (edit("agent_radius", -1), "agent_radius", "must be ≥ 0, got -1.0"),
    (edit("obstacles.0.radius", 0), "obstacles[0].radius", "must be > 0"),
    (edit("leader.speed", DELETE), "leader.speed", "missing \\(or empty\\): a number is needed"),
    (edit("duration", 0.001), "duration", "0.001 s is shorter than one step dt = 0.01 s"),
    (edit("agents.2.offset", [1, 2, 3]), "agents[2].offset", "must be a list of 2 numbers"),
    (edit("agents.2.offset", [-3, -3], base3d()), "agents[2].offset",
     "must be a list of 3 numbers, got \\[-3, -3\\]"),
    (edit("agents", [{"offset": [0, 0]}]), "agents", "needs a leader and at least one follower"),
    (edit("graph.edges.1", [1, 9]), "graph.edges[1]", "agent 9 does not exist .ids are 1..4."),
    (edit("graph.edges.0", [0, 2]), "graph.edges[0]", "agent 0 does not exist"),
    (edit("graph.edges.2", [3, 3]), "graph.edges[2]", "a self-loop on agent 3"),
    (edit("graph.edges.0", [1, 2, 3]), "graph.edges[0]", "must be a pair of agent ids"),
    (edit("graph.directed", "yes"), "graph.directed", "must be true or false"),
    (edit("agents.0.offset", [0, 0.1]), "agents[0].offset", "the leader .agent 1. has offset zero"),
    (edit("agents.0.initial", [1, 0]), "agents[0].initial", "the leader starts where its path"),
    (edit("control.trigger_radius", 5.0), "control.trigger_radius",
     "d̄ = 5.0 must be < the sensing radius d = 5.0"),
    (edit("control.trigger_radius", 1.25), "control.trigger_radius",  # r + ρ + ε = 1.25
     "d̄ = 1.25 m must exceed the largest guard radius r_max \\+ ρ \\+ ε = 1.25 m"),
    (edit("obstacles", [*base()["obstacles"], {"centre": [12, 4], "radius": 1.0}]), "obstacles[1]",
     "overlaps obstacles\\[0\\]"),
    (edit("agents.2.initial", [10, 4.5]), "agents[2].initial",
     "agent 3 starts inside obstacles\\[0\\]"),
    (edit("reshape", [{"at": 5.0, "scale": 2.0}, {"at": 4.0}]), "reshape[1].at",
     "reshapes must be listed in time order"),
    (edit("leader.sinusoid", sinusoid()["leader"]["sinusoid"]), "leader",
     "give exactly one of 'waypoints' .with 'speed'. or 'sinusoid'"),
    (edit("leader", {"speed": 1.0}), "leader", "give exactly one of"),
    (edit("leader.sinusoid.direction", [0, 0], sinusoid()), "leader.sinusoid.direction",
     "must not be zero"),
    (edit("leader.waypoints", []), "leader.waypoints", "needs at least one waypoint"),
    (edit("control", [1, 2]), "control", "must be a mapping"),
    (edit("robots", {"namespaces": ["a", "b"]}), "robots.namespaces",
     "needs one per agent \\(4\\), got 2"),
    (edit("robots", {"namespaces": ["a", "b", "1c", "d"]}), "robots.namespaces (agent 3)",
     "must be a ROS 2 name"),
    (edit("robots", {"namespaces": ["a", "b", "/a", "d"]}), "robots.namespaces",
     "/a is given to two agents"),
    (edit("robots", {"domain": 300}), "robots.domain", "a ROS 2 domain id is 0–232, got 300"),
    (edit("robots", {"distro": "iron"}), "robots.distro",
     "must be one of humble, jazzy, kilted, rolling, got 'iron'"),
    (edit("robots", {"pose": "tf"}), "robots.pose", "must be one of odom, pose"),
    (edit("robots", {"pose_timeout": 0}), "robots.pose_timeout", "must be > 0"),
    (edit("robots", {"connect": [7447]}), "robots.connect", "an endpoint is a string"),
    (edit("robots", {"namespace": ["a"]}), "robots.namespace", "unknown field"),
    (edit("robots", [1]), "robots", "must be a mapping"),
]  # fmt: skip


@pytest.mark.parametrize(("data", "field", "message"), FIELD_CASES, ids=[c[1] for c in FIELD_CASES])
def test_field_error_names_the_field(data: dict[str, Any], field: str, message: str) -> None:
    with pytest.raises(ScenarioError, match="^" + re.escape(field) + ": " + message) as info:
        scenario_from_dict(data)
    assert type(info.value) is ScenarioError and info.value.field == field


def test_text_errors() -> None:
    with pytest.raises(ScenarioError, match=r"^yaml: not valid YAML") as info:
        parse_scenario("dt: [0.01,\nagents: {")
    assert info.value.field == "yaml"
    for text in ("- dt: 0.01\n- seed: 1\n", "42", "", "just a string"):
        with pytest.raises(ScenarioError, match=r"^scenario: the file must hold a mapping"):
            parse_scenario(text)
    with pytest.raises(ScenarioError, match=r"^durration: unknown field"):
        parse_scenario(yaml.safe_dump(edit("durration", 1.0)))


def test_missing_file_lists_builtins(tmp_path: Any) -> None:
    known = re.escape(", ".join(builtin_names()))
    with pytest.raises(ScenarioError, match=rf"^scenario: no file 'nosuch' .*\({known}\)$"):
        load_scenario("nosuch")
    with pytest.raises(ScenarioError, match="no built-in of that name"):
        load_scenario(tmp_path / "missing.yaml")


# -- initial positions ---------------------------------------------------------------------------


def test_random_initial_positions_are_seeded() -> None:
    noisy = edit("initial_noise", 1.0)
    a = scenario_from_dict(noisy).initial_positions
    assert np.array_equal(a, scenario_from_dict(copy.deepcopy(noisy)).initial_positions)
    b = scenario_from_dict(edit("seed", 7, noisy)).initial_positions
    assert np.array_equal(a[0], b[0]) and not np.allclose(a[1:], b[1:])
    assert np.abs(a - scenario_from_dict(base()).offsets).max() <= 1.0
    pinned = scenario_from_dict(edit("agents.2.initial", [-3.5, -2.5], noisy)).initial_positions
    assert pinned[2].tolist() == [-3.5, -2.5]
    # every agent draws its jitter, so pinning one does not move the others
    assert np.array_equal(np.delete(pinned, 2, axis=0), np.delete(a, 2, axis=0))


@pytest.mark.parametrize("direction", [[1, 2, 2], [1, 0, 0], [0.3, -0.2, 0.9]])
def test_3d_sinusoid_default_normal_is_unit_and_perpendicular(direction: list[float]) -> None:
    d = edit("leader", {"sinusoid": {"start": [0, 0, 0], "direction": direction, "speed": 0.5,
                                     "amplitude": 0.5, "period": 10.0}}, base3d())  # fmt: skip
    path = scenario_from_dict(edit("obstacles", [], d)).path
    n, u = np.asarray(path.normal), np.asarray(path.direction)
    assert np.linalg.norm(n) == pytest.approx(1.0) and np.linalg.norm(u) == pytest.approx(1.0)
    assert n @ u == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(u, np.asarray(direction) / np.linalg.norm(direction))


# -- extreme values (each was a bug) --------------------------------------------------------------


NO_OBSTACLES = edit("obstacles", [])
HUGE = [[1e308, 0], [1e308, 1]]
CRASHES = [  # (data, must it be refused?): each once let another exception escape, or loaded
    pytest.param(edit("seed", -1), True),
    pytest.param(edit("dt", 10**400), True),
    pytest.param(edit("initial_noise", 1e308), True),
    pytest.param(edit("reshape", [{"at": 1e300}], edit("dt", 1e-300, NO_OBSTACLES)), True),
    pytest.param(edit("duration", 1e20, sinusoid()) | {"obstacles": base()["obstacles"]}, True),
    pytest.param(edit("agents.1.offset", [1e308, 0], edit("leader.waypoints", HUGE, NO_OBSTACLES)),
                 True),
    pytest.param(edit("leader.waypoints", [[0, 0], [-1.7e308, 0]],
                      edit("obstacles", [{"centre": [-1e300, 0], "radius": 1.0}])),
                 True),
]  # fmt: skip


CRASH_IDS = ["neg-seed", "huge-int", "huge-noise", "reshape-tick", "long-sinusoid", "inf-initial",
             "a4-overflow"]  # fmt: skip


@pytest.mark.parametrize(("data", "refuse"), CRASHES, ids=CRASH_IDS)
def test_extreme_values_give_scenario_errors(data: dict[str, Any], refuse: bool) -> None:
    # No RuntimeWarning either: pytest turns warnings into errors.
    with pytest.raises(ScenarioError) if refuse else contextlib.suppress(ScenarioError):
        scenario_from_dict(data)


def test_3d_sinusoid_along_z_gets_a_default_normal() -> None:
    test_3d_sinusoid_default_normal_is_unit_and_perpendicular([0, 0, 1])


# -- property: nothing but ScenarioError escapes -------------------------------------------------

FIELDS = ["dim", "dt", "duration", "seed", "control", "graph", "agents", "leader", "obstacles",
          "reshape", "edges", "offset", "waypoints", "sinusoid", "centre", "radius"]  # fmt: skip
# Magnitudes are bounded: the overflow bugs above are pinned separately.
LEAVES = (
    st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.text(max_size=8)
    | st.floats(-1e6, 1e6).filter(lambda x: x == 0 or abs(x) > 1e-6)
    | st.sampled_from([math.nan, math.inf, -math.inf])
)  # fmt: skip
KEYS = st.sampled_from(FIELDS) | st.text(max_size=6)
VALUES = st.recursive(
    LEAVES, lambda c: st.lists(c, max_size=4) | st.dictionaries(KEYS, c, max_size=4), max_leaves=12
)
FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _only_scenario_errors(call: Any, *args: Any) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.suppress(ScenarioError):
            call(*args)
    allowed = (BetaWarning, DetourWarning, SpeedCapWarning)
    assert all(issubclass(w.category, allowed) for w in caught), [str(w) for w in caught]


@FUZZ
@given(
    st.text(max_size=300) | VALUES.map(yaml.safe_dump) | st.dictionaries(KEYS, VALUES, max_size=6)
)
def test_random_text_or_dict_raises_only_scenario_error(data: str | dict[Any, Any]) -> None:
    _only_scenario_errors(parse_scenario if isinstance(data, str) else scenario_from_dict, data)


def _paths(node: Any, prefix: str = "") -> list[str]:
    if not isinstance(node, dict | list):
        return []
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for k, v in items:
        p = f"{prefix}.{k}" if prefix else str(k)
        out += [p, *_paths(v, p)]
    return out


FULL = base() | {"reshape": [{"at": 5.0, "scale": 1.5, "rotate": 0.5}], "initial_noise": 0.5}
BASE_PATHS = _paths(FULL)


@FUZZ
@given(st.sampled_from(BASE_PATHS), VALUES | st.just(DELETE))
def test_mutated_base_raises_only_scenario_error(path: str, value: Any) -> None:
    if path == "seed" and isinstance(value, int) and value < 0:
        return  # a known bug, pinned in CRASHES
    _only_scenario_errors(scenario_from_dict, edit(path, value, FULL))


def test_a_missing_block_says_missing_and_a_syntax_error_names_the_file(tmp_path: Path) -> None:
    """Not `graph: must be a mapping, got None`, and not `in "<unicode string>"`."""
    empty = tmp_path / "no-graph.yaml"
    empty.write_text(
        "agents: [{offset: [0, 0]}, {offset: [1, 0]}]\n"
        "leader: {waypoints: [[0, 0], [5, 0]], speed: 1}\ngraph:\n"
    )
    with pytest.raises(ScenarioError, match=r"^graph: missing \(or empty\): a mapping is needed"):
        load_scenario(empty)
    broken = tmp_path / "broken.yaml"
    broken.write_text("dim: 2\nagents: [\n  {offset: [0, 0]\n")
    with pytest.raises(ScenarioError, match="not valid YAML") as info:
        load_scenario(broken)
    assert f'in "{broken}", line 3' in str(info.value)
    assert "<unicode string>" not in str(info.value)
