"""The paper's figures, drawn from a scenario and the trajectory a run recorded.

Pure drawing: every function takes the run and returns a matplotlib ``Figure``; nothing here
reads files or picks a backend (``tools.plot`` does both). Agents are named by their ids, the
paper's 1..n (1 is the leader) as everywhere in shoal; arrays are indexed from 0. Distances in
m, times in s of simulated time. A 3-D run's trajectories add its x–z and y–z projections.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from shoal.geometry.path import path_positions
from shoal.geometry.vectors import FloatArray
from shoal.world.contacts import contacts
from shoal.world.metrics import (
    Summary,
    Sweep,
    clearances,
    formation_errors,
    pair_distances,
    summarize,
)
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory
from shoal.world.unicycle import body_centres

SNAPSHOTS = 6  # formation snapshots drawn along the trajectories (start and end included)


@dataclass(frozen=True)
class RunView:
    """What every figure is drawn from; ``summary`` is recomputed from the trajectory, so a
    figure never trusts a number the run merely claimed."""

    scenario: Scenario
    traj: Trajectory
    label: str  # where the run came from, for titles

    @property
    def times(self) -> FloatArray:
        """(T+1,) s: the time of every recorded position."""
        return np.arange(self.traj.positions.shape[0], dtype=np.float64) * self.traj.dt

    @property
    def tick_times(self) -> FloatArray:
        """(T,) s: the start of every tick."""
        return np.arange(self.traj.ticks, dtype=np.float64) * self.traj.dt

    def summary(self) -> Summary:
        return summarize(self.scenario, self.traj)


def colour(agent: int) -> Any:
    """One colour per agent (array column), the same in every figure: the leader's (C0) is its
    own; followers take the 18 colours of tab20 unlike it (its two blues skipped), in turn."""
    if agent == 0:
        return "C0"
    return colormaps["tab20"](2 + (agent - 1) % 18)


def agent_name(column: int) -> str:
    """The name of the agent in array column ``column`` (id = column + 1)."""
    return "agent 1 (leader)" if column == 0 else f"agent {column + 1}"


def _figure(width: float = 8.0, height: float = 4.5) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def _snapshot_ticks(view: RunView, count: int = SNAPSHOTS) -> list[int]:
    last = view.traj.positions.shape[0] - 1
    return sorted({round(x) for x in np.linspace(0, last, count)})


def _omega_at(view: RunView, k: int) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Ω of every agent at position index k (the last position takes the last tick's flags)."""
    return np.asarray(view.traj.omega[min(k, view.traj.ticks - 1)], dtype=np.bool_)


# Above this many agents the legend names the leader only; the followers' ids are written at
# the ends of their paths instead (a legend of 12+ entries hid the plot).
LEGEND_AGENTS = 10


