"""Least distances over whole steps (world/sweep.py) against a brute-force fine sampling."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from shoal.world.sweep import step_clearances, step_separations

SAMPLES = 10_001  # per step, ends included


def _walk(rng: np.random.Generator, steps: int, n: int, dim: int) -> np.ndarray:
    """(steps+1, n, dim) positions anywhere in a box of ±4 m; one step in ten stands still."""
    positions = rng.uniform(-4.0, 4.0, size=(steps + 1, n, dim))
    for k, i in zip(*np.nonzero(rng.random((steps, n)) < 0.1), strict=True):
        positions[k + 1, i] = positions[k, i]
    return positions


def _sampled(positions: np.ndarray, k: int) -> np.ndarray:
    """(SAMPLES, n, dim) positions along step k."""
    u = np.linspace(0.0, 1.0, SAMPLES)[:, None, None]
    return positions[k] + u * (positions[k + 1] - positions[k])


@pytest.mark.parametrize("dim", [2, 3])
def test_step_clearance_is_the_least_of_a_fine_sampling_of_the_step(dim: int) -> None:
    rng = np.random.default_rng(29 + dim)
    positions = _walk(rng, steps=60, n=3, dim=dim)
    centres = rng.uniform(-4.0, 4.0, size=(4, dim))
    radii = rng.uniform(0.3, 1.5, size=4)
    got = step_clearances(positions, centres, radii)
    assert got.shape == (60, 3, 4)
    inside = 0
    for k in range(60):
        along = _sampled(positions, k)
        brute = (np.linalg.norm(along[:, :, None] - centres, axis=-1) - radii).min(axis=0)
        # the distance is 1-Lipschitz: between samples it can dip by half their spacing
        spacing = np.linalg.norm(positions[k + 1] - positions[k], axis=-1)[:, None] / (SAMPLES - 1)
        assert np.all(got[k] <= brute + 1e-12)
        assert np.all(got[k] >= brute - spacing / 2 - 1e-12)
        inside += int((brute < 0).sum())
    assert inside > 0  # some steps do go through a disc


def test_step_separation_is_the_least_of_a_fine_sampling_of_the_step() -> None:
    rng = np.random.default_rng(2029)
    positions = _walk(rng, steps=60, n=4, dim=2)
    got = step_separations(positions)
    pairs = list(itertools.combinations(range(4), 2))
    assert got.shape == (60, len(pairs))
    for k in range(60):
        along = _sampled(positions, k)
        for col, (i, j) in enumerate(pairs):
            brute = float(np.linalg.norm(along[:, i] - along[:, j], axis=-1).min())
            rel = (positions[k + 1, i] - positions[k + 1, j]) - (positions[k, i] - positions[k, j])
            spacing = float(np.linalg.norm(rel)) / (SAMPLES - 1)
            assert brute - spacing / 2 - 1e-12 <= got[k, col] <= brute + 1e-12


def test_a_step_through_a_disc_is_inside_though_both_ticks_are_clear() -> None:
    positions = np.array([[[-2.0, 0.0]], [[2.0, 0.0]]])  # one agent, one step through (0, 0)
    got = step_clearances(positions, np.zeros((1, 2)), np.array([0.5]))
    assert got.shape == (1, 1, 1)
    assert got[0, 0, 0] == -0.5  # through the centre: the whole radius
    ticks = np.linalg.norm(positions[:, 0], axis=-1) - 0.5
    assert ticks.tolist() == [1.5, 1.5]


def test_two_agents_that_swap_places_pass_within_their_least_distance() -> None:
    positions = np.array([[[-1.0, 0.0], [1.0, 0.1]], [[1.0, 0.0], [-1.0, 0.1]]])
    got = step_separations(positions)
    assert got.shape == (1, 1)
    assert got[0, 0] == pytest.approx(0.1, abs=1e-15)  # at mid-step, one above the other
    assert np.linalg.norm(positions[0, 0] - positions[0, 1]) > 2.0


def test_a_swept_minimum_is_never_above_the_tick_samples_it_spans() -> None:
    """Bit for bit: the ends are computed as the tick samples are (world/metrics.py)."""
    rng = np.random.default_rng(7)
    positions = _walk(rng, steps=200, n=5, dim=3)
    centres, radii = rng.uniform(-4.0, 4.0, size=(3, 3)), rng.uniform(0.3, 1.5, size=3)
    ticks = np.linalg.norm(positions[:, :, None] - centres, axis=-1) - radii
    swept = step_clearances(positions, centres, radii)
    assert np.all(swept <= np.minimum(ticks[:-1], ticks[1:]))
    pairs = np.stack(
        [np.linalg.norm(positions[:, i] - positions[:, j], axis=1)
         for i, j in itertools.combinations(range(5), 2)],
        axis=1,
    )  # fmt: skip
    assert np.all(step_separations(positions) <= np.minimum(pairs[:-1], pairs[1:]))


def test_an_agent_standing_still_is_measured_where_it_stands() -> None:
    positions = np.array([[[3.0, 4.0]], [[3.0, 4.0]]])
    assert step_clearances(positions, np.zeros((1, 2)), np.array([1.0]))[0, 0, 0] == 4.0
    assert step_separations(positions).shape == (1, 0)  # one agent: no pairs
