"""Each robot's own safety layer (world/onboard.py, docs/safety.md "Without a referee"): robots
that know each other only from a late and lossy radio never come within 2R of each other,
between ticks too, whatever they are told to do — and the layers that forget the age of what
they heard, do not wait for the snapshot, or use the last-heard positions as if they were
fresh (the Crazyflie's buffered Voronoi cells) let robots collide on the same runs."""

from __future__ import annotations

import dataclasses
import math
import random
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shoal.bus.types import ControlParams, Vector
from shoal.geometry.safety import Row
from shoal.world.kinematics import estimated, sense_all
from shoal.world.loader import load_scenario
from shoal.world.onboard import Link, OnboardLayers, epoch_ticks, plane_row

DT = 0.1
R = 0.5  # half the separation, m
RHO = 0.4  # guard margin, m
VMAX = 1.0  # m/s
CENTRE = np.array([[0.0, 0.0]])  # one standing obstacle, radius 0.5 m
RADIUS = np.array([0.5])
SLACK = 1e-9


def _params() -> ControlParams:
    base = load_scenario("default").params()
    return dataclasses.replace(
        base, speed_limit=VMAX, separation=2 * R, safety_margin=RHO, sensing_radius=50.0
    )


def _closest(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> float:
    """Least distance between two points moving straight from a0 to a1 and b0 to b1 at once."""
    r0, dr = a0 - b0, (a1 - a0) - (b1 - b0)
    den = float(dr @ dr)
    t = 0.0 if den == 0.0 else min(1.0, max(0.0, -float(r0 @ dr) / den))
    return float(np.linalg.norm(r0 + t * dr))


def _to_guard(a0: np.ndarray, a1: np.ndarray) -> float:
    return _closest(a0, a1, CENTRE[0], CENTRE[0]) - RADIUS[0]


def _start(rng: random.Random, n: int, apart: float) -> np.ndarray:
    """n robots in a 5 m box, ``apart`` m apart and outside the guard (drawn until they are)."""
    while True:
        pts = np.array([[rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5)] for _ in range(n)])
        gaps = [np.linalg.norm(pts[a] - pts[b]) for a in range(n) for b in range(a)]
        guard = np.linalg.norm(pts - CENTRE, axis=1) - RADIUS
        if min(gaps) >= apart and guard.min() >= RHO:
            return pts


def swarm(
    seed: int,
    layers: Callable[..., OnboardLayers] = OnboardLayers,
    ticks: int = 80,
    error: float = 0.0,
) -> tuple[float, float]:
    """Robots told, tick by tick, to drive at the speed limit towards where another one is (on
    half the runs always the nearest; or anywhere), through their layers over a radio drawn
    from ``seed``; (least distance between two robots − 2R, least distance to the obstacle −
    ρ), both along the whole steps. ``error``: each robot believes it is up to that far from
    where it is (constant; the layers keep 2R + 2·error between the beliefs)."""
    rng = random.Random(seed)
    n = rng.randint(2, 5)
    delay = rng.choice([0.0, 0.4, 1.0, 2.5, 4.0, 7.0])
    chase = rng.random() < 0.5  # every robot always at the nearest other, head on
    link = Link(
        delay=delay, jitter=rng.uniform(0.0, delay), drop_rate=rng.choice([0.0, 0.1, 0.4]),
        seed=seed,
    )  # fmt: skip
    params = dataclasses.replace(_params(), separation=2 * R + 2 * error)
    layer = layers(params, DT, rng.randint(2, 8), link, n)
    pos = _start(rng, n, 2 * R + 4 * error)
    way = np.array([[rng.gauss(0, 1), rng.gauss(0, 1)] for _ in range(n)])
    bias = way / np.linalg.norm(way, axis=1, keepdims=True) * error * rng.random()
    pair, guard = math.inf, math.inf
    for k in range(ticks):
        wanted = np.zeros((n, 2))
        for i in range(n):
            if chase:
                j = min(
                    (q for q in range(n) if q != i), key=lambda q: np.linalg.norm(pos[q] - pos[i])
                )
                way = pos[j] - pos[i]
            elif rng.random() < 0.8:
                j = rng.choice([q for q in range(n) if q != i])
                way = pos[j] - pos[i]
            else:
                way = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1)])
            size = float(np.linalg.norm(way))
            wanted[i] = way / size * VMAX * rng.choice([0.5, 1.0, 1.0]) if size > 0 else 0.0
        sensings = estimated(sense_all(k, pos, CENTRE, RADIUS, 50.0), bias)
        held = layer.act(k, sensings, wanted)
        assert np.all(np.linalg.norm(held.velocities, axis=1) <= VMAX * (1 + 1e-9))
        nxt = pos + DT * held.velocities
        for a in range(n):
            guard = min(guard, _to_guard(pos[a], nxt[a]) - RHO)
            for b in range(a):
                pair = min(pair, _closest(pos[a], nxt[a], pos[b], nxt[b]) - 2 * R)
        pos = nxt
    return pair, guard


