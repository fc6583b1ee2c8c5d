"""Adjacency, M of Theorem 1 / (10), reachability from the leader and the diameter L_G."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from shoal.world.graph import (
    adjacency,
    communication_graph,
    diameter,
    follower_matrix,
    hop_distances,
    reached_from_leader,
)


def _random_connected(rng: np.random.Generator, n: int) -> np.ndarray:
    edges = [(i, int(rng.integers(1, i))) for i in range(2, n + 1)]  # random spanning tree
    edges += [(i, j) for i, j in itertools.combinations(range(1, n + 1), 2) if rng.random() < 0.2]
    return adjacency(n, edges, directed=False)


def _path(n: int) -> np.ndarray:
    return adjacency(n, [(i, i + 1) for i in range(1, n)], directed=False)


def _ring(n: int) -> np.ndarray:
    return adjacency(n, [(i, i % n + 1) for i in range(1, n + 1)], directed=False)


def _floyd(a: np.ndarray) -> np.ndarray:
    d = np.where(a > 0, 1.0, np.inf)
    np.fill_diagonal(d, 0.0)
    for k in range(a.shape[0]):
        d = np.minimum(d, d[:, [k]] + d[[k], :])
    return d


def test_adjacency_undirected_is_symmetric_one_based() -> None:
    a = adjacency(4, [(1, 2), (2, 3), (4, 2)], directed=False)
    expected = np.array([[0, 1, 0, 0], [1, 0, 1, 1], [0, 1, 0, 0], [0, 1, 0, 0]], dtype=float)
    np.testing.assert_array_equal(a, expected)
    np.testing.assert_array_equal(a, a.T)


def test_adjacency_directed_row_is_who_i_senses() -> None:
    a = adjacency(3, [(2, 1), (3, 2)], directed=True)
    np.testing.assert_array_equal(a, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert not np.array_equal(a, a.T)


def test_adjacency_drops_self_loops_and_keeps_entries_binary() -> None:
    a = adjacency(3, [(1, 1), (1, 2), (1, 2), (2, 1)], directed=False)
    np.testing.assert_array_equal(a, [[0, 1, 0], [1, 0, 0], [0, 0, 0]])


def test_follower_matrix_hand_computed_undirected() -> None:
    # Leader 1 - {2, 3}; followers 2-3, 3-4. L_f over (2, 3, 4) plus diag(A_21, A_31, A_41).
    a = adjacency(4, [(1, 2), (2, 3), (3, 4), (1, 3)], directed=False)
    expected = np.array([[2, -1, 0], [-1, 3, -1], [0, -1, 1]], dtype=float)
    np.testing.assert_array_equal(follower_matrix(a), expected)


def test_follower_matrix_hand_computed_directed() -> None:
    # 2 senses 1; 3 and 4 sense 2.
    a = adjacency(4, [(2, 1), (3, 2), (4, 2)], directed=True)
    expected = np.array([[1, 0, 0], [-1, 1, 0], [-1, 0, 1]], dtype=float)
    np.testing.assert_array_equal(follower_matrix(a), expected)


def test_follower_matrix_spd_for_connected_undirected_graphs() -> None:
    rng = np.random.default_rng(40)
    for _ in range(120):
        a = _random_connected(rng, int(rng.integers(2, 13)))
        m = follower_matrix(a)
        np.testing.assert_array_equal(m, m.T)
        assert np.linalg.eigvalsh(m).min() > 1e-9


def test_follower_matrix_singular_when_a_follower_is_cut_off() -> None:
    a = adjacency(4, [(1, 2), (3, 4)], directed=False)
    assert np.linalg.eigvalsh(follower_matrix(a)).min() == pytest.approx(0.0, abs=1e-12)


def test_follower_matrix_rows_give_consensus_error_at_zero_offsets() -> None:
    # M z with z = x_f - x_1 equals Σ_j A_ij (x_i - x_j) for every follower.
    rng = np.random.default_rng(41)
    a = _random_connected(rng, 7)
    x = rng.normal(size=7)
    direct = np.array([sum(a[i, j] * (x[i] - x[j]) for j in range(7)) for i in range(1, 7)])
    np.testing.assert_allclose(follower_matrix(a) @ (x[1:] - x[0]), direct, atol=1e-12)


def test_reached_from_leader_directed_chain() -> None:
    chain = adjacency(4, [(2, 1), (3, 2), (4, 3)], directed=True)
    assert reached_from_leader(chain) == {0, 1, 2, 3}
    backwards = adjacency(4, [(1, 2), (2, 3), (3, 4)], directed=True)
    assert reached_from_leader(backwards) == {0}


@pytest.mark.parametrize(("without", "expected"), [(1, {0, 1}), (2, {0, 1, 2}), (3, {0, 1, 2, 3})])
def test_reached_from_leader_without_cuts_off_downstream(without: int, expected: set[int]) -> None:
    chain = adjacency(4, [(2, 1), (3, 2), (4, 3)], directed=True)
    assert reached_from_leader(chain, without=without) == expected


def test_reached_from_leader_without_leader_changes_nothing() -> None:
    chain = adjacency(4, [(2, 1), (3, 2), (4, 3)], directed=True)
    assert reached_from_leader(chain, without=0) == {0, 1, 2, 3}


def test_reached_from_leader_cut_vertex_in_undirected_graph() -> None:
    # 1-2, 2-3, 2-4, 3-4, 1-5: agent 2 (index 1) is a cut vertex for {3, 4}.
    a = adjacency(5, [(1, 2), (2, 3), (2, 4), (3, 4), (1, 5)], directed=False)
    assert reached_from_leader(a) == {0, 1, 2, 3, 4}
    assert reached_from_leader(a, without=1) == {0, 1, 4}
    assert reached_from_leader(a, without=2) == {0, 1, 2, 3, 4}  # 4 still hears 2


def test_reached_from_leader_ring_survives_one_evader() -> None:
    a = _ring(6)
    for k in range(1, 6):
        assert reached_from_leader(a, without=k) == set(range(6))


def test_communication_graph_symmetrises_sensing() -> None:
    a = adjacency(3, [(2, 1), (3, 2)], directed=True)
    np.testing.assert_array_equal(
        communication_graph(a), adjacency(3, [(1, 2), (2, 3)], directed=False)
    )


def test_hop_distances_path_and_unreachable() -> None:
    np.testing.assert_array_equal(hop_distances(_path(5), 0), [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(hop_distances(_path(5), 2), [2, 1, 0, 1, 2])
    a = adjacency(4, [(1, 2), (3, 4)], directed=False)
    np.testing.assert_array_equal(hop_distances(a, 0), [0, 1, -1, -1])


@pytest.mark.parametrize("n", [2, 3, 6, 11])
def test_diameter_of_path_is_n_minus_one(n: int) -> None:
    assert diameter(_path(n)) == n - 1


@pytest.mark.parametrize(("n", "expected"), [(3, 1), (4, 2), (5, 2), (8, 4), (9, 4)])
def test_diameter_of_ring_is_half_n(n: int, expected: int) -> None:
    assert diameter(_ring(n)) == expected


@pytest.mark.parametrize("n", [3, 5, 10])
def test_diameter_of_star_is_two_and_complete_is_one(n: int) -> None:
    assert diameter(adjacency(n, [(1, j) for j in range(2, n + 1)], directed=False)) == 2
    complete = adjacency(n, list(itertools.combinations(range(1, n + 1), 2)), directed=False)
    assert diameter(complete) == 1


def test_diameter_of_single_agent_is_zero() -> None:
    assert diameter(np.zeros((1, 1))) == 0


def test_diameter_matches_floyd_warshall_on_random_graphs() -> None:
    rng = np.random.default_rng(42)
    for _ in range(100):
        a = _random_connected(rng, int(rng.integers(3, 13)))
        assert diameter(a) == int(_floyd(a).max())


def test_diameter_raises_on_disconnected_graph() -> None:
    a = adjacency(4, [(1, 2), (3, 4)], directed=False)
    with pytest.raises(ValueError, match="not connected"):
        diameter(a)
