"""world/trajectory.Recorder, the one way a run is recorded: what it keeps when a run ends early,
how it closes the last tick, and that a log's tick records rebuild the same trajectory."""

from __future__ import annotations

import numpy as np
import pytest

from shoal.bus.messages import TickRecord
from shoal.world.trajectory import Recorder, Trajectory


def tick(k: int) -> TickRecord:
    """Two agents in 2-D and one moving obstacle; every figure depends on k."""
    return TickRecord(
        tick=k,
        positions=((float(k), 0.0), (0.0, float(k))),
        velocities=((1.0, 0.5), (-0.5, 1.0)),
        omega=(k % 2 == 0, False),
        bid=(1.0 - 0.1 * k, 1.0),
        sigma=(1.0, 0.9),
        theta=(0.0, 0.1 * k),
        alive=(True, True),
        filtered=(False, k == 1),
        mover_centres=((5.0 + k, 5.0),),
        mover_velocities=((2.0, 0.0),),
    )


def test_a_run_that_ends_early_keeps_exactly_the_ticks_it_recorded() -> None:
    recorder = Recorder(0.5, 2, 2, steps=10, movers=1)
    for k in range(3):
        recorder.record(tick(k))
    traj = recorder.finish()
    assert traj.ticks == 3
    assert traj.positions.shape == (4, 2, 2) and traj.velocities.shape == (3, 2, 2)
    assert traj.movers is not None and traj.movers.shape == (4, 1, 2)
    # after the last tick: start + dt · velocity, as the world integrates
    assert traj.positions[3].tolist() == [[2.5, 0.25], [-0.25, 2.5]]
    assert traj.movers[3].tolist() == [[8.0, 5.0]]
    assert traj.omega[:, 0].tolist() == [True, False, True]
    assert traj.filtered[:, 1].tolist() == [False, True, False]
    assert traj.theta[:, 1] == pytest.approx([0.0, 0.1, 0.2])


def test_given_final_positions_replace_the_integrated_ones() -> None:
    recorder = Recorder(0.5, 2, 2, steps=2)
    announced = ([True] * 2, [1.0] * 2, [1.0] * 2, [0.0] * 2)
    recorder.add(np.zeros((2, 2)), np.ones((2, 2)), announced, [False] * 2)
    traj = recorder.finish(positions=np.full((2, 2), 7.0))
    assert traj.positions[-1].tolist() == [[7.0, 7.0], [7.0, 7.0]]
    assert traj.movers is None and traj.mover_velocities is None


def test_a_trajectory_needs_a_tick() -> None:
    with pytest.raises(ValueError, match="at least one tick"):
        Recorder(0.5, 2, 2, steps=5).finish()


def test_tick_records_rebuild_the_trajectory_the_recorder_built() -> None:
    records = [tick(k) for k in range(4)]
    recorder = Recorder(0.5, 2, 2, steps=4, movers=1)
    for r in records:
        recorder.record(r)
    assert Trajectory.from_records(records, 0.5).digest() == recorder.finish().digest()
