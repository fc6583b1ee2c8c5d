"""Graph facts the paper relies on: adjacency, Laplacian, M (Theorem 1), reachability from the
leader (Assumption 1), the diameter L_G (Algorithm 1).

Agents are numbered 1..n in the paper; arrays here are indexed 0..n-1 (index = id - 1), with the
leader at index 0. ``A[i, j] = 1`` when agent i senses agent j (row i is what i uses in (1)).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from shoal.geometry.vectors import FloatArray

__all__ = [
    "adjacency",
    "communication_graph",
    "diameter",
    "follower_matrix",
    "hop_distances",
    "reached_from_leader",
]


def adjacency(n: int, edges: Iterable[tuple[int, int]], *, directed: bool) -> FloatArray:
    """(n, n) 0/1 adjacency from 1-based ``edges``; (i, j) means i senses j when directed."""
    a = np.zeros((n, n))
    for i, j in edges:
        a[i - 1, j - 1] = 1.0
        if not directed:
            a[j - 1, i - 1] = 1.0
    np.fill_diagonal(a, 0.0)
    return a


def follower_matrix(a: FloatArray) -> FloatArray:
    """M = L_f + diag(A_21, ..., A_n1): (n-1, n-1), the matrix of Theorem 1 and (10).

    L_f is the Laplacian of the graph induced by the followers; the diagonal term is each
    follower's link to the leader. For undirected graphs M is symmetric positive definite exactly
    when every follower is connected to the leader.
    """
    af = a[1:, 1:]
    lf = np.diag(af.sum(axis=1)) - af
    return lf + np.diag(a[1:, 0])


def reached_from_leader(a: FloatArray, *, without: int | None = None) -> set[int]:
    """Indices whose control law depends, through a chain of sensing links, on the leader.

    Information flows from j to i when A[i, j] = 1. ``without`` models Algorithm 2 for one
    evading agent: every other agent stops sensing it (it still senses its own neighbours).
    """
    n = a.shape[0]
    seen = {0}
    queue = deque([0])
    while queue:
        j = queue.popleft()
        if j == without and j != 0:
            continue  # nobody follows an evading agent, so information stops here
        for i in range(n):
            if a[i, j] and i not in seen:
                seen.add(i)
                queue.append(i)
    return seen


def communication_graph(a: FloatArray) -> FloatArray:
    """The undirected graph over which σ bids are broadcast: i and j talk if either senses the
    other (a radio broadcast reaches both ways)."""
    return np.maximum(a, a.T)


def hop_distances(a: FloatArray, source: int) -> NDArray[np.int64]:
    """Breadth-first hop counts from ``source`` along A (any direction A encodes); -1 if
    unreachable."""
    n = a.shape[0]
    dist = np.full(n, -1, dtype=np.int64)
    dist[source] = 0
    queue = deque([source])
    while queue:
        u = queue.popleft()
        for v in np.flatnonzero(a[u]):
            if dist[v] < 0:
                dist[v] = dist[u] + 1
                queue.append(int(v))
    return dist


def diameter(a: FloatArray) -> int:
    """L_G: the longest shortest path (in hops) of the undirected graph ``a``.

    Raises ValueError if the graph is not connected (the diameter is then infinite).
    """
    n = a.shape[0]
    longest = 0
    for s in range(n):
        d = hop_distances(a, s)
        if (d < 0).any():
            raise ValueError("the communication graph is not connected")
        longest = max(longest, int(d.max()))
    return longest
