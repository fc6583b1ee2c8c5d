"""Cases and checkers for the safety filter's properties (tests/geometry/test_safety.py), written
against any filter with the signature of :func:`shoal.geometry.safety.safe_velocity`, so that
the same checkers can be shown to catch broken filters (tests/geometry/test_safety_mutants.py).

A case is one agent at a safe position among obstacles and other agents, often right at a guard
circle or a cell edge (where corners of several rows meet), with an arbitrary nominal velocity.
Distances in m, velocities in m/s.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from shoal.bus.messages import Sensing
from shoal.bus.types import Vector
from shoal.geometry.safety import Row, rows_for

Filter = Callable[..., tuple[float, ...]]
SLACK = 1e-9  # m: what the whole-step checks allow for rounding (the filter's own is 1e-12)


@dataclass(frozen=True)
class Case:
    sensing: Sensing
    nominal: Vector
    dt: float
    margin: float  # ρ
    half_separation: float  # R
    speed_limit: float
    previous: Vector | None = None  # the velocity held at the last tick (keep_going's input)

    def rows(self) -> list[Row]:
        return rows_for(self.sensing, 1, margin=self.margin, half_separation=self.half_separation)

    def run(self, f: Filter) -> tuple[float, ...]:
        return tuple(
            f(
                self.nominal,
                self.sensing,
                1,
                dt=self.dt,
                margin=self.margin,
                half_separation=self.half_separation,
                speed_limit=self.speed_limit,
                **({} if self.previous is None else {"previous": self.previous}),
            )
        )


def _near_surface(
    rng: np.random.Generator, centre: np.ndarray, keep: float, dim: int
) -> np.ndarray:
    """A point at distance keep + (0 … a little) from ``centre``: at the boundary, mostly."""
    u = rng.normal(size=dim)
    u /= np.linalg.norm(u)
    extra = 0.0 if rng.random() < 0.3 else float(rng.exponential(0.05))
    return np.asarray(centre + u * (keep + extra), dtype=np.float64)


def random_case(rng: np.random.Generator, dim: int | None = None) -> Case:
    """One agent (id 1) at the origin-ish, up to 4 obstacles and 3 agents crowding it."""
    dim = dim or int(rng.choice([2, 3]))
    margin = float(rng.uniform(0.0, 0.4))
    half = float(rng.uniform(0.05, 0.5))
    dt = float(rng.choice([0.001, 0.01, 0.05]))
    pos = np.zeros(dim)
    centres, radii = [], []
    for _ in range(int(rng.integers(0, 5))):
        r = float(rng.uniform(0.1, 2.0))
        centres.append(_near_surface(rng, pos, r + margin, dim))
        radii.append(r)
    others = [_near_surface(rng, pos, 2 * half, dim) for _ in range(int(rng.integers(0, 4)))]
    speed = float(rng.exponential(3.0))
    direction = rng.normal(size=dim)
    nominal = tuple(float(x) for x in direction / np.linalg.norm(direction) * speed)
    if rng.random() < 0.2:
        nominal = tuple(0.0 for _ in range(dim))
    sensing = Sensing(
        tick=0,
        position=tuple(float(x) for x in pos),
        obstacle_ids=tuple(range(len(radii))),
        obstacle_centres=tuple(tuple(float(x) for x in c) for c in centres),
        obstacle_radii=tuple(radii),
        agent_ids=tuple(range(2, 2 + len(others))),
        agent_positions=tuple(tuple(float(x) for x in q) for q in others),
    )
    limit = float(rng.uniform(0.5, 30.0))
    previous = tuple(float(x) for x in rng.normal(size=dim) * rng.uniform(0.0, 10.0))
    return Case(sensing, nominal, dt, margin, half, limit, previous if rng.random() < 0.7 else None)


def cases(seed: int, count: int) -> list[Case]:
    rng = np.random.default_rng(seed)
    return [random_case(rng) for _ in range(count)]


# -- the properties --------------------------------------------------------------------------


def capped(case: Case) -> np.ndarray:
    v = np.asarray(case.nominal)
    speed = float(np.linalg.norm(v))
    return v if speed <= case.speed_limit else v * (case.speed_limit / speed)


def violates_rows(case: Case, v: tuple[float, ...]) -> bool:
    """Some row g·v·dt ≥ h fails by more than SLACK."""
    return any(float(np.dot(r.normal, v)) * case.dt < r.bound - SLACK for r in case.rows())


def step_leaves_guard(case: Case, v: tuple[float, ...]) -> bool:
    """Somewhere along the step s + t·v·dt (t ∈ [0, 1]) the agent is inside a guard circle
    r_j + ρ (the closest point of the segment to the centre, exactly)."""
    s = np.asarray(case.sensing.position)
    step = np.asarray(v) * case.dt
    for c, r in zip(case.sensing.obstacle_centres, case.sensing.obstacle_radii, strict=True):
        if segment_gap(np.asarray(c), s, s + step) < r + case.margin - SLACK:
            return True
    return False


def segment_gap(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from p to the segment a–b, written here again on purpose: the checkers do not
    trust the code they check."""
    ab = b - a
    length2 = float(ab @ ab)
    t = 0.0 if length2 == 0 else min(1.0, max(0.0, float((p - a) @ ab) / length2))
    return float(np.linalg.norm(p - (a + t * ab)))


