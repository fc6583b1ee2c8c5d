"""``shoal plot``'s tracking figure: commanded against achieved velocity, from the log's ticks.
The world's kinematics track exactly; robots with mass (``--plant mujoco``) do not."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from shoal.tools.plot.figures import FIGURES, RunView, achieved_velocities, tracking
from shoal.tools.plot.save import FIGURE_COUNT
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario


def gaps(view: RunView) -> np.ndarray:
    """The drawn |achieved − commanded| of every agent, from the figure's lower panel."""
    figure = tracking(view)
    bottom = figure.axes[1]
    return np.array([line.get_ydata() for line in bottom.get_lines()])


def test_the_count_the_command_shows_is_the_figures_it_draws() -> None:
    assert len(FIGURES) == FIGURE_COUNT and "tracking" in FIGURES


def test_the_kinematic_plant_achieves_what_was_commanded() -> None:
    scn = dataclasses.replace(load_scenario("default"), duration=3.0)
    traj = simulate(scn)
    achieved = achieved_velocities(traj)
    assert achieved.shape == (traj.ticks - 1, scn.n, scn.dim)
    drawn = gaps(RunView(scn, traj, "default"))
    assert drawn.shape == (scn.n, traj.ticks - 1) and drawn.max() < 1e-9


def test_robots_with_mass_lag_behind_their_commands_and_the_figure_shows_it() -> None:
    pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")
    scn = dataclasses.replace(load_scenario("default"), duration=3.0)
    traj = simulate(scn, plant="mujoco")
    drawn = gaps(RunView(scn, traj, "default on mujoco"))
    # the formation's first jumps are beyond what a 4 m/s² base reaches in a tick
    assert drawn.max() > 0.1
    # and the achieved velocities are a body's: one tick's mean differs from the next by at
    # most the force limit's acceleration over a tick
    achieved = achieved_velocities(traj)
    change = np.linalg.norm(np.diff(achieved, axis=0), axis=-1)
    assert change.max() <= 4.0 * scn.dt * (1 + 1e-6)


def test_foxglove_views_plot_the_tracking_of_every_tick_across_blocks() -> None:
    """The exported views' tracking channel: one message per plotted tick, the world's
    kinematics tracked up to rounding, and a block's last tick judged against the next block's
    first positions (BLOCK ticks per block)."""
    from runlogs import TINY, reference_log

    from shoal.tools.foxglove.plots import TRACKING, tracking
    from shoal.tools.foxglove.views import BLOCK, ViewOptions, views

    run = reference_log(TINY.replace("duration: 4.0", "duration: 12.0"))
    got = [v.message for v in views(run, ViewOptions(plot_hz=1000.0)) if v.topic == TRACKING]
    assert [m["tick"] for m in got] == [r.tick for _ns, r in run.ticks]
    assert max(m["value"] for m in got) < 1e-6
    records = [r for _ns, r in run.ticks]
    assert len(records) > BLOCK
    # a block's last tick: judged from the next record, not integrated from its own command
    moved = [list(p) for p in records[BLOCK].positions]
    moved[0][0] += 0.01 * run.scenario.dt  # as if robot 1 had gone 0.01 m/s faster
    last = tracking(run.scenario, records[:BLOCK], moved)[-1]
    assert last["agents"][0]["value"] == pytest.approx(0.01, abs=1e-6)