def trajectories(view: RunView) -> Figure:
    """Fig. 1b / 2a / 3a: every agent's path, the obstacles with their trigger discs, the
    leader's reference path, formation snapshots with the graph's edges (an edge to an evading
    agent, which its neighbours drop, dashed grey) and every collision, marked where it began.
    A 3-D run gets two more panels, the x–z and y–z projections."""
    sc = view.scenario
    if sc.dim == 3:
        fig = _figure(9.0, 9.0)
        grid = fig.add_gridspec(2, 2, height_ratios=(2.0, 1.0))
        main = fig.add_subplot(grid[0, :])
        sides = [(fig.add_subplot(grid[1, 0]), (0, 2)), (fig.add_subplot(grid[1, 1]), (1, 2))]
    else:
        fig = _figure(9.0, 6.0)
        main, sides = fig.add_subplot(), []
    _draw_paths(main, view, (0, 1), snapshots=True)
    for ax, axes in sides:
        _draw_paths(ax, view, axes, snapshots=False)
    handles, _ = main.get_legend_handles_labels()  # only what the figure draws
    if sc.standing_ids:
        handles += [
            Line2D([], [], color="0.35", marker="o", ls="", ms=9, label="obstacle"),
            Line2D([], [], color="0.55", ls=":", label="obstacle + trigger radius"),
        ]
    if view.traj.omega.any():
        handles += [
            Line2D([], [], color="0.3", lw=3.5, alpha=0.45, label="evading (Ω = 1)"),
            Line2D([], [], color="0.5", ls="--", lw=0.8, label="edge dropped (evading)"),
        ]
    if sc.mover_ids:
        handles.append(
            Line2D([], [], color=MOVER_COLOUR, marker="o", lw=0.9,
                   label="moving obstacle (trail, at the snapshots, 1 s of its velocity)")
        )  # fmt: skip
    if sc.n > LEGEND_AGENTS:
        handles.append(Line2D([], [], color="0.3", lw=1.2, label="followers: id at path's end"))
    main.legend(handles=handles, fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    times = ", ".join(f"{k * view.traj.dt:g}" for k in _snapshot_ticks(view))
    hits = len(_collisions(view))
    crashed = f"; {hits} collision{'s' if hits != 1 else ''} (×)" if hits else ""
    main.set_title(f"{view.label}: trajectories{crashed}\nformation at t = {times} s")
    return fig


_AXIS_NAMES = ("x", "y", "z")


def _draw_paths(ax: Axes, view: RunView, axes: tuple[int, int], *, snapshots: bool) -> None:
    """Paths, obstacles and collisions projected on the coordinates ``axes`` (0 x, 1 y, 2 z)."""
    sc, pos = view.scenario, view.traj.positions
    u, w = axes
    for o in sc.standing:
        x, y = o.centre[u], o.centre[w]  # a sphere projects onto a circle of its radius
        ax.add_patch(Circle((x, y), o.radius, color="0.35", zorder=1))
        trigger = o.radius + sc.control.trigger_radius
        ax.add_patch(Circle((x, y), trigger, fill=False, ls=":", color="0.55", lw=0.8, zorder=1))
    _draw_movers(ax, view, axes, snapshots=snapshots)
    ref = path_positions(sc.path, view.times)
    ax.plot(ref[:, u], ref[:, w], color="k", lw=0.8, ls="--", label="leader's path", zorder=2)
    named = sc.n <= LEGEND_AGENTS
    for i in range(sc.n):
        label = agent_name(i) if named or i == 0 else None
        ax.plot(pos[:, i, u], pos[:, i, w], color=colour(i), lw=1.2, label=label, zorder=3)
        evading = np.concatenate([view.traj.omega[:, i], [False]])
        if evading.any():
            masked = np.where(evading[:, None], pos[:, i, :][:, [u, w]], np.nan)
            ax.plot(masked[:, 0], masked[:, 1], color=colour(i), lw=3.5, alpha=0.45, zorder=3)
        if not named and i > 0:
            ax.annotate(
                str(i + 1), (pos[-1, i, u], pos[-1, i, w]), fontsize=7, color=colour(i),
                xytext=(3, 3), textcoords="offset points", zorder=6,
            )  # fmt: skip
    if snapshots:
        shades = np.linspace(0.25, 0.9, len(_snapshot_ticks(view)))
        for shade, k in zip(shades, _snapshot_ticks(view), strict=True):
            _draw_formation(ax, view, k, alpha=float(shade), axes=axes)
    theirs = [c for c in contacts(sc, view.traj) if not c.agent_at_fault]
    if theirs:
        where = np.asarray([pos[c.start, c.agent - 1] for c in theirs])
        ax.plot(
            where[:, u], where[:, w], ls="", marker="o", ms=9, mfc="none", mec=MOVER_COLOUR,
            mew=1.5, label="walked into by a moving obstacle", zorder=7,
        )  # fmt: skip
    spots = _collisions(view)
    if spots:
        where = np.asarray([pos[k, i] for k, i, _ in spots])
        ax.plot(
            where[:, u], where[:, w], ls="", marker="X", ms=11, color="r", mec="k", mew=0.6,
            label="collision (where it began)", zorder=7,
        )  # fmt: skip
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{_AXIS_NAMES[u]} (m)")
    ax.set_ylabel(f"{_AXIS_NAMES[w]} (m)")
    ax.grid(True, lw=0.3)


MOVER_COLOUR = "purple"


def _draw_movers(ax: Axes, view: RunView, axes: tuple[int, int], *, snapshots: bool) -> None:
    """Moving obstacles: each one's trail, where it starts (dashed), and with ``snapshots``
    where it is at the formation's snapshot times, with an arrow of one second's walk."""
    sc, movers, walks = view.scenario, view.traj.movers, view.traj.mover_velocities
    if movers is None or walks is None:
        return
    u, w = axes
    for q, k in enumerate(sc.mover_ids):
        r = sc.obstacles[k].radius
        ax.plot(movers[:, q, u], movers[:, q, w], color=MOVER_COLOUR, lw=0.9, alpha=0.7, zorder=2)
        start = (movers[0, q, u], movers[0, q, w])
        ax.add_patch(Circle(start, r, fill=False, ls="--", color=MOVER_COLOUR, lw=0.8, zorder=2))
        if not snapshots:
            continue
        ticks = _snapshot_ticks(view)
        for shade, t in zip(np.linspace(0.25, 0.9, len(ticks)), ticks, strict=True):
            at = min(t, walks.shape[0] - 1)
            x, y = movers[t, q, u], movers[t, q, w]
            ax.add_patch(Circle((x, y), r, color=MOVER_COLOUR, alpha=float(shade), zorder=5))
            ax.annotate(
                "", (x + walks[at, q, u], y + walks[at, q, w]), (x, y),
                arrowprops={"arrowstyle": "->", "color": MOVER_COLOUR, "lw": 1.0}, zorder=5,
            )  # fmt: skip


def _collisions(view: RunView) -> list[tuple[int, int, str]]:
    """(position index, agent column, what) of every collision's first moment, the start of the
    first step in which it happened (the summary's count, world/metrics.py): an agent closer
    than its radius to a standing obstacle's edge, two agents closer than twice it (both
    marked), or an agent that moved into a moving obstacle (world/contacts.py)."""
    sc, traj = view.scenario, view.traj
    swept = Sweep.of(sc, traj)
    out: list[tuple[int, int, str]] = []
    if sc.standing_ids:
        inside = np.asarray(
            (swept.clearance < sc.agent_radius - swept.slack).any(axis=2), dtype=np.bool_
        )
        for i in range(sc.n):
            out += [(a, i, "obstacle") for a, _ in _runs(inside[:, i])]
    out += [(c.start, c.agent - 1, "mover") for c in contacts(sc, traj) if c.agent_at_fault]
    close = np.asarray(swept.separation < 2 * sc.agent_radius - swept.slack, dtype=np.bool_)
    for col, (i, j) in enumerate(itertools.combinations(range(sc.n), 2)):
        for a, _ in _runs(close[:, col]):
            out += [(a, i, "agent"), (a, j, "agent")]
    return sorted(out)


def _draw_formation(
    ax: Axes, view: RunView, k: int, *, alpha: float, axes: tuple[int, int] = (0, 1)
) -> None:
    sc, full = view.scenario, view.traj.positions[k]
    p = full[:, list(axes)]
    omega = _omega_at(view, k)
    for i, j in _edge_columns(sc):
        dropped = bool(omega[i] or omega[j])
        ax.plot(
            [p[i, 0], p[j, 0]],
            [p[i, 1], p[j, 1]],
            color="0.5" if dropped else "0.15",
            ls="--" if dropped else "-",
            lw=0.8,
            alpha=alpha,
            zorder=4,
        )
    headings, lookahead = view.traj.headings, sc.lookaheads
    if headings is not None and lookahead is not None:  # unicycles: body and heading, 2-D
        axles = body_centres(full, headings[k], lookahead)
        for i in range(sc.n):
            ax.add_patch(Circle(tuple(axles[i]), sc.agent_radius, fill=False, color=colour(i),
                                lw=0.8, alpha=alpha, zorder=5))  # fmt: skip
            ax.plot([axles[i, 0], p[i, 0]], [axles[i, 1], p[i, 1]], color=colour(i), lw=1.0,
                    alpha=alpha, zorder=5)  # fmt: skip
    for i in range(sc.n):
        ax.plot(
            p[i, 0],
            p[i, 1],
            marker="*" if i == 0 else "o",
            ms=10 if i == 0 else 6,
            color=colour(i),
            mec="k",
            mew=0.5,
            alpha=alpha,
            zorder=5,
        )


def _edge_columns(sc: Scenario) -> list[tuple[int, int]]:
    """The graph's edges as (smaller, larger) column pairs, each once (scenario files use ids)."""
    return sorted({(min(i, j) - 1, max(i, j) - 1) for i, j in sc.edges})


def distances(view: RunView) -> Figure:
    """Fig. 2b / 3b: distance between every pair of neighbours over time against the collision
    distance (twice the agent radius) and the filter's separation, and (with obstacles) each
    agent's clearance to the nearest obstacle's edge against the agent radius (collision) and
    the guard ρ; the axes reach below zero when something went through something. The lines
    are samples at ticks; the minima in the titles (and the axes' reach) are the least over
    whole steps, as the summary reports them."""
    sc, t = view.scenario, view.times
    swept = Sweep.of(sc, view.traj)
    least = float(swept.separation.min())
    panels = 2 if sc.obstacles else 1
    fig = _figure(9.0, 3.4 * panels)
    axes = fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0]
    pairs = list(itertools.combinations(range(sc.n), 2))
    dist = pair_distances(view.traj)
    neighbours = set(_edge_columns(sc))
    ax = axes[0]
    for col, (i, j) in enumerate(pairs):
        if (i, j) in neighbours:
            ax.plot(t, dist[:, col], lw=1.0, label=f"{i + 1}–{j + 1}")
    others = [c for c, pair in enumerate(pairs) if pair not in neighbours]
    if others:
        ax.plot(
            t,
            dist[:, others].min(axis=1),
            color="0.5",
            lw=0.8,
            ls="-.",
            label="closest non-neighbours",
        )
    a = sc.agent_radius
    ax.axhline(2 * a, color="r", lw=1.0, ls="--", label=f"collision (2 × radius {a:g} m)")
    if sc.params().filtered:
        ax.axhline(
            sc.separation, color="r", lw=0.8, ls=":", label=f"separation {sc.separation:g} m"
        )
    ax.set_ylabel("inter-agent distance (m)")
    ax.set_ylim(bottom=min(0.0, least))
    ax.legend(fontsize="small", ncol=4, loc="best")
    ax.set_title(f"{view.label}: distances between neighbours (min {least:.3f} m)")
    if sc.obstacles:
        clear = clearances(sc, view.traj).min(axis=2)
        lowest = min(float(clear.min()), float(swept.clearance.min(initial=np.inf)))
        ax = axes[1]
        for i in range(sc.n):
            ax.plot(t, clear[:, i], color=colour(i), lw=1.0, label=agent_name(i))
        ax.axhline(a, color="r", lw=1.0, ls="--", label=f"collision (radius {a:g} m)")
        rho = sc.control.safety_margin
        ax.axhline(rho, color="r", lw=0.8, ls=":", label=f"guard ρ = {rho:g} m")
        ax.set_ylabel("clearance to nearest obstacle (m)")
        ax.set_yscale("symlog", linthresh=1.0)
        ax.set_ylim(bottom=min(0.0, lowest))  # a collision shows below zero
        ax.legend(fontsize="small", ncol=3, loc="best")
        ax.set_title(f"clearance to obstacles (min {lowest:.3f} m)")
    for ax in axes:
        ax.grid(True, lw=0.3)
    axes[-1].set_xlabel("time (s)")
    return fig


