"""Position error (docs/safety.md, Position error): every robot believes it is b_i away from where
it is, |b_i| ≤ e, constant over the run. What it senses of obstacles and people is relative, so
it moves with its error; the other robots it knows by their own estimates. The filter keeps
2R + 2e between estimates, so the robots keep 2R; lockstep stays equal to the reference bit for
bit; and a filter that forgets the widening lets robots closer than 2R on the same run."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from memoryrun import recorded, run_in_memory, short

from shoal.bus.memory import MemoryBus
from shoal.tools.simulator import simulate
from shoal.world.errors import ScenarioError
from shoal.world.kinematics import estimated, sense_all
from shoal.world.loader import parse_scenario, scenario_from_dict
from shoal.world.metrics import summarize
from shoal.world.scenario import Scenario

E = 0.05


def _ring(error: float) -> Scenario:
    """Eight followers on a ring round a standing leader, rotated by π: every slot straight
    through the leader, so the robots press on each other's cells for seconds."""
    n, radius = 8, 3.0
    offsets = [[0.0, 0.0]] + [
        [radius * math.cos(2 * math.pi * k / n), radius * math.sin(2 * math.pi * k / n)]
        for k in range(n)
    ]
    edges = [[1, i] for i in range(2, n + 2)] + [[i, i + 1] for i in range(2, n + 1)] + [[n + 1, 2]]
    return scenario_from_dict({
        "dt": 0.01, "duration": 8.0, "position_error": error,
        "graph": {"edges": edges},
        "agents": [{"offset": o} for o in offsets],
        "leader": {"waypoints": [[0.0, 0.0], [0.0, 0.0]], "speed": 0.5},
        "reshape": [{"at": 1.0, "rotate": math.pi}],
    })  # fmt: skip


def test_each_robot_senses_with_its_own_error_and_the_others_by_theirs() -> None:
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]])
    biases = np.array([[0.03, -0.01], [0.0, 0.04], [-0.02, 0.0]])
    centres, radii = np.array([[0.5, 1.0]]), np.array([0.2])
    true = sense_all(0, positions, centres, radii, 5.0)
    seen = estimated(true, biases)
    for i, s in enumerate(seen):
        assert s.position == pytest.approx(tuple(positions[i] + biases[i]))
        # the obstacle where the robot's range sensor puts it: the true offset from the robot
        offset = np.subtract(s.obstacle_centres[0], s.position)
        assert offset == pytest.approx(centres[0] - positions[i])
        for q, p in zip(s.agent_ids, s.agent_positions, strict=True):
            assert p == pytest.approx(tuple(positions[q - 1] + biases[q - 1]))  # q's estimate
        assert s.agent_ids == true[i].agent_ids  # sensed by the true range


def test_the_errors_are_seeded_bounded_and_none_without_error() -> None:
    scn = _ring(E)
    b = scn.position_biases
    assert b is not None and b.shape == (9, 2)
    assert np.linalg.norm(b, axis=1).max() <= E and np.linalg.norm(b, axis=1).min() > 0
    assert np.array_equal(b, _ring(E).position_biases)  # the same draws again
    assert _ring(0.0).position_biases is None
    assert scn.params().separation == pytest.approx(scn.separation + 2 * E)


def test_the_robots_keep_2r_though_each_is_off_by_up_to_e() -> None:
    scn = _ring(E)
    s = summarize(scn, simulate(scn))
    assert s.collisions == 0
    assert s.min_interagent_distance >= scn.separation - 1e-9
    assert s.min_clearance is None or s.min_clearance >= scn.control.safety_margin - 1e-9


def test_a_filter_that_forgets_the_error_lets_robots_closer_than_2r() -> None:
    """The same ring, the same errors, the filter keeping only 2R between estimates."""
    scn = _ring(E)
    forgetful = dataclasses.replace(scn, position_error=0.0)
    object.__setattr__(forgetful, "position_biases", scn.position_biases)  # errors, no widening
    s = summarize(forgetful, simulate(forgetful))
    assert s.min_interagent_distance < scn.separation - 1e-3


def test_lockstep_with_position_error_equals_the_reference_bit_for_bit() -> None:
    scn = dataclasses.replace(short("obstacles", 4.0), position_error=E)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus)
    assert not errors, errors
    assert recorded(bus, scn.dt).equals(simulate(scn))
    assert not recorded(bus, scn.dt).equals(simulate(short("obstacles", 4.0)))  # it mattered
    assert summary["collisions"] == 0


def test_a_bad_position_error_is_named() -> None:
    text = (
        "agents:\n  - offset: [0, 0]\n  - offset: [-3, 0]\nposition_error: -0.1\n"
        "graph: {edges: [[1, 2]]}\nleader: {waypoints: [[0, 0], [5, 0]], speed: 1}\n"
    )
    with pytest.raises(ScenarioError, match="position_error"):
        parse_scenario(text)
    close = {
        "position_error": 0.1, "initial_noise": 0.0, "graph": {"edges": [[1, 2]]},
        "agents": [{"offset": [0, 0]}, {"offset": [-0.7, 0]}],
        "leader": {"waypoints": [[0, 0], [5, 0]], "speed": 1.0},
    }  # fmt: skip
    with pytest.raises(ScenarioError, match="position_error"):
        scenario_from_dict(close)  # 0.7 m < 2R + 4e = 0.8 m
