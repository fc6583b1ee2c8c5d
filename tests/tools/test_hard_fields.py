"""The adversarial generator (tools/campaign/hard.py): admissible, reproducible fields that
carry the hard cases — reversals, rotations by π, clusters just wider than the guards, obstacles
on the leader's legs — in 2-D and 3-D."""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings

import numpy as np
import pytest

from shoal.geometry.vectors import segment_distance
from shoal.tools.campaign.hard import RHO, SLACK, hard_field
from shoal.tools.campaign.runner import judge
from shoal.world.errors import BetaWarning
from shoal.world.loader import parse_scenario

SEEDS = range(24)


@pytest.fixture(scope="module", params=[2, 3])
def fields(request: pytest.FixtureRequest) -> list[object]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [hard_field(seed, request.param) for seed in SEEDS]


def test_the_same_seed_gives_the_same_field_byte_for_byte() -> None:
    assert hard_field(5, 2).source == hard_field(5, 2).source
    assert hard_field(5, 2).source != hard_field(6, 2).source
    assert hard_field(5, 3).dim == 3


def test_every_field_is_admissible_and_reloads_from_its_own_text(fields: list) -> None:
    for f in fields:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            again = parse_scenario(f.source, default_name="x")  # raises if refused
        assert not [w for w in caught if issubclass(w.category, BetaWarning)]
        assert again.obstacles == f.obstacles and again.name == f.name
        assert 4 <= f.n <= 10 and f.duration >= SLACK


def test_the_fields_carry_the_hard_cases(fields: list) -> None:
    reversals = rotations = clusters = on_leg = 0
    for f in fields:
        pts = np.asarray(f.path.points)
        legs = np.diff(pts, axis=0)
        for a, b in itertools.pairwise(legs):
            cos = float(a @ b / np.linalg.norm(a) / np.linalg.norm(b))
            reversals += cos < math.cos(math.radians(135))
        rotations += any(r.rotate == math.pi for r in f.reshapes)
        c, r = f.obstacle_centres, f.obstacle_radii
        for i, j in itertools.combinations(range(len(r)), 2):
            gap = float(np.linalg.norm(c[i] - c[j]) - r[i] - r[j])
            clusters += 2 * RHO < gap <= 2 * RHO + 0.3
        on_leg += any(
            segment_distance(c[o], pts[k], pts[k + 1]) - r[o] <= RHO
            for o in range(len(r))
            for k in range(len(pts) - 1)
        )
    n = len(fields)
    assert reversals >= n // 4 and rotations >= n // 4 and clusters >= n and on_leg >= n // 4


def test_a_dimension_other_than_2_or_3_is_refused() -> None:
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        hard_field(0, 4)


def test_the_boundary_layer_option_runs_the_same_field_with_phi_k_beta_dt() -> None:
    plain, layered = hard_field(73, 2), hard_field(73, 2, boundary_layer=2.0)
    c = plain.control
    assert layered.control.boundary_layer == pytest.approx(2.0 * c.beta * plain.dt, abs=1e-4)
    assert plain.control.boundary_layer == 0.0
    assert layered.obstacles == plain.obstacles and layered.agents == plain.agents
    assert dataclasses.replace(layered.control, boundary_layer=0.0) == c


def test_a_sampled_sign_law_cycle_that_never_arrives_arrives_with_the_boundary_layer() -> None:
    """Hard field 73 (2-D): β·dt = 0.28 m against an arrival tolerance R = 0.2 m, so the paper's
    sampled sign(e) keeps a follower jumping across its slot for good (named a deadlock: it
    makes no progress). sat(e/φ) with φ = 2·β·dt halves the error each tick instead."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sign, layered = hard_field(73, 2), hard_field(73, 2, boundary_layer=2.0)
    assert sign.control.beta * sign.dt > 0.2
    first, second = judge(sign, "hard/2d"), judge(layered, "hard/2d")
    assert (first.arrived, first.not_arrived) == (False, "deadlock")
    assert (second.arrived, second.collided) == (True, False)