def formation_error(view: RunView) -> Figure:
    """Each follower's formation error ‖s_i - s_0 - R(θ)δ_i/σ‖_∞ over time, on a log axis, with
    the tolerance band and the convergence-time bound of Theorem 1 (Remark 3 if directed)."""
    sc, summary = view.scenario, view.summary()
    errors = formation_errors(sc, view.traj)
    floor = sc.tolerance * 1e-3  # the sign term chatters; exact zeros would vanish on a log axis
    fig = _figure()
    ax = fig.add_subplot()
    for f in range(errors.shape[1]):
        ax.plot(
            view.tick_times,
            np.maximum(errors[:, f], floor),
            color=colour(f + 1),
            lw=1.0,
            label=agent_name(f + 1),
        )
    ax.axhline(sc.tolerance, color="k", lw=0.8, ls=":", label=f"tolerance {sc.tolerance:g} m")
    which = "Remark 3" if sc.directed else "Theorem 1"
    if math.isfinite(summary.convergence_bound):
        ax.axvline(
            summary.convergence_bound,
            color="r",
            lw=1.2,
            ls="--",
            label=f"{which} bound t̄ = {summary.convergence_bound:.2f} s",
        )
    if summary.convergence_time is not None:
        ax.axvline(
            summary.convergence_time,
            color="g",
            lw=1.0,
            label=f"converged at {summary.convergence_time:.2f} s",
        )
    for a, b in _runs(np.asarray(view.traj.omega.any(axis=1), dtype=np.bool_)):
        ax.axvspan(a * view.traj.dt, b * view.traj.dt, color="0.85", lw=0, zorder=0)
    ax.set_yscale("log")
    ax.set_xlabel("time (s) — grey: some agent evading, its slot deliberately left")
    ax.set_ylabel("formation error (m, ∞-norm)")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize="small", loc="best")
    ax.set_title(f"{view.label}: formation error against the convergence bound")
    return fig


