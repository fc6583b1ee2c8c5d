"""What every plant must do, checked on the world's kinematics and on MuJoCo's robots with mass
(world/physics/) where the physics allows: a velocity held long enough is tracked within the
stated bound; a motor's limit saturates and is never exceeded; latency delays; a robot whose
commands stop comes to rest by its own timeout.

The robots are driven directly (no controller), by commands a test chooses, and compared with
the exact kinematics of the same commands (world/unicycle.py's arcs, straight steps)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from shoal.world.dynamics import PRESETS, Dynamics
from shoal.world.loader import scenario_from_dict
from shoal.world.plant import Kinematics, Plant
from shoal.world.scenario import Scenario

mujoco = pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")
from shoal.world.physics.engine import Engine  # noqa: E402


def settled_bound(speed: float, robot: Dynamics) -> float:
    """m: how far, once settled, a robot with mass may be from where the exact kinematics of
    the same commands put it (docs/physics.md, "Tracking"): the distance lost reaching the
    speed at its acceleration limit, |u|²/2a (its loop does not integrate while saturated, so
    that is never made up) — twice that for a wheeled robot, whose wheels' torque also turns it
    to the new heading —, what its latency holds it back, |u|·L, and 1 mm for the rest of the
    transient."""
    turns = 2.0 if robot.drive == "differential" else 1.0
    return turns * speed**2 / (2 * robot.braking) + speed * robot.latency + 1e-3


def pair(unicycles: bool) -> Scenario:
    """Two robots 2 m apart, no obstacles: a leader and one follower."""
    data: dict[str, Any] = {
        "name": "pair", "dt": 0.01, "duration": 5.0, "agent_radius": 0.1,
        "control": {"alpha": 1.0, "beta": 0.5, "sensing_radius": 1.0, "trigger_radius": 0.8,
                    "epsilon": 0.05, "safety_margin": 0.2},
        "graph": {"edges": [[1, 2]]},
        "agents": [{"offset": [0, 0]}, {"offset": [0, -2]}],
        "leader": {"waypoints": [[0, 0], [4, 0]], "speed": 0.1},
    }  # fmt: skip
    if unicycles:
        data["kinematics"] = {"model": "unicycle", "lookahead": 0.05, "max_speed": 0.5,
                              "max_turn_rate": 10.0}  # fmt: skip
    return scenario_from_dict(data)


def engine(scn: Scenario, **changes: float) -> Engine:
    robots = tuple(dataclasses.replace(r, **changes) for r in scn.robot_dynamics())
    return Engine(scn, robots)


def kinematics(scn: Scenario) -> Kinematics:
    return Kinematics(scn.initial_positions, scn.initial_headings, scn.lookaheads, scn.dt)


def drive(plant: Plant, u: np.ndarray, ticks: int) -> list[np.ndarray]:
    """Send ``u`` (n, dim) for ``ticks`` ticks; the points observed after each."""
    out = []
    for _ in range(ticks):
        seen = plant.observe()
        plant.send(u, seen.headings)
        out.append(plant.observe().positions.copy())
    return out


@pytest.mark.parametrize("unicycles", [False, True], ids=["holonomic", "wheeled"])
@pytest.mark.parametrize("kind", ["kinematics", "mujoco"])
def test_a_velocity_held_is_tracked_within_the_stated_bound(kind: str, unicycles: bool) -> None:
    scn = pair(unicycles)
    u = np.array([[0.12, 0.05], [0.08, -0.06]])
    plant = kinematics(scn) if kind == "kinematics" else engine(scn)
    exact = drive(kinematics(scn), u, 150)
    got = drive(plant, u, 150)
    for i, robot in enumerate(scn.robot_dynamics()):
        speed = float(np.linalg.norm(u[i]))
        bound = 1e-12 if kind == "kinematics" else settled_bound(speed, robot)
        assert np.linalg.norm(got[-1][i] - exact[-1][i]) <= bound
    # and settled: the last half second at the commanded velocity
    achieved = (got[-1] - got[-51]) / (50 * scn.dt)
    assert np.abs(achieved - u).max() <= (1e-9 if kind == "kinematics" else 2e-3)


def test_a_base_accelerates_at_its_force_limit_and_never_faster() -> None:
    scn = pair(False)
    base = PRESETS["holonomic-heavy"]
    plant = engine(scn, mass=base.mass, max_acceleration=base.max_acceleration or 0.0)
    u = np.array([[3.0, 4.0], [0.0, 0.0]])  # 5 m/s: far beyond what 1 m/s² reaches in 0.5 s
    start = plant.observe().positions.copy()
    points = [start, *drive(plant, u, 50)]
    speed = np.linalg.norm(np.diff(np.array(points)[:, 0], axis=0), axis=1) / scn.dt
    accel = np.diff(speed) / scn.dt
    assert accel.max() <= 1.0 * (1 + 1e-6)  # the norm of the force, not each axis, is limited
    assert accel[5:].min() >= 0.99  # saturated: it uses all of it
    assert np.isclose(speed[-1], 0.5 - 0.5 * scn.dt, atol=0.02)


def test_a_wheel_motor_saturates_at_its_torque_limit() -> None:
    scn = pair(True)
    limit = PRESETS["gritsbot"].max_torque
    plant = engine(scn)
    torques = []
    u = np.array([[0.3, 0.0], [0.0, 0.0]])
    for _ in range(20):
        seen = plant.observe()
        plant.send(u, seen.headings)
        torques.append(np.abs(plant.data.ctrl).max())
    assert max(torques) <= limit and torques[0] == limit


@pytest.mark.parametrize("unicycles", [False, True], ids=["holonomic", "wheeled"])
def test_latency_delays_the_first_motion(unicycles: bool) -> None:
    scn = pair(unicycles)
    u = np.array([[0.2, 0.0], [0.2, 0.0]])
    prompt = drive(engine(scn), u, 1)
    late = engine(scn, latency=0.03)
    start = late.observe().positions.copy()
    points = drive(late, u, 5)
    assert np.abs(prompt[0] - start).max() > 1e-5  # no latency: it moves in the first tick
    assert np.abs(points[2] - start).max() < 1e-9  # 30 ms: three ticks without moving at all
    assert np.abs(points[4] - start).max() > 1e-5


@pytest.mark.parametrize("unicycles", [False, True], ids=["holonomic", "wheeled"])
def test_a_robot_whose_commands_stop_comes_to_rest_after_its_timeout(unicycles: bool) -> None:
    scn = pair(unicycles)
    plant = engine(scn, command_timeout=0.3)
    u = np.array([[0.2, 0.0], [0.2, 0.0]])
    drive(plant, u, 50)
    before = plant.observe().positions.copy()
    plant.idle(20)  # 0.2 s: within the timeout, it holds the last command
    held = plant.observe().positions.copy()
    assert np.abs(held - before - 0.2 * u).max() < 5e-3
    plant.idle(60)  # past the timeout, and time to brake
    rest = plant.observe().positions.copy()
    plant.idle(20)
    assert np.abs(plant.observe().positions - rest).max() < 1e-4


def test_a_plant_owns_its_time() -> None:
    """Both simulated plants serve a lockstep run (the world refuses only robots on the wall
    clock there)."""
    scn = pair(False)
    assert kinematics(scn).simulated and engine(scn).simulated


def test_every_preset_is_a_complete_robot() -> None:
    for name, robot in PRESETS.items():
        assert robot.preset == name
        wheels = (robot.wheel_radius, robot.axle, robot.max_wheel_speed, robot.max_torque)
        if robot.drive == "differential":
            assert all(x is not None and x > 0 for x in wheels) and robot.max_acceleration is None
        else:
            assert all(x is None for x in wheels) and (robot.max_acceleration or 0) > 0
        assert isinstance(robot, Dynamics) and robot.mass > 0 and robot.loop_time > 0
