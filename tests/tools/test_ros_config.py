"""Where a run's ROS 2 robots are (tools/ros2/config.py): the command line's options,
else the scenario's ``robots:`` section, else the defaults; the world, its guard and ``shoal
robots`` resolve them the same way (the end to end: tests/tools/test_fleet.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from shoal.tools.procs.children import GuardSpec
from shoal.tools.procs.launch import RunPlan, _ros_options, _world
from shoal.tools.ros2.config import ros_config
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.scenario import RobotSetup


def test_without_a_section_or_options_the_robots_are_rmw_zenohs_defaults() -> None:
    conf = ros_config(load_scenario("default"))
    assert conf.namespaces == tuple(f"/robot{i}" for i in range(1, 6))
    assert (conf.connect, conf.domain, conf.distro) == (("tcp/127.0.0.1:7447",), 0, "jazzy")
    assert (conf.pose, conf.pose_timeout) == ("odom", 0.5)


def test_the_scenarios_section_names_them_and_the_command_line_wins() -> None:
    base = load_scenario("default")
    text = base.source + (
        "robots:\n  namespaces: [tb3_a, /lab/tb3_b, tb3_c, tb3_d, tb3_e]\n  domain: 0\n"
        "  connect: tcp/10.0.0.2:7447\n  distro: humble\n  pose: pose\n  pose_timeout: 0.2\n"
    )
    scn = parse_scenario(text)
    assert scn.robots == RobotSetup(
        namespaces=("/tb3_a", "/lab/tb3_b", "/tb3_c", "/tb3_d", "/tb3_e"),
        domain=0, connect=("tcp/10.0.0.2:7447",), distro="humble", pose="pose",
        pose_timeout=0.2,
    )  # fmt: skip
    conf = ros_config(scn)
    assert conf.namespaces == scn.robots.namespaces and conf.connect == ("tcp/10.0.0.2:7447",)
    assert (conf.domain, conf.distro, conf.pose, conf.pose_timeout) == (0, "humble", "pose", 0.2)
    given = ros_config(scn, connect=("tcp/127.0.0.1:9000",), domain=7, distro="kilted",
                       prefix="bot", pose="odom", pose_timeout=1.0)  # fmt: skip
    assert given.namespaces == tuple(f"/bot{i}" for i in range(1, 6))
    assert (given.connect, given.domain, given.distro) == (("tcp/127.0.0.1:9000",), 7, "kilted")
    assert (given.pose, given.pose_timeout) == ("odom", 1.0)
    partial = dataclasses.replace(scn, robots=RobotSetup(domain=3))
    conf = ros_config(partial, distro="rolling")
    assert conf.namespaces[0] == "/robot1" and (conf.domain, conf.distro) == (3, "rolling")


def test_a_resolved_configuration_handed_on_is_taken_as_it_is(tmp_path: Path) -> None:
    """`shoal run` resolves the robots once; the world and its guard get every value under
    the option names they read, and the world's own resolution then looks nothing up."""
    scn = load_scenario("default")
    ros = ros_config(scn, domain=4, distro="humble", prefix="tb", pose="pose")
    plan = RunPlan(scenario=scn, out=tmp_path / "x.mcap", run_id="r", ros=ros)
    world = _world(plan, tmp_path, {"run_id": "r"})
    assert world.robots == "ros2" and world.ros_prefix is None
    handed = ros_config(
        dataclasses.replace(scn, robots=RobotSetup(domain=9, distro="kilted")),
        connect=world.ros_connect, domain=world.ros_domain, distro=world.ros_distro,
        prefix=world.ros_prefix, namespaces=world.ros_namespaces, pose=world.ros_pose,
        pose_timeout=world.pose_timeout,
    )  # fmt: skip
    assert handed == ros
    guard = GuardSpec(**_ros_options(ros, GuardSpec), run_id="r")
    assert guard.ros_namespaces == ros.namespaces == tuple(f"/tb{i}" for i in range(1, 6))
    assert (guard.ros_connect, guard.ros_domain, guard.ros_distro) == (ros.connect, 4, "humble")
