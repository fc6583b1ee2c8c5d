"""Deadlocks in crowds (geometry/safety.py ``slide_right``): a jammed agent follows the
right-hand face of its cell, so a symmetric crowd unwinds like a roundabout; the answer is still
a projection onto the filter's rows, so nothing about safety changes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shoal.bus.messages import Sensing
from shoal.geometry.safety import project, rows_for, safe_velocity, satisfies, sidestep, slide_right
from shoal.geometry.vectors import right_of
from shoal.tools.simulator import simulate
from shoal.world.loader import scenario_from_dict
from shoal.world.metrics import formation_errors, summarize

DT, R = 0.01, 0.2  # s; half the separation, m


def _jammed() -> Sensing:
    """The jam of the ring of eight, as one follower met it: the leader straight ahead (its slot
    lies beyond) and a neighbour on either side, each at exactly the separation 2R."""
    others = ((-2 * R, 0.0), (0.0, 2 * R), (0.0, -2 * R))
    return Sensing(0, (0.0, 0.0), (), (), (), (1, 3, 4), others)


def test_a_jammed_agent_follows_the_right_hand_face_of_its_cell() -> None:
    sensing, nominal = _jammed(), (-2.0, 0.0)
    rows = rows_for(sensing, 2, margin=0.2, half_separation=R)
    kwargs = {"dt": DT, "margin": 0.2, "half_separation": R, "speed_limit": 5.0}
    bare = safe_velocity(nominal, sensing, 2, right_hand=False, **kwargs).velocity
    assert bare == (0.0, 0.0)  # the projection alone: stuck for good
    turned = sidestep(nominal, bare, rows, DT)  # the right-hand turn of the nominal: blocked too
    assert turned is not None and project(turned, rows, DT).velocity == (0.0, 0.0)
    v = safe_velocity(nominal, sensing, 2, **kwargs).velocity
    assert satisfies(v, rows, DT)
    # along the face of the neighbour on its left, to the right of it: backing off, at the
    # nominal's speed (nothing else holds that way)
    assert v[0] == pytest.approx(2.0, abs=1e-12) and v[1] == pytest.approx(0.0, abs=1e-12)


def test_an_agent_that_still_moves_is_not_turned() -> None:
    sensing = Sensing(0, (0.0, 0.0), (), (), (), (2,), ((0.0, 2 * R),))  # beside, not ahead
    rows = rows_for(sensing, 1, margin=0.2, half_separation=R)
    assert slide_right((2.0, 0.1), (2.0, 0.0), rows, DT) is None


def _ring(n: int, radius: float, dim: int, tilt: float = 0.0) -> dict[str, object]:
    """n followers on a ring round a standing leader, star plus ring edges, rotated by π at 2 s:
    every follower's slot is the opposite point, straight through the leader."""
    offsets = [[0.0] * dim]
    for k in range(n):
        a = 2 * math.pi * k / n
        x, y = radius * math.cos(a), radius * math.sin(a)
        offsets.append([x, y] if dim == 2 else [x, y * math.cos(tilt), y * math.sin(tilt)])
    edges = [[1, i] for i in range(2, n + 2)] + [[i, i + 1] for i in range(2, n + 1)] + [[n + 1, 2]]
    return {
        "dim": dim, "dt": DT, "duration": 12.0,
        "graph": {"edges": edges},
        "agents": [{"offset": o} for o in offsets],
        "leader": {"waypoints": [[0.0] * dim, [0.0] * dim], "speed": 0.5},
        "reshape": [{"at": 2.0, "rotate": math.pi}],
    }  # fmt: skip


@pytest.mark.parametrize(
    ("n", "radius", "dim", "tilt"),
    [(8, 3.0, 2, 0.0), (16, 5.0, 2, 0.0), (8, 3.0, 3, 0.0), (8, 3.0, 3, 0.5)],
)
def test_a_ring_sent_through_its_centre_swaps_and_settles(
    n: int, radius: float, dim: int, tilt: float
) -> None:
    """A ring of eight (and a bigger one, and in 3-D, flat and tilted): before the
    rule every follower stopped 0.4–0.57 m from the leader for the rest of the run."""
    scn = scenario_from_dict(_ring(n, radius, dim, tilt))
    traj = simulate(scn)
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.min_interagent_distance >= scn.separation - 1e-9
    worst = formation_errors(scn, traj).max(axis=1)
    late = np.flatnonzero(worst > scn.tolerance)
    assert late[-1] * scn.dt < 2.0 + 5.0  # settled within 5 s of the reshape, and stays
    assert s.final_formation_error <= scn.tolerance


def test_two_agents_head_on_along_the_vertical_turn_opposite_ways() -> None:
    """In 3-D "right" is heading × z; for a vertical heading both ends of a pair once took the
    same x axis, slid side by side the same way and stayed head on."""
    up, down = right_of((0.0, 0.0, 1.0)), right_of((0.0, 0.0, -1.0))
    assert up == tuple(-x for x in down) and up != (0.0, 0.0, 0.0)