@settings(max_examples=120, deadline=None)
@given(st.integers(min_value=0, max_value=10**6))
def test_robots_that_hear_each_other_late_and_lossily_never_meet(seed: int) -> None:
    pair, guard = swarm(seed)
    assert pair >= -SLACK, pair
    assert guard >= -SLACK, guard


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=0, max_value=10**6))
def test_robots_that_misjudge_where_they_are_by_up_to_e_still_keep_2r(seed: int) -> None:
    pair, guard = swarm(seed, error=0.1)
    assert pair >= -SLACK, pair
    assert guard >= -SLACK, guard


def test_the_radio_is_seeded_late_and_lossy_as_asked() -> None:
    link = Link(delay=2.0, jitter=1.0, drop_rate=0.25, seed=3)
    got = [link.arrival(1, 2, t) for t in range(4000)]
    lost = sum(a is None for a in got)
    late = [a - t for t, a in enumerate(got) if a is not None]
    assert 800 < lost < 1200  # 25 % of 4,000
    assert set(late) == {2, 3}  # ceil of 2 ± 1 ticks (exactly 1 has probability 0)
    assert got == [link.arrival(1, 2, t) for t in range(4000)]  # the same draws again
    assert Link().arrival(1, 2, 7) == 7
    with pytest.raises(ValueError, match="jitter"):
        Link(delay=1.0, jitter=2.0)


def test_a_pair_standing_at_the_snapshot_may_go_to_the_cell_edge_and_not_beyond() -> None:
    """The plane row: from the snapshot positions D apart, each robot may end its step at
    τ = min(R, D/2) from the bisector; a step beyond it breaks the row."""
    own, other = (0.0, 0.0), (1.6, 0.0)
    row = plane_row(own, own, other, 0.5, lower=True)
    assert row.normal == (-1.0, 0.0)
    assert row.bound == pytest.approx(-0.3)  # 0.8 deep, may lose 0.3
    assert not _meets(row, (3.01, 0.0)) and _meets(row, (2.99, 0.0))
    close = plane_row(own, own, (0.6, 0.0), 0.5, lower=True)  # nearer than 2R: no deeper
    assert close.bound == 0.0


def _meets(row: Row, v: Vector) -> bool:
    return sum(g * x for g, x in zip(row.normal, v, strict=True)) * DT >= row.bound - 1e-12


def test_an_epoch_is_at_least_two_ticks() -> None:
    assert epoch_ticks(0.1, 0.01) == 10 and epoch_ticks(0.1, 0.05) == 2
    assert epoch_ticks(0.01, 0.033) == 2


# -- mutants: each broken layer lets robots meet on some of these runs ------------------------


class _AgeIgnored(OnboardLayers):
    """The far test trusts a last-heard position as if it were of the snapshot tick."""

    def may_be_near(self, own: Vector, heard: tuple[int, Vector] | None, k: int) -> bool:
        return heard is None or math.dist(own, heard[1]) < self.far


class _NoWait(OnboardLayers):
    """Moves freely before a snapshot has arrived, within the cells it already knows."""

    def cell(self, i: int, k: int, now: Vector) -> tuple[list[Row], float]:
        return super().cell(i, k, now)[0], math.inf


class _LeewayWithoutAge(OnboardLayers):
    """Gives a robot leeway as if the neighbour were still where it was last heard."""

    def leeway(self, own: Vector, heard: tuple[int, Vector] | None, k: int) -> float:
        return 0.0 if heard is None else max(0.0, math.dist(own, heard[1]) / 2.0 - self.half)


class _StaleCells(OnboardLayers):
    """Buffered Voronoi cells against each neighbour's last-heard position, as if it were now
    (what the Crazyflie firmware does with positions younger than 5 s)."""

    def cell(self, i: int, k: int, now: Vector) -> tuple[list[Row], float]:
        out = []
        for q in range(len(self.snapshot)):
            heard = self._heard(q, i, k) if q != i else None
            if heard is not None:
                out.append(plane_row(now, now, heard[1], self.half, lower=i < q))
        return out, math.inf


class _NoEpochMargin(OnboardLayers):
    """Calls a pair far at 2R, forgetting what both may do in an epoch."""

    @staticmethod
    def far_for(params: ControlParams, dt: float, epoch: int) -> float:
        return params.separation


@pytest.mark.parametrize(
    "mutant", [_AgeIgnored, _NoWait, _LeewayWithoutAge, _StaleCells, _NoEpochMargin]
)
def test_each_broken_layer_lets_robots_meet(mutant: type[OnboardLayers]) -> None:
    worst = min(swarm(seed, mutant)[0] for seed in range(60))
    assert worst < -1e-3, f"{mutant.__name__} kept every pair apart (least gap {worst})"
