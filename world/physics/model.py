"""The MJCF model of a scenario's world for MuJoCo: each agent's robot (world/dynamics.py), the
standing obstacles as static geoms, the people and other moving obstacles as kinematic (mocap)
bodies the program walks. A pure function of the scenario and the robots, so two runs build the
same model byte for byte.

Collision groups (``contype`` / ``conaffinity``): the floor touches only wheels and casters, and
the judged geoms — robots' bodies, obstacles, people — touch each other; a contact the engine
reports between two judged geoms is a collision (world/physics/engine.py).

A 2-D robot's body and an obstacle are upright cylinders; in 3-D, spheres. A holonomic base
slides in x and y (and z in 3-D) and turns freely about z; a differential drive is a free body on
its two wheels and two frictionless casters, on a floor, under gravity. Names: ``robot{i}``
(agent i), its body geom ``body{i}``, obstacle k (scenario order) ``obstacle{k}``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from shoal.world.dynamics import Drive, Dynamics
from shoal.world.scenario import Scenario

FLOOR_GAP = 0.002  # m between a wheeled chassis and the floor
WHEEL_SHARE = 0.05  # of a differential drive's mass in each wheel
WHEEL_FRICTION = 1.5  # sliding friction of a wheel on the floor (rubber on a hard floor)


@dataclass(frozen=True)
class Layout:
    """What the plant needs to drive the model: the physics step ``timestep`` s, and
    ``substeps`` of it per tick of the formation."""

    xml: str
    timestep: float
    substeps: int
    motors: tuple[
        tuple[int, str], ...
    ]  # each actuator's agent (0-based) and joint: x y z left right


def layout(scenario: Scenario, robots: tuple[Dynamics, ...]) -> Layout:
    """The model of ``scenario`` with agent i's robot ``robots[i - 1]``."""
    s = scenario
    finest = min(r.timestep for r in robots)
    substeps = max(1, math.ceil(s.dt / finest - 1e-9))
    timestep = s.dt / substeps
    tall = 2.0 * max(r.height for r in robots) + 0.5  # obstacles stand above every robot
    gravity = "0 0 -9.81" if s.dim == 2 else "0 0 0"
    parts = [
        '<mujoco model="shoal">',
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{timestep!r}" integrator="implicitfast" gravity="{gravity}"/>',
        "  <worldbody>",
    ]
    if any(r.drive == Drive.DIFFERENTIAL for r in robots):
        parts.append(
            '    <geom name="floor" type="plane" size="0 0 1" contype="1" conaffinity="0"/>'
        )
    centres = s.initial_positions
    headings = s.initial_headings
    lookaheads = s.lookaheads
    for i, robot in enumerate(robots):
        ell = 0.0 if lookaheads is None else float(lookaheads[i])
        point = [float(x) for x in centres[i]]
        theta = float(headings[i])
        if robot.drive == Drive.DIFFERENTIAL:
            parts += _wheeled(i + 1, robot, s.agent_radius, point, theta, ell)
        else:
            parts += _based(i + 1, robot, s.agent_radius, s.dim)
    movers = set(s.mover_ids)
    for k, o in enumerate(s.obstacles):
        parts += _obstacle(k, o.radius, [float(x) for x in o.centre], tall, s.dim, k in movers)
    parts += ["  </worldbody>", "  <actuator>"]
    motors = tuple(
        (i, joint) for i, robot in enumerate(robots) for joint in _actuated(robot, s.dim)
    )
    for i, joint in motors:
        parts.append(f'    <motor joint="{joint}{i + 1}" ctrllimited="false"/>')
    parts += ["  </actuator>", "  <sensor>"]
    # Each robot's body touching anything (only judged geoms can touch it): a fixed-size
    # reading per physics step, so the judge parses the contact list only when there is one.
    for i in range(1, len(robots) + 1):
        parts.append(f'    <contact geom1="body{i}" num="1" data="found" reduce="mindist"/>')
    parts += ["  </sensor>", "</mujoco>"]
    return Layout("\n".join(parts) + "\n", timestep, substeps, motors)