def longer_than_nominal(case: Case, v: tuple[float, ...]) -> bool:
    return float(np.linalg.norm(v)) > float(np.linalg.norm(capped(case))) * (1 + 1e-12) + 1e-15


def brute_force(case: Case) -> np.ndarray:
    """The projection of the capped nominal by brute force, independent of the solver's active
    sets, multipliers and pruning: the nearest feasible point among the nominal itself and its
    projections onto the affine hull of every set of at most ``dim`` rows (the optimum is one
    of them), with numpy's least squares."""
    rows = case.rows()
    target = capped(case).astype(np.float64)
    best, best_dist = None, np.inf
    candidates = [target]
    for size in range(1, min(len(target), len(rows)) + 1):
        for chosen in itertools.combinations(rows, size):
            g = np.asarray([r.normal for r in chosen])
            c = np.asarray([r.bound / case.dt for r in chosen])
            if np.linalg.matrix_rank(g) < size:
                continue
            lam = np.linalg.solve(g @ g.T, c - g @ target)
            candidates.append(target + g.T @ lam)
    candidates.append(np.zeros_like(target))  # feasible for a safe agent
    for x in candidates:
        if violates_rows(case, tuple(x.tolist())):
            continue
        dist = float(np.linalg.norm(x - target))
        if dist < best_dist:
            best, best_dist = x, dist
    assert best is not None
    return best


def not_nearest(case: Case, v: tuple[float, ...]) -> bool:
    """Farther from the capped nominal than the brute-force projection (beyond rounding)."""
    target = capped(case)
    ref = brute_force(case)
    scale = max(1.0, float(np.linalg.norm(target)))
    return (
        float(np.linalg.norm(np.asarray(v) - target))
        > float(np.linalg.norm(ref - target)) + 1e-9 * scale
    )


CHECKS: dict[str, Callable[[Case, tuple[float, ...]], bool]] = {
    "rows": violates_rows,
    "guard": step_leaves_guard,
    "longer": longer_than_nominal,
    "nearest": not_nearest,
}


def failures(f: Filter, batch: list[Case]) -> dict[str, int]:
    """How many cases of ``batch`` each check finds wrong with filter ``f``."""
    out = dict.fromkeys(CHECKS, 0)
    for case in batch:
        v = case.run(f)
        for name, check in CHECKS.items():
            if check(case, v):
                out[name] += 1
    return out


def pair_gap_along_step(
    a: np.ndarray, va: np.ndarray, b: np.ndarray, vb: np.ndarray, dt: float
) -> float:
    """The least distance between two agents moving straight over one step (exact)."""
    rel, drel = a - b, (va - vb) * dt
    d2 = float(drel @ drel)
    t = 0.0 if d2 == 0 else min(1.0, max(0.0, -float(rel @ drel) / d2))
    return float(np.linalg.norm(rel + t * drel))


def unit(rng: np.random.Generator, dim: int) -> np.ndarray:
    u = rng.normal(size=dim)
    return np.asarray(u / math.sqrt(float(u @ u)), dtype=np.float64)
