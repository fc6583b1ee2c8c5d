"""MuJoCo as a plant (world/physics/): every built-in runs on robots with mass, two runs are the
same bytes, a crash is a contact the engine reports and the summary counts, and a scenario's
``dynamics:`` section is checked field by field at load."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from physics_cases import CRASH

from shoal.tools.cli import main
from shoal.tools.simulator import reference
from shoal.world.dynamics import PRESETS
from shoal.world.errors import ScenarioError
from shoal.world.loader import builtin_names, load_scenario, parse_scenario
from shoal.world.metrics import summarize
from shoal.world.plant import MUJOCO, simulated

pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")


@pytest.mark.parametrize("name", builtin_names())
def test_every_builtin_runs_on_robots_with_mass(name: str) -> None:
    """Two seconds of each built-in in the engine: the robots start where the scenario puts
    them, every physics step is judged, and nothing touches."""
    scn = dataclasses.replace(load_scenario(name), duration=2.0)
    plant = simulated(scn, MUJOCO)
    start = plant.observe()
    assert np.abs(start.positions - scn.initial_positions).max() < 1e-12
    traj, judged = reference(scn, plant=MUJOCO)
    assert judged["plant"] == "mujoco" and judged["physics_steps"] == traj.ticks * round(
        scn.dt / judged["physics_step"]
    )
    assert judged["engine_contacts"] == 0 and judged["collisions"] == 0
    assert np.isfinite([judged["tracking_error_p50"], judged["tracking_error_max"]]).all()


def test_two_physics_runs_are_the_same_bytes() -> None:
    scn = dataclasses.replace(load_scenario("robotarium"), duration=3.0)
    first, judged = reference(scn, plant=MUJOCO)
    second, again = reference(scn, plant=MUJOCO)
    assert first.digest() == second.digest() and judged == again


def test_a_crash_is_a_contact_the_engine_reports_and_the_summary_counts() -> None:
    """The paper's law alone (no safety filter) drives the follower into an obstacle: the
    engine's contact is the collision, and the figures are the engine's motion's."""
    scn = parse_scenario(CRASH)
    traj, judged = reference(scn, plant=MUJOCO)
    assert judged["engine_contacts"] >= 1 and judged["collisions"] >= 1
    assert judged["engine_deepest_contact"] < -1e-3  # a real overlap, millimetres deep
    # the least point-to-edge distance is inside the body radius: the overlap the engine saw
    assert judged["min_clearance"] < scn.agent_radius
    # without the engine's judgement the same run would still be a collision by the ticks
    assert summarize(scn, traj).collisions >= 1


def test_a_crash_on_the_kinematic_plant_is_judged_by_the_ticks_only() -> None:
    """The kinematic plant reports no engine figures (the ticks' own judge the run)."""
    scn = parse_scenario(CRASH)
    _, judged = reference(scn)
    assert judged == {}


@pytest.mark.parametrize(
    ("section", "field", "words"),
    [
        ("{preset: segway}", "dynamics.preset", "must be one of gritsbot"),
        ("{preset: holonomic, mass: -1}", "dynamics.mass", "positive"),
        ("{preset: holonomic, mass: .nan}", "dynamics.mass", "finite"),
        ("{preset: holonomic, latency: -0.01}", "dynamics.latency", "non-negative"),
        ("{preset: holonomic, axle: 0.1}", "dynamics.axle", "not a figure of a holonomic"),
        ("{preset: holonomic, wheels: 3}", "dynamics.wheels", "unknown"),
        ("{mass: 3}", "dynamics.preset", "is required"),
        ("{preset: gritsbot}", "dynamics.preset", "every agent is one of the single"),
        ("[holonomic]", "dynamics", "must be a mapping"),
    ],
)
def test_a_bad_dynamics_section_is_named_at_load(section: str, field: str, words: str) -> None:
    text = load_scenario("default").source + f"dynamics: {section}\n"
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text)
    assert caught.value.field == field and words in str(caught.value)


def test_the_files_overrides_apply_to_the_preset_the_command_line_names() -> None:
    text = load_scenario("default").source + "dynamics: {preset: holonomic, latency: 0.03}\n"
    scn = parse_scenario(text)
    robot = scn.robot_dynamics()[0]
    assert (robot.preset, robot.latency, robot.mass) == (
        "holonomic",
        0.03,
        PRESETS["holonomic"].mass,
    )
    heavy = scn.robot_dynamics("holonomic-heavy")[0]
    assert (heavy.preset, heavy.latency, heavy.mass) == ("holonomic-heavy", 0.03, 10.0)


def test_a_mixed_formation_has_wheels_and_bases() -> None:
    text = load_scenario("robotarium").source.replace(
        "[-0.4, 0.4]}", "[-0.4, 0.4], kinematics: single}"
    )
    robots = parse_scenario(text).robot_dynamics("turtlebot3")
    assert [r.preset for r in robots] == ["turtlebot3", "holonomic", *["turtlebot3"] * 3]


