"""The paper's assumptions, checked when a scenario is loaded.

Assumption 1: the graph is connected (undirected) or the leader reaches every follower (directed).
Assumption 2: an evading agent always keeps a non-evading neighbour. Which agents evade together
    depends on the run, so the load-time check is structural: no single evading follower may cut
    any other agent off from the leader once its neighbours drop their edges to it (Algorithm 2).
    Runs count the ticks where the literal assumption fails.
Assumption 3: desired inter-agent distances exceed 2 r_max (under every demanded scale).
Assumption 4: the leader's path clears every obstacle by its guard radius r_j + ρ.
Theorem 1 needs |f| < β per coordinate, and a speed limit under which the capped law still
    closes every coordinate's error (cap_needed): warnings, since a run is still meaningful.
The safety filter's theorem (docs/safety.md), with ``control.safety: filter``: (D) one step at
    the speed limit cannot reach an unsensed obstacle's guard or an unsensed agent's cell,
    v_max·dt ≤ min(d − r_max − ρ, (d − 2R)/2); the guard ρ and the separation 2R cover the
    bodies that count a collision; (F) every agent starts outside every guard circle r_j + ρ
    and at least 2R from every other agent.
Assumptions 2 and 3 only matter when there are obstacles to evade and are skipped otherwise.
Moving obstacles (docs/people.md) are left to the safety filter: the assumptions above are about
the standing ones; the filter needs u_max·dt more sensing range, (D) above with
d − r_max − ρ − u_max·dt, and every agent to start outside every guard circle.

Fields the formation can never finish, with ``control.safety: filter`` (the filter keeps every
agent's centre outside every guard circle r_j + ρ and every pair of agents 2R apart, at all
times, so a slot inside either can never be filled; ρ ≥ agent_radius already holds the body):
every shape demanded, the offsets and each applied reshape, keeps its slots 2R apart; every
follower's final slot (the leader's last waypoint, or where its sinusoid is at the last tick,
plus R(θ)δ_i/σ of the last reshape) lies outside every standing obstacle's guard circle; and
no moving obstacle that walks a route and stops stops with a final slot inside its guard
r + ρ + u·dt (the margin its row keeps, geometry/safety.py ``mover_row``).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from shoal.bus.types import PathSpec, Waypoints
from shoal.geometry.path import leader_velocities, path_position, path_positions, peak_speed
from shoal.geometry.vectors import FloatArray, norm, segment_distance, shaped
from shoal.world.errors import (
    AssumptionError,
    BetaWarning,
    DetourWarning,
    ScenarioError,
    SpeedCapWarning,
)
from shoal.world.graph import communication_graph, hop_distances, reached_from_leader
from shoal.world.movers import Route
from shoal.world.scenario import Scenario


@dataclass(frozen=True)
class Check:
    """One load-time check, named as the campaign's sets are (docs/campaign.md).

    ``run`` raises :class:`ScenarioError` (or :class:`AssumptionError`) as the loader applies
    it; ``literal``, where it differs, is the paper's assumption as stated (A4: a leg through
    an obstacle is an error, where the loader, with the safety filter, warns and the leader
    goes round). ``needs``: "standing" (only with standing obstacles), "movers" (only with
    moving ones), or "" (always)."""

    name: str
    run: Callable[[Scenario], None]
    needs: str = ""
    literal: Callable[[Scenario], None] | None = None

    def applies(self, s: Scenario) -> bool:
        return {"": True, "standing": bool(s.standing_ids), "movers": bool(s.mover_ids)}[self.needs]


def check_assumptions(s: Scenario) -> None:
    """Raise the first violated check of :data:`CHECKS`; warn when |f| ≥ β."""
    for check in CHECKS:
        if check.applies(s):
            check.run(s)
    check_speed(s)


def broken_checks(s: Scenario) -> frozenset[str]:
    """The names of every check of :data:`CHECKS` that ``s`` fails, each run on its own (in
    its literal form: the paper's assumption as stated), and "speed" if |f| ≥ β. Empty for a
    scenario the loader accepts silently."""
    failed = set()
    for check in CHECKS:
        if check.applies(s):
            try:
                (check.literal or check.run)(s)
            except ScenarioError:
                failed.add(check.name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BetaWarning)
        check_speed(s)
    if any(issubclass(w.category, BetaWarning) for w in caught):
        failed.add("speed")
    return frozenset(failed)


def check_graph(s: Scenario) -> None:
    """Assumptions 1 and 2 alone, with or without obstacles: the graph a scenario's obstacles
    will need (A2 is checked at load only when there are obstacles to evade)."""
    _assumption1(s)
    _assumption2(s)


def _named(s: Scenario, o: int) -> str:
    """The field of standing obstacle ``o`` (an index into ``obstacle_centres``): its place in
    the scenario's ``obstacles`` list, where moving ones may come before it."""
    return f"obstacles[{s.standing_ids[o]}]"


def _from_edge(distance: float, thing: str) -> str:
    """ "0.5 m from the edge of obstacles[0]", or for a point inside it "inside obstacles[0] by
    0.9 m from its edge": a negative distance read as the error it is."""
    if distance < 0:
        return f"inside {thing} by {-distance:.3g} m from its edge"
    return f"{distance:.3g} m from the edge of {thing}"


def _start_field(s: Scenario, i: int) -> str:
    """The key that sets where agent i + 1 starts, as the file spells it: its ``initial``, or
    without one its ``offset`` (it starts at the path's start + offset + initial_noise)."""
    return f"agents[{i}].initial" if s.agents[i].given_initial else f"agents[{i}].offset"


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
        gap = norm(offsets[i] - offsets[j]) / max(scales)
        if gap <= 2 * r_max:
            raise AssumptionError(
                3,
                f"agents[{j}].offset",
                f"agents {i + 1} and {j + 1} are meant to be {gap:.3g} m apart, "
                f"not more than 2 r_max = {2 * r_max:.3g} m",
            )


def _assumption4(s: Scenario) -> None:
    margin = s.control.safety_margin
    centres, radii = s.obstacle_centres, s.obstacle_radii
    if isinstance(s.path, Waypoints):
        pts = np.asarray(s.path.points, dtype=np.float64)
        legs = [(k, pts[k], pts[k + 1]) for k in range(len(pts) - 1)] or [(0, pts[0], pts[0])]
        for (k, a, b), o in itertools.product(legs, range(len(radii))):
            clear = segment_distance(centres[o], a, b) - radii[o]
            if clear <= margin:
                raise AssumptionError(
                    4,
                    f"leader.waypoints[{k}]",
                    f"the leg from waypoint {k} passes {_from_edge(clear, _named(s, o))}, "
                    f"within the safety margin {margin} m",
                )
        return
    for o in range(len(radii)):
        clear = _closest_on_sinusoid(s, centres[o]) - radii[o]
        if clear <= margin:
            raise AssumptionError(
                4,
                "leader.sinusoid",
                f"the path passes {_from_edge(clear, _named(s, o))}, "
                f"within the safety margin {margin} m",
            )


def _leader_path(s: Scenario) -> None:
    """Assumption 4; with the safety filter and waypoints a broken one is a warning, since the
    leader goes round the obstacle (agent/leader.py), unless a waypoint itself lies too close
    to an obstacle to be reached round it."""
    try:
        _assumption4(s)
    except AssumptionError as exc:
        if s.control.safety != "filter" or not isinstance(s.path, Waypoints):
            raise
        _waypoints_reachable(s, s.path)
        warnings.warn(
            f"{s.name}: {exc.problem}; the leader will go round it (docs/safety.md)",
            DetourWarning,
            stacklevel=4,
        )


def _waypoints_reachable(s: Scenario, path: Waypoints) -> None:
    """Every waypoint after the start keeps r_j + 2ρ + ε from every obstacle's centre: the
    circle a detour keeps (agent/leader.py) must not hold the waypoint it goes to."""
    c = s.control
    centres, radii = s.obstacle_centres, s.obstacle_radii
    for k, point in enumerate(path.points[1:], start=1):
        dist = np.linalg.norm(centres - np.asarray(point), axis=1) - radii
        o = int(np.argmin(dist))
        keep = 2 * c.safety_margin + c.epsilon
        if dist[o] <= keep:
            raise AssumptionError(
                4,
                f"leader.waypoints[{k}]",
                f"the waypoint is {_from_edge(dist[o], _named(s, o))}, within "
                f"2ρ + ε = {keep:.3g} m: the leader can go round an obstacle on its path, but "
                "not reach a waypoint this close to one",
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
    """Obstacles do not overlap (Section 3); with the safety filter their guard circles do not
    touch either: an agent pressed into the notch where two guards meet has every way out
    closed by one of the two rows (a pocket narrower than 2ρ), and stays there."""
    centres, radii = s.obstacle_centres, s.obstacle_radii
    rho = s.control.safety_margin
    for i, j in itertools.combinations(range(len(radii)), 2):
        gap = norm(centres[i] - centres[j]) - radii[i] - radii[j]
        if gap <= 0:
            raise ScenarioError(_named(s, j), f"overlaps {_named(s, i)} (Section 3)")
        if s.control.safety == "filter" and gap <= 2 * rho:
            raise ScenarioError(
                _named(s, j),
                f"is {gap:.3g} m from {_named(s, i)}, not more than 2ρ = {2 * rho:.3g} m: their "
                "guard circles meet and an agent can be wedged in the notch between them; "
                "move them apart or give one obstacle that encloses both",
            )


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
    filtered = s.control.safety == "filter"
    keep = s.control.safety_margin if filtered else s.agent_radius
    for i, pos in enumerate(s.initial_positions):
        dist = np.linalg.norm(centres - pos, axis=1) - radii
        o = int(np.argmin(dist))
        if dist[o] <= s.agent_radius:
            raise ScenarioError(_start_field(s, i), f"agent {i + 1} starts inside {_named(s, o)}")
        if dist[o] < keep:
            raise ScenarioError(
                _start_field(s, i),
                f"agent {i + 1} starts {dist[o]:.3g} m from the edge of {_named(s, o)}, inside "
                f"its guard circle (ρ = {keep} m): the safety filter needs every agent to start "
                "outside",
            )


def _shapes(s: Scenario) -> list[tuple[int | None, float, float]]:
    """Every shape the formation is asked to take, in order, as (index in ``reshape``, σ, θ);
    index None: the offsets as given. A reshape counts when a tick of the run applies it: not
    one that a later entry at the same tick replaces, nor one at the run's very end (ticks run
    0 .. steps − 1); the offsets as given count unless a reshape applies from tick 0."""
    r = s.reshapes
    applied = [
        (k, x.scale, x.rotate)
        for k, x in enumerate(r)
        if x.tick < s.steps and (k + 1 == len(r) or r[k + 1].tick != x.tick)
    ]
    given = [] if applied and r[applied[0][0]].tick == 0 else [(None, 1.0, 0.0)]
    return [*given, *applied]


def _closest_pair(points: FloatArray) -> tuple[float, int, int]:
    """The least distance between two of ``points`` (k, dim) m, and the first such pair (i < j).
    Row by row: O(k) memory for a swarm of thousands."""
    best, pair = math.inf, (0, 1)
    for i in range(len(points) - 1):
        dist = np.linalg.norm(points[i + 1 :] - points[i], axis=1)
        k = int(np.argmin(dist))
        if dist[k] < best:
            best, pair = float(dist[k]), (i, i + 1 + k)
    return best, *pair


def _slots_apart(s: Scenario) -> None:
    """With the safety filter, every demanded shape keeps its slots the separation 2R apart:
    the filter never lets two agents closer, so such a shape could never be taken (a 4×4 grid
    0.5 m apart shrunk ×2 stood gridlocked for the rest of its run). A rotation keeps every
    distance, so the closest pair of offsets is the closest pair of every shape."""
    if s.control.safety != "filter" or s.n < 2:
        return
    gap, i, j = _closest_pair(s.offsets)
    sep = s.separation
    for k, scale, _theta in _shapes(s):
        if gap / scale < sep:  # Python floats: a tiny σ overflows to inf, never an error
            raise ScenarioError(
                f"agents[{j}].offset" if k is None else f"reshape[{k}].scale",
                f"agents {i + 1} and {j + 1} {'are' if k is None else 'would be'} meant to be "
                f"{gap / scale:.3g} m apart, closer than the separation {sep:.3g} m the safety "
                "filter keeps; the formation could never take this shape",
            )


def final_slots(s: Scenario) -> FloatArray:
    """(n, dim) where every agent should end, m: the leader's last waypoint, or on a sinusoid
    where the path is at the last tick, plus R(θ)δ_i/σ of the last shape demanded."""
    _k, scale, theta = _shapes(s)[-1]
    if isinstance(s.path, Waypoints):
        end = np.asarray(s.path.points[-1], dtype=np.float64)
    else:
        end = path_position(s.path, (s.steps - 1) * s.dt)
    with np.errstate(over="ignore", invalid="ignore"):  # δ/σ for a σ of 1e-300: no slot, no error
        return np.asarray(end + shaped(s.offsets, sigma=scale, theta=theta), dtype=np.float64)


def _final_slots_clear(s: Scenario) -> None:
    """With the safety filter, no follower's final slot lies inside a standing obstacle's guard
    circle r_j + ρ: the filter keeps the follower's centre out of it for good (the leader's
    end is Assumption 4's, or the detour's 2ρ + ε).

    The margin is the guard itself, no more: the agent's body needs nothing beyond it (the load
    demands ρ ≥ agent_radius), and a slot on the circle can be held (the row allows D = r + ρ).
    A slot inside it by less than a tolerance may still be counted as reached, the agent
    pressed against the guard by its nominal law for good; its shape is never taken."""
    if s.control.safety != "filter":
        return
    rho = s.control.safety_margin
    slots = final_slots(s)[1:]
    with np.errstate(over="ignore", invalid="ignore"):
        clear = np.linalg.norm(slots[:, None, :] - s.obstacle_centres, axis=2) - s.obstacle_radii
    inside = np.argwhere(clear < rho)  # NaN (an overflowed slot) is never inside
    if inside.size:
        i = int(inside[0, 0])
        o = int(np.argmin(clear[i]))
        raise ScenarioError(
            f"agents[{i + 1}].offset",
            f"the final slot of agent {i + 2} lies {_from_edge(clear[i, o], _named(s, o))}, "
            f"inside its guard circle ρ = {rho} m: the safety filter keeps the "
            "agent out of it, so the formation can never arrive in its final shape",
        )


def _parked_movers(s: Scenario) -> None:
    """No moving obstacle that walks a route and stops (``kind: route`` without ``loop``) stops
    before the last tick with some agent's final slot inside r + ρ + u·dt of its centre: its
    row (geometry/safety.py ``mover_row``) keeps agents that far from it even at rest. When it stops
    is bounded from above: each leg takes at most ⌈L/(u·dt)⌉ ticks, one more for rounding;
    a walker that may still be on its way at the end is left alone."""
    slots = final_slots(s)
    rho, dt, last = s.control.safety_margin, s.dt, s.steps - 1  # last: the last tick
    for k in s.mover_ids:
        o = s.obstacles[k]
        m = o.motion
        if not isinstance(m, Route) or m.loop:
            continue
        stops = [o.centre, *m.waypoints]
        walk = sum(math.dist(a, b) / m.speed + 2 * dt for a, b in itertools.pairwise(stops))
        if walk > last * dt:
            continue
        keep = o.radius + rho + m.speed * dt
        with np.errstate(over="ignore", invalid="ignore"):
            dist = np.linalg.norm(slots - np.asarray(m.waypoints[-1]), axis=1)
        i = int(np.argmin(dist))
        if dist[i] < keep:
            raise ScenarioError(
                f"obstacles[{k}].moves",
                f"it stops for good at its last waypoint, its edge {dist[i] - o.radius:.3g} m "
                f"from the final slot of agent {i + 1}, within ρ + u·dt = {keep - o.radius:.3g} "
                "m: the safety filter keeps the agent out, so the formation can never arrive in "
                "its final shape",
            )


# What the unicycle's terms are, said after its reach (Scenario.body_reach, world/unicycle.py)
_REACH = (
    " (a unicycle's reach; l·x²/2 is its point's departure from its chord, sin x = v_max·dt/2l)"
)


def _safety(s: Scenario) -> None:
    """What the safety filter's theorem needs of the scenario (module docstring, (D) and (F))."""
    c = s.control
    if c.safety != "filter":
        return
    # The speed limit first: the unicycle's reach below is reckoned at it (the arc's departure)
    if s.unicycle is not None and s.speed_limit > s.unicycle.fastest_point(s.dt):
        raise ScenarioError(
            "control.speed_limit",
            f"{s.speed_limit} m/s is faster than the unicycle's point can move under its "
            f"limits in any direction ({s.unicycle.fastest_point(s.dt):.6g} m/s: max_speed, "
            "lookahead·max_turn_rate and the wheels', and no more than lookahead/dt)",
        )
    reach, what, terms, twice, also = s.agent_radius, "agent_radius", "", "2·agent_radius", ""
    if s.unicycle is not None:  # the body is l behind the point, and the point leaves its chord
        reach, what = s.body_reach, "agent_radius + l + l·x²/2"
        sum_ = f"{s.agent_radius:.6g} + {s.unicycle.lookahead:.6g} + {s.arc_departure:.6g}"
        terms, twice = f" = {sum_}", f"2·({what}) = 2·({sum_})"
        also = _REACH
    if c.safety_margin < reach:
        raise ScenarioError(
            "control.safety_margin",
            f"ρ = {c.safety_margin} m is less than {what}{terms} = {reach:.6g} m{also}: the "
            "filter's guard circles would not keep the agents' bodies off the obstacles",
        )
    if s.separation < 2 * reach:
        raise ScenarioError(
            "control.separation",
            f"{s.separation} m is less than {twice} = {2 * reach:.6g} m{also}: the filter "
            "would let two agents' bodies touch",
        )
    step = s.largest_step
    if step <= 0:
        raise ScenarioError(
            "control.sensing_radius",
            f"d = {c.sensing_radius} m leaves no safe step: it must exceed r_max + ρ"
            f"{' + u_max·dt' if s.u_max > 0 else ''} and the separation {s.separation} m, or an "
            "agent cannot sense what one step can reach",
        )
    if s.speed_limit * s.dt > step * (1 + 1e-12):
        walk = " − u_max·dt" if s.u_max > 0 else ""
        raise ScenarioError(
            "control.speed_limit",
            f"v_max·dt = {s.speed_limit * s.dt:.4g} m exceeds min(d − r_max − ρ{walk}, "
            f"(d − 2R)/2) = {step:.4g} m: one step could reach an obstacle or agent not yet "
            f"sensed; lower it to at most {step / s.dt:.4g} m/s or raise control.sensing_radius",
        )
    starts = s.initial_positions
    for i, j in itertools.combinations(range(s.n), 2):
        gap = norm(starts[i] - starts[j])
        least = s.separation + 4.0 * s.position_error  # estimates 2e off: 2R + 2e between them
        if gap < least:
            extra = f" + 4 × position_error {s.position_error}" if s.position_error else ""
            raise ScenarioError(
                _start_field(s, j),
                f"agents {i + 1} and {j + 1} start {gap:.3g} m apart, closer than the "
                f"separation {s.separation} m{extra} the safety filter keeps",
            )


def _movers(s: Scenario) -> None:
    """Moving obstacles: only the safety filter acts on them, and every agent starts outside
    every guard circle r_j + ρ; they start apart from the standing obstacles and each other."""
    if s.control.safety != "filter":
        raise ScenarioError(
            f"obstacles[{s.mover_ids[0]}].moves",
            "moving obstacles need control.safety: filter (the paper's Algorithm 2 plans round "
            "standing obstacles only, so nothing would keep the agents off a moving one)",
        )
    rho = s.control.safety_margin
    for k in s.mover_ids:
        o = s.obstacles[k]
        for i, pos in enumerate(s.initial_positions):
            gap = norm(pos - np.asarray(o.centre)) - o.radius
            if gap < rho:
                raise ScenarioError(
                    f"obstacles[{k}].centre",
                    f"starts {gap:.3g} m from agent {i + 1}, inside its guard circle (ρ = "
                    f"{rho} m): the safety filter needs every agent to start outside",
                )
        for q, other in enumerate(s.obstacles):
            if q == k:
                continue
            gap = norm(np.asarray(o.centre) - np.asarray(other.centre)) - o.radius - other.radius
            if gap <= 0:
                raise ScenarioError(f"obstacles[{k}].centre", f"starts inside obstacles[{q}]")


def check_speed(s: Scenario) -> None:
    """Warn when |f| ≥ β in some coordinate, and when the speed limit is below
    :func:`cap_needed`."""
    peak = peak_speed(s.path)
    worst = int(np.argmax(peak))
    if peak[worst] >= s.control.beta:
        warnings.warn(
            f"{s.name}: the leader moves at up to {peak[worst]:.3g} m/s along axis {worst}, "
            f"not below β = {s.control.beta} m/s; Theorem 1 does not guarantee convergence",
            BetaWarning,
            stacklevel=3,
        )
    need = cap_needed(s.path, s.control.beta)
    cap, cause = s.speed_limit, ""
    if s.unicycle is not None and s.unicycle.any_direction(s.dt) < cap:
        cap = s.unicycle.any_direction(s.dt)
        cause = " (the unicycle's point cap in every direction)"
    if s.control.safety == "filter" and cap < need:
        warnings.warn(
            f"{s.name}: the speed limit {cap:.4g} m/s{cause} is below {need:.4g} m/s, "
            "the least at which the capped law still closes every coordinate of a follower's "
            "error against the leader's velocity: Theorem 1 does not guarantee convergence "
            "(lower the leader's speed, or give the robots more speed)",
            SpeedCapWarning,
            stacklevel=3,
        )


def unlimited(s: Scenario) -> str | None:
    """What it costs that ``s`` sets no ``control.speed_limit`` (None if it sets one, or if
    every agent is a unicycle, whose wheels give the limit): the largest speed the safety
    theorem admits is used, which no robot has. Said once by the command line, not warned on
    every load: the reference, the lockstep runs and the proofs hold with it all the same."""
    if s.control.speed_limit is not None or all(not a.single for a in s.agents):
        return None
    return (
        f"{s.name}: control.speed_limit is not set, so the largest the safety theorem admits, "
        f"{s.speed_limit:.3g} m/s, is used. No robot drives that fast: in realtime each "
        "robot's own safety layer then stands at every snapshot until its neighbours' arrive "
        "(docs/safety.md, Without a referee), and robots with mass are asked for speeds they "
        "cannot follow (docs/physics.md). Set it to your robots' top speed"
    )


def cap_needed(path: PathSpec, beta: float) -> float:
    """m/s: the least speed limit under which a follower's capped law still closes its error
    in every coordinate, whatever the leader's velocity f on ``path``.

    The cap scales the nominal f − β·s (s the signs of the error) by λ = v_max/‖f − β·s‖ ≤ 1;
    coordinate c's error then changes at λ(f_c − β·s_c) − f_c, which closes it iff
    λ > |f_c|/(β + |f_c|) (the worst case: s_c against f_c). With ‖f − β·s‖ at most
    √Σ(|f_c| + β)², that holds for every s when v_max exceeds
    √Σ(|f_c| + β)² · max_c |f_c|/(β + |f_c|) — maximised over the path's velocities."""
    f = np.abs(leader_velocities(path))
    if f.size == 0:
        return 0.0
    longest = np.sqrt(np.sum((f + beta) ** 2, axis=1))
    return float(np.max(longest * np.max(f / (beta + f), axis=1)))


# Every load-time check, in the order the loader runs them (it stops at the first).
CHECKS: tuple[Check, ...] = (
    Check("overlap", _obstacles_apart),
    Check("A1", _assumption1),
    Check("safety", _safety),
    Check("slots", _slots_apart),
    Check("A2", _assumption2, "standing"),
    Check("A3", _assumption3, "standing"),
    Check("A4", _leader_path, "standing", literal=_assumption4),
    Check("reach", _trigger_reach, "standing"),
    Check("starts", _starts_clear, "standing"),
    Check("goals", _final_slots_clear, "standing"),
    Check("movers", _movers, "movers"),
    Check("parked", _parked_movers, "movers"),
)
