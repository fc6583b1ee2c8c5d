"""Where a run's ROS 2 robots are (docs/ros2.md): the command line's ``--ros-*``
options, else the scenario's ``robots:`` section, else the defaults, resolved once, so that the
world and its guard drive and stop the same robots."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar

from shoal.tools.ros2.node import RMW_ZENOHD
from shoal.world.scenario import RobotSetup, Scenario

T = TypeVar("T")
DEFAULT_PREFIX = "robot"  # agent i's robot is /robot<i> when nothing names it


@dataclass(frozen=True)
class RosConfig:
    """The robots of a run: ``namespaces`` (agent i's is ``namespaces[i - 1]``, with a leading
    slash), the router's ``connect`` endpoints, ``domain``, ``distro``, the ``pose`` topic kind
    (odom or pose) and ``pose_timeout`` s."""

    namespaces: tuple[str, ...]
    connect: tuple[str, ...]
    domain: int
    distro: str
    pose: str
    pose_timeout: float


def ros_config(
    scn: Scenario,
    *,
    connect: tuple[str, ...] = (),
    domain: int | None = None,
    distro: str | None = None,
    prefix: str | None = None,
    namespaces: tuple[str, ...] = (),
    pose: str | None = None,
    pose_timeout: float | None = None,
) -> RosConfig:
    """The robots of ``scn``'s agents: each argument given (not None, not empty) wins over the
    scenario's ``robots:`` section, which wins over the defaults (/robot<i>, rmw_zenohd on
    this machine, domain 0, Jazzy, odometry, 0.5 s). ``prefix`` names agent i's robot
    /<prefix><i>, in place of the section's namespaces; ``namespaces`` names each (a
    configuration resolved already, handed on: every argument given, nothing is looked up)."""
    section = scn.robots or RobotSetup()
    if namespaces:
        names = namespaces
    elif prefix is None and section.namespaces is not None:
        names = section.namespaces
    else:
        names = tuple(f"/{prefix or DEFAULT_PREFIX}{i}" for i in range(1, scn.n + 1))
    return RosConfig(
        namespaces=names,
        connect=connect or section.connect or (RMW_ZENOHD,),
        domain=_first(domain, section.domain, 0),
        distro=_first(distro, section.distro, "jazzy"),
        pose=_first(pose, section.pose, "odom"),
        pose_timeout=_first(pose_timeout, section.pose_timeout, 0.5),
    )


def _first(*values: T | None) -> T:
    """The first of ``values`` that is not None."""
    for v in values:
        if v is not None:
            return v
    raise ValueError("no value")
