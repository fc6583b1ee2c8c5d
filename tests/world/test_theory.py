"""Theorem 1 and Remark 3 convergence bounds and the formation error; world/theory.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shoal.agent.formation import consensus_error, velocity
from shoal.world.graph import adjacency
from shoal.world.theory import convergence_bound, formation_error, remark3_bound, theorem1_bound

# 3 agents on a path 1-2-3: M = [[2, -1], [-1, 1]], eigenvalues (3 ± √5)/2 = φ², 1/φ².
PATH3 = adjacency(3, [(1, 2), (2, 3)], directed=False)
OFFSETS = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
POSITIONS = np.array([[0.0, 0.0], [2.0, 0.0], [4.0, 3.0]])
Z0 = np.array([[1.0, 0.0], [2.0, 3.0]])  # formation error of POSITIONS


def test_formation_error_hand_computed() -> None:
    np.testing.assert_allclose(formation_error(POSITIONS, OFFSETS), Z0)


def test_formation_error_zero_at_desired_formation() -> None:
    rng = np.random.default_rng(50)
    offsets = rng.normal(size=(6, 3))
    offsets[0] = 0.0
    positions = rng.normal(size=3) + offsets
    z = formation_error(positions, offsets)
    assert z.shape == (5, 3)
    np.testing.assert_allclose(z, 0.0, atol=1e-12)


def test_theorem1_bound_hand_computed() -> None:
    # x: zᵀMz = 2·1 - 2·1·2 + 4 = 2, margin 1 -> √(2 λmax)/λmin = √2 φ³.
    # y: zᵀMz = 9, margin 1.5 -> 3φ/(1.5/φ²) = 2φ³ = 4 + 2√5 ≈ 8.472, the larger.
    bound = theorem1_bound(PATH3, Z0, beta=2.0, f_max=np.array([1.0, 0.5]))
    assert bound == pytest.approx(4.0 + 2.0 * math.sqrt(5.0), rel=1e-12)


def test_theorem1_bound_takes_worst_coordinate() -> None:
    # Margin 0.5 in x: √2 φ³ / 0.5 = 2√2 (2 + √5) ≈ 11.98 now beats y's 8.47.
    bound = theorem1_bound(PATH3, Z0, beta=2.0, f_max=np.array([1.5, 0.5]))
    assert bound == pytest.approx(2.0 * math.sqrt(2.0) * (2.0 + math.sqrt(5.0)), rel=1e-12)


def test_theorem1_bound_zero_at_desired_formation() -> None:
    assert theorem1_bound(PATH3, np.zeros((2, 2)), beta=2.0, f_max=np.array([1.0, 1.0])) == 0.0


@pytest.mark.parametrize("f_max", [(2.0, 0.0), (0.0, 2.5), (3.0, 3.0)])
def test_bounds_are_inf_when_beta_not_above_f_max(f_max: tuple[float, float]) -> None:
    f = np.array(f_max)
    assert theorem1_bound(PATH3, Z0, beta=2.0, f_max=f) == math.inf
    assert remark3_bound(Z0, beta=2.0, f_max=f) == math.inf


def test_remark3_bound_hand_computed() -> None:
    # x: max |z| = 2 over margin 1 -> 2; y: 3 over 1.5 -> 2.
    assert remark3_bound(Z0, beta=2.0, f_max=np.array([1.0, 0.5])) == pytest.approx(2.0)
    # x margin 0.5 -> 4.
    assert remark3_bound(Z0, beta=2.0, f_max=np.array([1.5, 0.5])) == pytest.approx(4.0)
    assert remark3_bound(-Z0, beta=2.0, f_max=np.array([1.5, 0.5])) == pytest.approx(4.0)


def test_convergence_bound_dispatches_on_graph_kind() -> None:
    f = np.array([1.0, 0.5])
    assert convergence_bound(PATH3, Z0, directed=True, beta=2.0, f_max=f) == pytest.approx(2.0)
    assert convergence_bound(PATH3, Z0, directed=False, beta=2.0, f_max=f) == pytest.approx(
        4.0 + 2.0 * math.sqrt(5.0)
    )


def test_simulated_convergence_within_theorem1_bound() -> None:
    # Law (1) on the 3-agent path, leader at 1 m/s along x, β = 2; Euler dt = 1e-3.
    dt, beta = 1e-3, 2.0
    x = POSITIONS.copy()
    bound = theorem1_bound(PATH3, Z0, beta=beta, f_max=np.array([1.0, 0.0]))
    settled_at = None
    for k in range(int(bound / dt) + 1):
        z = formation_error(x, OFFSETS)
        if np.abs(z).max() <= 25 * beta * dt:
            settled_at = k * dt
            break
        v = np.zeros_like(x)
        v[0] = [1.0, 0.0]
        for i in (1, 2):
            nb = np.flatnonzero(PATH3[i])
            e = consensus_error(x[i], OFFSETS[i], x[nb], OFFSETS[nb])
            v[i] = velocity(e, alpha=1.0, beta=beta, boundary_layer=0.0)
        x = x + dt * v
    assert settled_at is not None
    assert settled_at <= bound