def test_shoal_simulate_with_the_engine_says_which_plant_ran(tmp_path: Path) -> None:
    path = tmp_path / "crash.yaml"
    path.write_text(CRASH)
    runner = CliRunner()
    got = runner.invoke(main, ["simulate", str(path), "--plant", "mujoco", "--json"])
    assert got.exit_code == 0, got.output
    summary = json.loads(got.stdout)
    assert summary["plant"] == "mujoco" and summary["dynamics"] == "holonomic"
    assert summary["engine_contacts"] >= 1 and summary["collisions"] >= 1
    text = runner.invoke(main, ["simulate", str(path), "--plant", "mujoco"]).stdout
    assert "mujoco (holonomic)" in text and "engine contacts" in text


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--dynamics", "holonomic"], "add --plant mujoco"),
        (["--plant", "mujoco", "--dynamics", "gritsbot"], "--dynamics: gritsbot is a differential"),
        (["--plant", "bullet"], "Invalid value for '--plant'"),
    ],
)
def test_a_plant_that_cannot_run_is_refused_before_anything_starts(
    args: list[str], words: str
) -> None:
    got = CliRunner().invoke(main, ["simulate", "default", *args])
    assert got.exit_code != 0 and words in got.output


def test_the_world_publishes_the_engines_bodies_every_tick() -> None:
    """A lockstep run on an in-memory bus with the engine as the world's plant: one plant
    record per tick, each robot's body l behind its point, its motors' figures, and the
    contact of the crash in the tick it happened."""
    from memoryrun import RUN, run_in_memory

    from shoal.bus import codec
    from shoal.bus.keys import Keys
    from shoal.bus.memory import MemoryBus

    scn = parse_scenario(CRASH)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus, plant=simulated(scn, MUJOCO), plant_name=MUJOCO)
    assert not errors
    key = Keys(RUN)
    records = [codec.decode_plant(p) for k, p in bus.published if k == key.plant]
    ticks = [codec.decode_tick(p) for k, p in bus.published if k == key.tick]
    assert [r.tick for r in records] == [t.tick for t in ticks] == list(range(scn.steps))
    for r, nxt in zip(records, ticks[1:], strict=False):  # a base's body is its point
        assert r.bodies == nxt.positions and len(r.motor_speeds) == 2 * scn.n
    touched = [r for r in records if r.contacts]
    assert touched and all(c[0] == 2 and c[1] == scn.n + 1 and c[2] < 0 for r in touched
                           for c in r.contacts)  # fmt: skip
    assert summary["engine_contacts"] >= 1 and summary["plant"] == "mujoco"


@pytest.mark.parametrize(
    ("section", "field", "words"),
    [
        ("{preset: holonomic, loop_time: 0.001}", "dynamics.loop_time", "two physics steps"),
        ("{preset: holonomic, timestep: 0.015}", "dynamics.timestep", "two physics steps"),
        ("{preset: holonomic, timestep: 0.000001, loop_time: 0.001}", "dynamics.timestep",
         "below"),
    ],
)  # fmt: skip
def test_a_velocity_loop_the_physics_step_cannot_resolve_is_refused(
    section: str, field: str, words: str
) -> None:
    text = load_scenario("default").source + f"dynamics: {section}\n"
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text)
    assert caught.value.field == field and words in str(caught.value)


def test_a_diverging_engine_is_an_error_not_robots_back_at_their_starts() -> None:
    """MuJoCo resets a state gone non-finite and warns; the plant must say so, not go on from
    the reset. A base of a microgram under a 4 m/s² loop diverges at once."""
    from shoal.world.physics.engine import Engine
    from shoal.world.plant import PlantError

    scn = dataclasses.replace(load_scenario("default"), duration=0.5)
    robots = tuple(dataclasses.replace(r, mass=1e-9) for r in scn.robot_dynamics())
    plant = Engine(scn, robots)
    plant.data.qvel[:] = 1e30  # as a blow-up leaves it
    with pytest.raises(PlantError, match="diverged"):
        seen = plant.observe()
        plant.send(np.ones((scn.n, 2)), seen.headings)
    assert not (Path.cwd() / "MUJOCO_LOG.TXT").exists()  # MuJoCo's warning came to the plant


def test_the_engine_is_the_pinned_version() -> None:
    """Physics runs are bit-exact only within one MuJoCo version (and CPU architecture): the
    determinism and lockstep-equality checks here are made on the version pyproject.toml pins."""
    import tomllib

    import mujoco

    from shoal.world.physics.engine import PINNED

    pyproject = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    assert pyproject["project"]["optional-dependencies"]["physics"] == [f"mujoco=={PINNED}"]
    assert mujoco.__version__ == PINNED