def consensus(view: RunView) -> Figure:
    """σ each agent applies over time and, zoomed on the first epoch in which someone bid above
    1, Algorithm 1's rounds: every agent's value per round until all hold the maximum."""
    sc, traj, t = view.scenario, view.traj, view.tick_times
    fig = _figure(9.0, 6.0)
    top, bottom = fig.subplots(2, 1)
    for i in range(sc.n):
        top.step(
            t, traj.sigma[:, i], where="post", color=colour(i), lw=1.0, label=f"σ, {agent_name(i)}"
        )
    top.step(t, traj.bid.max(axis=1), where="post", color="k", lw=0.6, ls=":", label="largest bid")
    top.set_xlabel("time (s)")
    top.set_ylabel("contraction factor σ")
    top.grid(True, lw=0.3)
    top.legend(fontsize="small", ncol=3, loc="best")
    top.set_title(f"{view.label}: scale agreed by max-consensus (L_G = {sc.rounds} rounds/epoch)")
    start = _first_contracting_epoch(traj.bid, sc.rounds)
    if start is None:
        bottom.text(
            0.5,
            0.5,
            "no agent bid above 1: the formation never had to contract",
            ha="center",
            va="center",
            transform=bottom.transAxes,
        )
        bottom.set_axis_off()
        return fig
    # Values announced at tick start + r have been through r rounds; after the epoch's L_G
    # rounds, the σ each agent applies at the next epoch's first tick is round L_G's value.
    k = sc.rounds
    held = traj.bid[start : start + k]
    if start + k < traj.ticks:
        held = np.concatenate([held, traj.sigma[start + k][None]])
    rounds = np.arange(held.shape[0])
    for i in range(sc.n):
        bottom.plot(
            rounds, held[:, i], marker="o", ms=10 - i % 6, color=colour(i), label=agent_name(i)
        )
    bottom.set_xticks(
        rounds, [f"{r}" + (" (σ applied)" if r == k else "") for r in rounds.tolist()]
    )
    bottom.set_xlabel(f"round of Algorithm 1 (epoch starting at t = {start * traj.dt:g} s)")
    bottom.set_ylabel("value held (bid)")
    bottom.grid(True, lw=0.3)
    bottom.legend(fontsize="small", ncol=3, loc="best")
    return fig