def _actuated(robot: Dynamics, dim: int) -> tuple[str, ...]:
    """The joints a robot's motors drive, in the plant's order."""
    return ("left", "right") if robot.drive == Drive.DIFFERENTIAL else tuple("xyz"[:dim])


def _based(i: int, robot: Dynamics, radius: float, dim: int) -> list[str]:
    """A holonomic base; its slides' positions are its point (set by the plant at the start)."""
    shape = (
        f'type="cylinder" size="{radius!r} {robot.height / 2!r}"'
        if dim == 2
        else f'type="sphere" size="{radius!r}"'
    )
    z = robot.height / 2 if dim == 2 else 0.0
    out = [f'    <body name="robot{i}" pos="0 0 {z!r}">']
    for axis, direction in zip("xyz"[:dim], ("1 0 0", "0 1 0", "0 0 1"), strict=False):
        out.append(f'      <joint name="{axis}{i}" type="slide" axis="{direction}"/>')
    if dim == 2:
        damping = 0.01 * robot.mass
        out.append(f'      <joint name="yaw{i}" type="hinge" axis="0 0 1" damping="{damping!r}"/>')
    out += [
        f'      <geom name="body{i}" {shape} mass="{robot.mass!r}" contype="2" conaffinity="2"/>',
        "    </body>",
    ]
    return out


def _wheeled(
    i: int, robot: Dynamics, radius: float, point: list[float], theta: float, ell: float
) -> list[str]:
    """A differential drive whose body centre (the axle's midpoint) is l behind ``point``."""
    assert robot.wheel_radius is not None and robot.axle is not None
    rw, half = robot.wheel_radius, robot.axle / 2
    cx, cy = point[0] - ell * math.cos(theta), point[1] - ell * math.sin(theta)
    wheel = WHEEL_SHARE * robot.mass
    chassis = robot.mass - 2 * wheel
    lift = robot.height / 2 + FLOOR_GAP - rw  # the chassis' centre above the axle
    caster = rw / 2
    reach = 0.6 * radius
    quat = f"{math.cos(theta / 2)!r} 0 0 {math.sin(theta / 2)!r}"
    out = [
        f'    <body name="robot{i}" pos="{cx!r} {cy!r} {rw!r}" quat="{quat}">',
        f'      <freejoint name="free{i}"/>',
        f'      <geom name="body{i}" type="cylinder" size="{radius!r} {robot.height / 2!r}" '
        f'pos="0 0 {lift!r}" mass="{chassis!r}" contype="2" conaffinity="2"/>',
    ]
    for side, x in (("front", reach), ("back", -reach)):
        out.append(
            f'      <geom name="caster{i}{side}" type="sphere" size="{caster!r}" '
            f'pos="{x!r} 0 {caster - rw!r}" condim="1" priority="1" mass="{1e-3 * robot.mass!r}" '
            'contype="0" conaffinity="1"/>'
        )
    for side, y in (("left", half), ("right", -half)):
        out += [
            f'      <body name="{side}{i}" pos="0 {y!r} 0" zaxis="0 1 0">',
            f'        <joint name="{side}{i}" type="hinge" axis="0 0 1"/>',
            f'        <geom type="cylinder" size="{rw!r} {0.2 * rw!r}" mass="{wheel!r}" '
            f'friction="{WHEEL_FRICTION!r}" contype="0" conaffinity="1"/>',
            "      </body>",
        ]
    return [*out, "    </body>"]


def _obstacle(
    k: int, radius: float, centre: list[float], tall: float, dim: int, moving: bool
) -> list[str]:
    shape = (
        f'type="cylinder" size="{radius!r} {tall / 2!r}"'
        if dim == 2
        else f'type="sphere" size="{radius!r}"'
    )
    where = [*centre, tall / 2] if dim == 2 else centre
    pos = " ".join(repr(x) for x in where)
    geom = f'name="obstacle{k}" {shape} contype="2" conaffinity="2"'
    if not moving:
        return [f'    <geom {geom} pos="{pos}"/>']
    return [
        f'    <body name="person{k}" mocap="true" pos="{pos}">',
        f"      <geom {geom}/>",
        "    </body>",
    ]
