"""Foxglove's exported views of a physics run: the log's plant records become /shoal/plant, one
message per plotted tick with each robot's speed, yaw rate, contacts and motors, valid against
its own schema; a kinematic run has no such channel."""

from __future__ import annotations

import jsonschema
import pytest
from physics_cases import CRASH

from shoal.bus.messages import PlantRecord, TickRecord
from shoal.tools.foxglove.plots import PLANT, SCHEMAS
from shoal.tools.foxglove.views import RunLog, ViewOptions, views
from shoal.tools.simulator import _commands, reference_step
from shoal.world.loader import parse_scenario

pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")


T0 = 1_790_000_000_000_000_000


def physics_log() -> RunLog:
    scn = parse_scenario(CRASH)
    step = reference_step(scn, "mujoco")
    ticks: list[tuple[int, TickRecord]] = []
    plants: dict[int, PlantRecord] = {}
    everyone = range(1, scn.n + 1)
    for k, reports in _commands(scn, step):
        ticks.append((T0 + k * 10_000_000, step.act_recorded(k, reports, everyone)))
        plants[k] = step.plant.record(k)  # type: ignore[assignment]
    return RunLog(scn, T0, ticks, (), plants)


def test_a_physics_run_exports_its_plant_channel() -> None:
    run = physics_log()
    got = [v.message for v in views(run, ViewOptions(plot_hz=1000.0)) if v.topic == PLANT]
    assert [m["tick"] for m in got] == sorted(run.plants)
    for m in got:
        jsonschema.validate(m, SCHEMAS["shoal.Plant"])
        assert [len(a["motors"]) for a in m["agents"]] == [2, 2]  # a base's x and y
    touched = [m for m in got if m["value"]]
    assert touched, "the crash's contact is in the channel"
    assert all(m["agents"][1]["contacts"] >= 1 for m in touched)  # the follower hit it
    fastest = max(a["value"] for m in got for a in m["agents"])
    assert 0.3 < fastest < 5.0  # a body's speed, m/s


def test_a_kinematic_run_has_no_plant_channel() -> None:
    run = physics_log()
    bare = RunLog(run.scenario, run.start_ns, run.ticks, ())
    assert not [v for v in views(bare, ViewOptions()) if v.topic == PLANT]
