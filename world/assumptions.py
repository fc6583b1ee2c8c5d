"""The paper's assumptions, checked when a scenario is loaded.

Assumption 1: the graph is connected (undirected) or the leader reaches every follower (directed).
Assumption 2: an evading agent always keeps a non-evading neighbour. Which agents evade together
    depends on the run, so the load-time check is structural: no single evading follower may cut
    any other agent off from the leader once its neighbours drop their edges to it (Algorithm 2).
    Runs count the ticks where the literal assumption fails.
Assumption 3: desired inter-agent distances exceed 2 r_max (under every demanded scale).
Assumption 4: the leader's path clears every obstacle by its guard radius r_j + ρ.
Theorem 1 needs |f| < β per coordinate: a warning, since a run is still meaningful.
Assumptions 2 and 3 only matter when there are obstacles to evade and are skipped otherwise.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from bus.path import path_positions, peak_speed
from bus.types import Waypoints
from world.errors import AssumptionError, BetaWarning, ScenarioError
from world.graph import FloatArray, communication_graph, hop_distances, reached_from_leader
from world.scenario import Scenario


def check_assumptions(s: Scenario) -> None:
    """Raise the first violated assumption; warn when |f| ≥ β."""
    _obstacles_apart(s)
    _assumption1(s)
    if s.obstacles:
        _assumption2(s)
        _assumption3(s)
        _assumption4(s)
        _trigger_reach(s)
        _starts_clear(s)
    _beta(s)


def _followers(ids: set[int]) -> str:
    return ", ".join(str(i + 1) for i in sorted(ids))


def _assumption1(s: Scenario) -> None:
    a = s.adjacency
    if s.directed:
        missing = set(range(s.n)) - reached_from_leader(a)
        if missing:
            raise AssumptionError(
                1,
                "graph.edges",
                f"no directed path from the leader to follower(s) {_followers(missing)}",
            )
    else:
        unreached = set(np.flatnonzero(hop_distances(communication_graph(a), 0) < 0).tolist())
        if unreached:
            raise AssumptionError(
                1, "graph.edges", f"the graph is not connected: {_followers(unreached)} apart"
            )


def _assumption2(s: Scenario) -> None:
    a = s.adjacency
    for k in range(1, s.n):
        cut = set(range(s.n)) - reached_from_leader(a, without=k)
        if cut:
            raise AssumptionError(
                2,
                "graph.edges",
                f"while agent {k + 1} evades and its neighbours drop it, agent(s) "
                f"{_followers(cut)} have no path to the leader; give them another neighbour",
            )


def _assumption3(s: Scenario) -> None:
    r_max = float(s.obstacle_radii.max())
    scales = [1.0, *(r.scale for r in s.reshapes)]
    offsets = s.offsets
    for i, j in itertools.combinations(range(s.n), 2):
        gap = float(np.linalg.norm(offsets[i] - offsets[j])) / max(scales)
        if gap <= 2 * r_max:
            raise AssumptionError(
                3,
                f"agents[{j}].offset",
                f"agents {i + 1} and {j + 1} are meant to be {gap:.3g} m apart, "
                f"not more than 2 r_max = {2 * r_max:.3g} m",
            )


def _segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> float:
    ab = b - a
    length2 = float(ab @ ab)
    t = 0.0 if length2 == 0 else min(1.0, max(0.0, float((p - a) @ ab) / length2))
    return float(np.linalg.norm(p - (a + t * ab)))


def _assumption4(s: Scenario) -> None:
    margin = s.control.safety_margin
    centres, radii = s.obstacle_centres, s.obstacle_radii
    if isinstance(s.path, Waypoints):
        pts = np.asarray(s.path.points, dtype=np.float64)
        legs = [(k, pts[k], pts[k + 1]) for k in range(len(pts) - 1)] or [(0, pts[0], pts[0])]
        for (k, a, b), o in itertools.product(legs, range(len(radii))):
            clear = _segment_distance(centres[o], a, b) - radii[o]
            if clear <= margin:
                raise AssumptionError(
                    4,
                    f"leader.waypoints[{k}]",
                    f"the leg from waypoint {k} passes {clear:.3g} m from the edge of "
                    f"obstacles[{o}], within the safety margin {margin} m",
                )
        return
    for o in range(len(radii)):
        clear = _closest_on_sinusoid(s, centres[o]) - radii[o]
        if clear <= margin:
            raise AssumptionError(
                4,
                "leader.sinusoid",
                f"the path passes {clear:.3g} m from the edge of obstacles[{o}], "
                f"within the safety margin {margin} m",
            )


def _closest_on_sinusoid(s: Scenario, centre: FloatArray) -> float:
    """Smallest distance from ``centre`` to the leader's sinusoid over the run, sampled every
    tick (the leader's positions are exactly these samples), in chunks to bound memory."""
    closest = np.inf
    for first in range(0, s.steps + 1, 100_000):
        ticks = np.arange(first, min(first + 100_000, s.steps + 1))
        track = path_positions(s.path, np.asarray(ticks * s.dt, dtype=np.float64))
        closest = min(closest, float(np.linalg.norm(track - centre, axis=1).min()))
    return closest


def _obstacles_apart(s: Scenario) -> None:
    centres, radii = s.obstacle_centres, s.obstacle_radii
    for i, j in itertools.combinations(range(len(radii)), 2):
        if float(np.linalg.norm(centres[i] - centres[j])) <= radii[i] + radii[j]:
            raise ScenarioError(f"obstacles[{j}]", f"overlaps obstacles[{i}] (Section 3)")


def _trigger_reach(s: Scenario) -> None:
    c = s.control
    guard = float(s.obstacle_radii.max()) + c.safety_margin + c.epsilon
    if c.trigger_radius <= guard:
        raise ScenarioError(
            "control.trigger_radius",
            f"d̄ = {c.trigger_radius} m must exceed the largest guard radius r_max + ρ + ε = "
            f"{guard:.3g} m, or an agent is inside the guard before (11) can fire",
        )


def _starts_clear(s: Scenario) -> None:
    centres, radii = s.obstacle_centres, s.obstacle_radii
    for i, pos in enumerate(s.initial_positions):
        dist = np.linalg.norm(centres - pos, axis=1) - radii
        if (dist <= s.agent_radius).any():
            o = int(np.argmin(dist))
            raise ScenarioError(f"agents[{i}].initial", f"starts inside obstacles[{o}]")


def _beta(s: Scenario) -> None:
    peak = peak_speed(s.path)
    worst = int(np.argmax(peak))
    if peak[worst] >= s.control.beta:
        warnings.warn(
            f"{s.name}: the leader moves at up to {peak[worst]:.3g} m/s along axis {worst}, "
            f"not below β = {s.control.beta} m/s; Theorem 1 does not guarantee convergence",
            BetaWarning,
            stacklevel=3,
        )
