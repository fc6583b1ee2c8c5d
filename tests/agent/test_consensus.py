"""Algorithm 1 (max-consensus on σ), Proposition 1, epochs and the passage bid."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from numpy.typing import ArrayLike

from shoal.agent.consensus import consensus_round, epoch_start, passage_bid
from shoal.world.graph import adjacency, communication_graph, diameter, hop_distances

RHO, EPS = 0.25, 0.125
NORTH = np.array([0.0, 1.0])


def _random_connected(rng: np.random.Generator, n: int) -> np.ndarray:
    """Sensing graph: random spanning tree with random edge directions plus random extra edges,
    turned into the undirected communication graph."""
    edges = []
    for i in range(2, n + 1):
        j = int(rng.integers(1, i))
        edges.append((i, j) if rng.random() < 0.5 else (j, i))
    for i in range(1, n + 1):
        for j in range(i + 1, n + 1):
            if rng.random() < 0.15:
                edges.append((i, j))
    return communication_graph(adjacency(n, edges, directed=True))


def _run_rounds(a: np.ndarray, values: np.ndarray, rounds: int) -> np.ndarray:
    vals = values.copy()
    for _ in range(rounds):
        vals = np.array(
            [
                consensus_round(vals[i], [vals[j] for j in np.flatnonzero(a[i])])
                for i in range(len(vals))
            ]
        )
    return vals


def test_consensus_round_is_max_of_own_and_received() -> None:
    assert consensus_round(1.0, []) == 1.0
    assert consensus_round(1.0, [1.5, 1.2]) == 1.5
    assert consensus_round(2.0, [1.5, 1.2]) == 2.0
    assert consensus_round(1.0, iter([1.0, 3.25, 2.0])) == 3.25


def test_epoch_start_every_rounds_ticks() -> None:
    starts = [t for t in range(13) if epoch_start(t, 4)]
    assert starts == [0, 4, 8, 12]
    assert all(epoch_start(t, 0) for t in range(5))  # degenerate L_G = 0: every tick
    assert all(epoch_start(t, 1) for t in range(5))


def _random_bids(
    seed: int, trials: int
) -> Iterator[tuple[np.random.Generator, np.ndarray, np.ndarray]]:
    """``trials`` connected graphs of 3–12 nodes, each with a bid > 1 per node, and the
    generator they were drawn from (seeded)."""
    rng = np.random.default_rng(seed)
    for _ in range(trials):
        n = int(rng.integers(3, 13))
        yield rng, _random_connected(rng, n), 1.0 + rng.exponential(size=n)


def test_proposition1_all_hold_max_after_diameter_rounds() -> None:
    for _, a, bids in _random_bids(20, 150):
        vals = _run_rounds(a, bids, diameter(a))
        np.testing.assert_array_equal(vals, np.full(len(bids), bids.max()))


def test_after_k_rounds_each_node_holds_max_within_k_hops() -> None:
    for rng, a, bids in _random_bids(21, 100):
        k = int(rng.integers(0, diameter(a) + 1))
        vals = _run_rounds(a, bids, k)
        for i in range(len(bids)):
            hops = hop_distances(a, i)
            assert vals[i] == bids[hops <= k].max()


@pytest.mark.parametrize("n", [3, 5, 9])
def test_path_graph_needs_all_diameter_rounds(n: int) -> None:
    a = adjacency(n, [(i, i + 1) for i in range(1, n)], directed=False)
    assert diameter(a) == n - 1
    bids = np.ones(n)
    bids[0] = 2.5
    short = _run_rounds(a, bids, n - 2)
    assert short[-1] == 1.0  # the far end has not heard yet
    np.testing.assert_array_equal(_run_rounds(a, bids, n - 1), np.full(n, 2.5))


def _bid(
    position: ArrayLike,
    heading: ArrayLike,
    centres: ArrayLike,
    radii: ArrayLike = (1.0, 1.0),
    *,
    radius: float = 2.0,
    sigma_max: float = 3.0,
    slot_shift: ArrayLike = (0.0, 0.0),
) -> float:
    return passage_bid(
        np.asarray(position, dtype=float),
        np.asarray(heading, dtype=float),
        np.asarray(centres, dtype=float).reshape(-1, 2),
        np.asarray(radii, dtype=float),
        formation_radius=radius,
        slot_shift=np.asarray(slot_shift, dtype=float),
        safety_margin=RHO,
        epsilon=EPS,
        sigma_max=sigma_max,
    )


# Gap of the standard pair: length 5 - r 1 - r 1 = 3 m; usable 3 - 2(0.25 + 0.125) = 2.25 m.
PAIR = [[-2.5, 5.0], [2.5, 5.0]]


def test_narrow_gap_ahead_bids_diameter_over_usable_width() -> None:
    # 2R / usable = 4 / 2.25 = 16/9.
    assert _bid([0.0, 0.0], NORTH, PAIR) == pytest.approx(16.0 / 9.0)


def test_narrow_gap_bid_with_oblique_heading_and_offcentre_agent() -> None:
    assert _bid([1.0, 0.0], [1.0, 1.0], PAIR) == pytest.approx(16.0 / 9.0)


def test_bid_is_capped_at_sigma_max() -> None:
    assert _bid([0.0, 0.0], NORTH, PAIR, sigma_max=1.5) == 1.5


@pytest.mark.parametrize("half", [1.25, 1.375])  # gap 0.5 and 0.75 = 2(ρ + ε): no usable width
def test_gap_without_usable_width_bids_sigma_max(half: float) -> None:
    assert _bid([0.0, 0.0], NORTH, [[-half, 5.0], [half, 5.0]]) == 3.0


def test_largest_bid_over_several_pairs() -> None:
    # Second pair: centres ±2, radii 1 -> gap 2, usable 1.25 -> 4 / 1.25 = 3.2 beats 16/9.
    centres = [*PAIR, [-2.0, 8.0], [2.0, 8.0]]
    assert _bid(
        [0.0, 0.0], NORTH, centres, radii=(1.0, 1.0, 1.0, 1.0), sigma_max=5.0
    ) == pytest.approx(4.0 / 1.25)


def test_no_obstacles_bids_one() -> None:
    assert _bid([0.0, 0.0], NORTH, np.zeros((0, 2)), radii=()) == 1.0


def test_wide_gap_bids_one() -> None:
    # centres ±4: gap 6 ≥ 2R + 2(ρ + ε) = 4.75.
    assert _bid([0.0, 0.0], NORTH, [[-4.0, 5.0], [4.0, 5.0]]) == 1.0


@pytest.mark.parametrize("heading", [[1.0, 0.0], [-1.0, 0.0], [np.cos(0.4), np.sin(0.4)]])
def test_heading_along_the_pair_bids_one(heading: list[float]) -> None:
    # 0.4 rad ≈ 23° from the line through the centres: within 30°, so "along", not "through".
    assert _bid([0.0, 0.0], heading, PAIR) == 1.0


def test_agent_already_past_bids_one() -> None:
    # Past when (s - mid)·through ≥ max(r) + ρ + ε = 1.375, i.e. y ≥ 6.375.
    assert _bid([0.0, 6.375], NORTH, PAIR) == 1.0
    assert _bid([0.0, 6.3], NORTH, PAIR) == pytest.approx(16.0 / 9.0)
    # Heading south from y = 3: (s - mid)·through = 2 ≥ 1.375, the gap is behind it.
    assert _bid([0.0, 3.0], -NORTH, PAIR) == 1.0


def test_agent_past_keeps_bidding_while_its_expanded_slot_is_not() -> None:
    # Agent at y = 6.5 is through, but its slot after expansion (y = 6.0) is not.
    assert _bid([0.0, 6.5], NORTH, PAIR, slot_shift=[0.0, -0.5]) == pytest.approx(16.0 / 9.0)
    assert _bid([0.0, 6.5], NORTH, PAIR, slot_shift=[3.0, -0.1]) == 1.0  # slot at 6.4: through
    # A slot ahead of an agent still in the gap does not release the bid: both must be through.
    assert _bid([0.0, 5.0], NORTH, PAIR, slot_shift=[0.0, 3.0]) == pytest.approx(16.0 / 9.0)


def test_still_agent_or_zero_radius_bids_one() -> None:
    assert _bid([0.0, 0.0], [0.0, 0.0], PAIR) == 1.0
    assert _bid([0.0, 0.0], NORTH, PAIR, radius=0.0) == 1.0


def test_gap_wider_than_formation_but_not_its_margins_still_bids() -> None:
    # centres ±3.25, r = 1: gap 4.5 ≥ 2R = 4, but usable 4.5 - 0.75 = 3.75 < 4.
    assert _bid([0.0, 0.0], NORTH, [[-3.25, 5.0], [3.25, 5.0]]) == pytest.approx(4.0 / 3.75)
