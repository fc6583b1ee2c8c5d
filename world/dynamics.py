"""Robots with mass: what a physics plant (world/physics/) needs to know about each robot, as
named presets that a scenario's ``dynamics:`` section picks and overrides field by field.

Pure data and its checks; no physics engine is imported here, so a scenario with a ``dynamics:``
section loads (and is checked) without the ``physics`` extra installed.

Two drives. A **differential** drive is a chassis disc of the agent's body radius on two hinge
wheels (``wheel_radius`` m, ``axle`` m apart), each with a torque-limited motor (``max_torque``
N·m) whose speed a PI loop holds at the set-point (at most ``max_wheel_speed`` rad/s); it drives
a scenario's unicycles. A **holonomic** base slides in the plane (or in space, for a 3-D
scenario) under a force-limited actuator (``mass`` × ``max_acceleration``) whose PI loop tracks
the commanded velocity; it drives the single integrators. Both: the velocity loop's time
constant ``loop_time`` s, an actuation ``latency`` s between a command and the motors acting on
it, and the robot's own ``command_timeout`` s after which, with no new command, it stops.
Sources of every preset's figures: docs/physics.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from shoal.world.errors import ScenarioError


class Drive(StrEnum):
    DIFFERENTIAL = "differential"
    HOLONOMIC = "holonomic"


@dataclass(frozen=True, slots=True, kw_only=True)
class Dynamics:
    """One robot's body and drive (module docstring); SI units."""

    preset: str
    drive: Drive
    mass: float  # kg, the whole robot
    height: float  # m, the chassis' height (a 2-D robot's body is a cylinder)
    loop_time: float  # s, the velocity loop's time constant
    latency: float = 0.0  # s from a command to the motors acting on it
    command_timeout: float = 0.5  # s without a command before the robot stops by itself
    timestep: float = 0.001  # s, the physics step (the velocity loop runs at its rate)
    max_acceleration: float | None = None  # holonomic: m/s², the force limit over the mass
    wheel_radius: float | None = None  # differential: m
    axle: float | None = None  # differential: m between the wheels
    max_wheel_speed: float | None = None  # differential: rad/s
    max_torque: float | None = None  # differential: N·m per wheel motor

    @property
    def max_force(self) -> float:
        """N: a holonomic base's actuator limit."""
        assert self.max_acceleration is not None
        return self.mass * self.max_acceleration

    @property
    def braking(self) -> float:
        """m/s²: the most its motors can accelerate (or brake) it straight ahead — a base's
        ``max_acceleration``; a wheeled robot's two wheel torques at their rims over its mass,
        2·τ_max/(r·m) (less while it also turns)."""
        if self.drive == Drive.HOLONOMIC:
            assert self.max_acceleration is not None
            return self.max_acceleration
        assert self.max_torque is not None and self.wheel_radius is not None
        return 2.0 * self.max_torque / (self.wheel_radius * self.mass)


_DIFFERENTIAL_ONLY = ("wheel_radius", "axle", "max_wheel_speed", "max_torque")
_HOLONOMIC_ONLY = ("max_acceleration",)
_MAY_BE_ZERO = ("latency",)

PRESETS: dict[str, Dynamics] = {
    # The Robotarium's GRITSbot: wheels, axle and wheel speed from robotarium_python_simulator;
    # mass and torque assumed (docs/physics.md says which and why).
    "gritsbot": Dynamics(
        preset="gritsbot", drive=Drive.DIFFERENTIAL, mass=0.25, height=0.04, loop_time=0.02,
        wheel_radius=0.016, axle=0.11, max_wheel_speed=12.5, max_torque=0.01,
    ),
    # TurtleBot3 Burger (ROBOTIS e-Manual): 1 kg, wheels 0.033 m on a 0.160 m axle, 0.22 m/s,
    # Dynamixel XL430-W250 motors (1.4 N·m stall torque at 11.1 V).
    "turtlebot3": Dynamics(
        preset="turtlebot3", drive=Drive.DIFFERENTIAL, mass=1.0, height=0.192, loop_time=0.05,
        wheel_radius=0.033, axle=0.160, max_wheel_speed=0.22 / 0.033, max_torque=1.4,
    ),
    "holonomic": Dynamics(
        preset="holonomic", drive=Drive.HOLONOMIC, mass=2.0, height=0.1, loop_time=0.02,
        max_acceleration=4.0,
    ),
    # A 10 kg base whose acceleration is limited to 1 m/s².
    "holonomic-heavy": Dynamics(
        preset="holonomic-heavy", drive=Drive.HOLONOMIC, mass=10.0, height=0.3, loop_time=0.05,
        max_acceleration=1.0,
    ),
}  # fmt: skip

MIN_TIMESTEP = 1e-5  # s: a finer physics step costs a hundred steps per millisecond simulated
FIELDS = tuple(f.name for f in dataclasses.fields(Dynamics) if f.name not in ("preset", "drive"))