def _first_contracting_epoch(bid: FloatArray, rounds: int) -> int | None:
    for start in range(0, bid.shape[0], rounds):
        if float(bid[start : start + rounds].max()) > 1.0:
            return start
    return None


def omega_timeline(view: RunView) -> Figure:
    """When each agent was on a collision course (Ω = 1) and evading."""
    sc, traj = view.scenario, view.traj
    fig = _figure(9.0, 0.5 * sc.n + 1.6)
    ax = fig.add_subplot()
    for i in range(sc.n):
        spans = _runs(traj.omega[:, i])
        ax.broken_barh(
            [(a * traj.dt, (b - a) * traj.dt) for a, b in spans],
            (i - 0.35, 0.7),
            color=colour(i),
        )
    ax.set_yticks(range(sc.n), [agent_name(i) for i in range(sc.n)])
    ax.set_ylim(sc.n - 0.5, -0.5)
    ax.set_xlim(0, traj.ticks * traj.dt)
    ax.set_xlabel("time (s)")
    ax.grid(True, axis="x", lw=0.3)
    episodes = sum(len(_runs(traj.omega[:, i])) for i in range(sc.n))
    ax.set_title(f"{view.label}: Ω timeline ({episodes} evasion episodes)")
    return fig


def _runs(flags: np.ndarray[Any, np.dtype[np.bool_]]) -> list[tuple[int, int]]:
    """[start, end) tick spans where flags hold."""
    padded = np.concatenate([[False], flags, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def achieved_velocities(traj: Trajectory) -> FloatArray:
    """(T-1, n, dim) m/s: each agent's point's mean velocity over every tick but the last, from
    where it was at the tick's start and the next one's, as the plant moved it (the pose after
    the last tick is not recorded: readers integrate it from the last command)."""
    moved: FloatArray = np.diff(traj.positions[:-1], axis=0) / traj.dt
    return moved


def tracking(view: RunView) -> Figure:
    """Each agent's commanded speed against the speed its robot achieved, tick by tick, and the
    gap |achieved − commanded| between the two vectors. The world's kinematics move every
    point exactly as commanded (the gap is rounding); robots with mass (``--plant mujoco``)
    lag, saturate and overshoot, and the gap is what the safety filter's theorem does not
    cover."""
    traj = view.traj
    achieved = achieved_velocities(traj)
    commanded = traj.velocities[: achieved.shape[0]]
    times = view.tick_times[: achieved.shape[0]]
    gap = np.linalg.norm(achieved - commanded, axis=-1)
    fig = _figure(height=6.0)
    top, bottom = fig.subplots(2, 1, sharex=True)
    for i in range(commanded.shape[1]):
        c = colour(i + 1)
        top.plot(times, np.linalg.norm(commanded[:, i], axis=-1), color=c, lw=0.8, ls="--")
        top.plot(times, np.linalg.norm(achieved[:, i], axis=-1), color=c, lw=1.0,
                 label=agent_name(i + 1))  # fmt: skip
        bottom.plot(times, np.maximum(gap[:, i], 1e-12), color=c, lw=0.8)
    top.set_ylabel("speed (m/s): dashed commanded, solid achieved")
    top.legend(fontsize="small", loc="best")
    top.grid(True, lw=0.3)
    bottom.set_yscale("log")
    bottom.set_ylabel("|achieved − commanded| (m/s)")
    bottom.set_xlabel("time (s)")
    bottom.grid(True, which="both", lw=0.3)
    top.set_title(f"{view.label}: commanded against achieved velocity")
    return fig


FIGURES = {
    "trajectories": trajectories,
    "distances": distances,
    "formation_error": formation_error,
    "consensus": consensus,
    "omega": omega_timeline,
    "tracking": tracking,
}
