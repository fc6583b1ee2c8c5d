"""The safety tests can fail: each broken filter below (a margin dropped, rows handled one at a
time instead of projected jointly, the cap forgotten, a stop instead of a projection, pruning by
the wrong radius) is caught by the very checkers tests/geometry/test_safety.py holds the real filter
to."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import pytest
from safety_cases import cases, failures

from shoal.bus.messages import Sensing
from shoal.bus.types import Vector
from shoal.geometry import safety
from shoal.geometry.safety import Filtered, Row, cap_speed, project, rows_for, safe_velocity

BATCH = cases(seed=11, count=600)


def _stop_when_infeasible(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
    out = safe_velocity(nominal, s, i, right_hand=False, **kw)
    return tuple(0.0 for _ in nominal) if out.active else out.velocity


def _no_margin(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
    return safe_velocity(nominal, s, i, **{**kw, "margin": 0.0}).velocity


def _no_separation(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
    return safe_velocity(nominal, s, i, **{**kw, "half_separation": 0.0}).velocity


def _one_row_at_a_time(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
    v = cap_speed(nominal, kw["speed_limit"])
    dt = kw["dt"]
    for r in rows_for(s, i, margin=kw["margin"], half_separation=kw["half_separation"]):
        gap = r.bound / dt - sum(g * x for g, x in zip(r.normal, v, strict=True))
        if gap > 0:
            v = tuple(x + gap * g for x, g in zip(v, r.normal, strict=True))
    return v


def _no_cap(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
    return safe_velocity(nominal, s, i, **{**kw, "speed_limit": math.inf}).velocity


def _pruned_by_speed_not_step(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
    """Keeps only rows nearer than ‖v̂‖·dt² (a units slip): drops rows that matter."""
    v = cap_speed(nominal, kw["speed_limit"])
    dt = kw["dt"]
    reach = math.sqrt(sum(x * x for x in v)) * dt * dt
    rows = rows_for(s, i, margin=kw["margin"], half_separation=kw["half_separation"],
                    reach=reach)  # fmt: skip
    return project(v, rows, dt).velocity


MUTANTS: dict[str, tuple[Callable[..., Vector], str]] = {
    "no margin": (_no_margin, "guard"),
    "no separation": (_no_separation, "rows"),
    "one row at a time": (_one_row_at_a_time, "rows"),
    "no speed cap": (_no_cap, "longer"),
    "stop instead of project": (_stop_when_infeasible, "nearest"),
    "pruned by the wrong radius": (_pruned_by_speed_not_step, "rows"),
}


@pytest.mark.parametrize("name", MUTANTS)
def test_a_broken_filter_fails_the_checks(name: str) -> None:
    mutant, caught_by = MUTANTS[name]
    found = failures(mutant, BATCH)
    assert found[caught_by] > 0, found


def test_the_real_filter_passes_the_same_batch() -> None:
    def real(nominal: Vector, s: Sensing, i: int, **kw: float) -> Vector:
        return safe_velocity(nominal, s, i, right_hand=False, **kw).velocity

    assert not any(failures(real, BATCH).values())


def test_a_solver_that_skips_the_multiplier_test_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    """Accepting an equality-constrained point whose multipliers are negative (not a KKT
    point) gives a feasible but farther answer when it is the first accepted."""

    def no_lambda_check(nominal: Vector, chosen: list[Row], dt: float) -> Vector | None:
        gram = [[safety.vdot(a.normal, b.normal) for b in chosen] for a in chosen]
        rhs = [r.bound / dt - safety.vdot(r.normal, nominal) for r in chosen]
        lam = safety._solve(gram, rhs)
        if lam is None:
            return None
        out = list(nominal)
        for w, r in zip(lam, chosen, strict=True):
            for c in range(len(out)):
                out[c] += w * r.normal[c]
        return tuple(out)

    def first_accepted(nominal: Vector, rows: list[Row], dt: float) -> Filtered:
        if safety.satisfies(nominal, rows, dt):
            return Filtered(nominal, active=False)
        for size in range(len(nominal), 0, -1):  # largest sets first: corners before faces
            for chosen in itertools.combinations(rows, size):
                v = no_lambda_check(nominal, list(chosen), dt)
                if v is not None and safety.satisfies(v, rows, dt):
                    return Filtered(v, active=True)
        return Filtered(tuple(0.0 for _ in nominal), active=True, fallback=True)

    monkeypatch.setattr(safety, "project", first_accepted)
    found = failures(lambda *a, **k: safety.safe_velocity(*a, right_hand=False, **k).velocity,
                     BATCH)  # fmt: skip
    assert found["nearest"] > 0, found