def preset(name: str, where: str = "dynamics.preset") -> Dynamics:
    """The preset called ``name``; :class:`ScenarioError` at ``where`` naming the choices."""
    found = PRESETS.get(name) if isinstance(name, str) else None
    if found is None:
        raise ScenarioError(where, f"must be one of {', '.join(PRESETS)}, got {name!r}")
    return found


@dataclass(frozen=True, slots=True)
class DynamicsSetup:
    """A scenario's ``dynamics:`` section, checked: the ``preset`` it names (None: the file
    names none, which only ``--dynamics`` may leave out) and the fields it overrides."""

    preset: str | None = None
    overrides: tuple[tuple[str, float], ...] = ()

    def resolve(self, override: str | None = None) -> Dynamics | None:
        """The robot: ``override`` (``--dynamics`` on the command line) replaces the file's
        preset and keeps its overrides. None when neither names a preset."""
        name = override if override is not None else self.preset
        if name is None:
            if self.overrides:
                raise ScenarioError("dynamics.preset", f"is required: one of {', '.join(PRESETS)}")
            return None
        base = preset(name, "--dynamics" if override is not None else "dynamics.preset")
        others = _HOLONOMIC_ONLY if base.drive == Drive.DIFFERENTIAL else _DIFFERENTIAL_ONLY
        for key, _ in self.overrides:
            if key in others:
                raise ScenarioError(
                    f"dynamics.{key}", f"is not a figure of a {base.drive} drive ({base.preset})"
                )
        changed: dict[str, Any] = dict(self.overrides)
        robot = dataclasses.replace(base, **changed)
        if robot.loop_time < 2 * robot.timestep:
            where = "dynamics.loop_time" if "loop_time" in changed else "dynamics.timestep"
            raise ScenarioError(
                where,
                f"the velocity loop's time constant {robot.loop_time:g} s must be at least two "
                f"physics steps ({robot.timestep:g} s each), or its discrete loop oscillates",
            )
        if robot.timestep < MIN_TIMESTEP:
            raise ScenarioError(
                "dynamics.timestep", f"{robot.timestep:g} s is below {MIN_TIMESTEP:g} s"
            )
        return robot


def setup(value: Any) -> DynamicsSetup | None:
    """A scenario's ``dynamics:`` section: ``preset`` (one of :data:`PRESETS`) and any of its
    fields (:data:`FIELDS`) to override, each checked; None when the file has none."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise ScenarioError("dynamics", f"must be a mapping, got {type(value).__name__}")
    unknown = sorted(str(k) for k in set(value) - {"preset", *FIELDS})
    if unknown:
        raise ScenarioError(
            f"dynamics.{unknown[0]}", f"unknown; one of preset, {', '.join(FIELDS)}"
        )
    name = value.get("preset")
    if name is not None:
        preset(name)
    changes = tuple((str(k), _number(v, str(k))) for k, v in value.items() if k != "preset")
    found = DynamicsSetup(name, changes)
    found.resolve()  # a field the preset's drive does not have is named now, at load
    return found


def _number(value: Any, key: str) -> float:
    where = f"dynamics.{key}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(where, f"must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or x < 0 or (x == 0 and key not in _MAY_BE_ZERO):
        kind = "non-negative" if key in _MAY_BE_ZERO else "positive"
        raise ScenarioError(where, f"must be a {kind} finite number, got {value!r}")
    return x


def of_agents(
    chosen: Dynamics | None, unicycles: tuple[bool, ...], dim: int, where: str = "dynamics.preset"
) -> tuple[Dynamics, ...]:
    """Each agent's robot: a unicycle is a differential drive (``chosen`` if it is one, else
    ``gritsbot``), a single integrator a holonomic base (``chosen`` if it is one, else
    ``holonomic``); :class:`ScenarioError` at ``where`` (the field or option that chose it)
    when ``chosen`` fits no agent of the formation."""
    wheeled = chosen if chosen is not None and chosen.drive == Drive.DIFFERENTIAL else None
    based = chosen if chosen is not None and chosen.drive == Drive.HOLONOMIC else None
    if chosen is not None and not any(
        (u and chosen.drive == Drive.DIFFERENTIAL) or (not u and chosen.drive == Drive.HOLONOMIC)
        for u in unicycles
    ):
        kind = "unicycles" if all(unicycles) else "single integrators"
        raise ScenarioError(
            where,
            f"{chosen.preset} is a {chosen.drive} drive, but every agent is one of the {kind}: "
            f"choose a {'differential' if all(unicycles) else 'holonomic'} preset",
        )
    if dim != 2 and (wheeled is not None or any(unicycles)):
        raise ScenarioError(where, "a differential drive rolls on a plane: dim must be 2")
    return tuple(
        (wheeled or PRESETS["gritsbot"]) if u else (based or PRESETS["holonomic"])
        for u in unicycles
    )
