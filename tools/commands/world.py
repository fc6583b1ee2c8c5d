"""``shoal world``: the world process of a run."""

from __future__ import annotations

import contextlib
import dataclasses
import json
from collections.abc import Iterator
from typing import Any

import click

from shoal.bus.acl import WORLD
from shoal.bus.runtime import exit_on_signals
from shoal.bus.seam import ZenohBus
from shoal.bus.types import Clock
from shoal.tools.commands.options import check_layer, check_plant, load_for_cli
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.extras import require
from shoal.tools.procs.children import WorldSpec, click_options
from shoal.tools.procs.session import (
    PROMPT_CONNECT_MS,
    client_session,
    open_session,
    session_config,
)
from shoal.world.onboard import Link
from shoal.world.plant import KINEMATICS, Plant, PlantError, simulated
from shoal.world.process import World, WorldAbort, WorldOptions
from shoal.world.scenario import Scenario


def scenario_of(spec: WorldSpec) -> Scenario:
    """The scenario the world runs: its file (or built-in), under ``--name`` if given."""
    scn = load_for_cli(spec.scenario)
    return scn if spec.name is None else dataclasses.replace(scn, name=spec.name)


def link_of(spec: WorldSpec, scn: Scenario) -> Link:
    """The robots' radio of ``spec`` in ticks: its wall-clock delays over the wall-clock tick
    (dt / speed; lockstep ticks as fast as the agents answer, and the delays count at speed 1)."""
    if spec.jitter_ms > spec.delay_ms:
        raise click.BadParameter(
            f"{spec.jitter_ms:g} ms is more than --delay-ms {spec.delay_ms:g}",
            param_hint="--jitter-ms",
        )
    tick_ms = scn.dt / spec.speed * 1e3
    return Link(
        delay=spec.delay_ms / tick_ms,
        jitter=spec.jitter_ms / tick_ms,
        drop_rate=spec.drop_rate,
        seed=spec.drop_seed,
    )


@contextlib.contextmanager
def robots_of(spec: WorldSpec, scn: Scenario) -> Iterator[Plant | None]:
    """The robots the world drives: None, its own kinematics; with ``--robots ros2``, ROS 2
    robots over a session with their router (tools/ros2/bridge.py), closed afterwards."""
    if spec.robots != "ros2":
        yield None
        return
    if spec.clock != Clock.REALTIME or spec.speed != 1.0:
        raise click.BadParameter("robots move on the wall clock: needs --clock realtime at "
                                 "--speed 1", param_hint="--robots")  # fmt: skip
    if scn.dim != 2:
        raise click.BadParameter(f"ROS 2 ground robots drive in the plane; {scn.name} is "
                                 f"{scn.dim}-D", param_hint="--robots")  # fmt: skip
    require("ros2", "--robots ros2")
    from shoal.tools.ros2.bridge import Ros2Robots
    from shoal.tools.ros2.config import ros_config
    from shoal.tools.ros2.node import RosSession
    from shoal.tools.ros2.rmw import ODOMETRY, POSE_STAMPED, RmwError

    ros_conf = ros_config(  # as given: `shoal run` gives every option, resolved once
        scn, connect=spec.ros_connect, domain=spec.ros_domain, distro=spec.ros_distro,
        prefix=spec.ros_prefix, namespaces=spec.ros_namespaces, pose=spec.ros_pose,
        pose_timeout=spec.pose_timeout,
    )  # fmt: skip
    endpoints = ros_conf.connect
    conf = session_config("client", connect=endpoints, connect_ms=PROMPT_CONNECT_MS)
    with open_session(conf, f"the ROS 2 router at {' '.join(endpoints)}") as session:
        try:
            ros = RosSession(session, ros_conf.domain, ros_conf.distro)
            pose = ODOMETRY if ros_conf.pose == "odom" else POSE_STAMPED
            robots = Ros2Robots(ros, list(ros_conf.namespaces), scn.lookaheads, scn.dt,
                                pose_type=pose, pose_timeout=ros_conf.pose_timeout)  # fmt: skip
        except RmwError as exc:
            raise click.BadParameter(str(exc), param_hint="--ros-prefix") from None
        try:
            yield robots
        finally:
            robots.stop()
            robots.close()


@click.command()
@click_options(WorldSpec)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def world(as_json: bool, **params: Any) -> None:
    """Sense and move the agents of run RUN: simulated kinematics, or ROS 2 robots."""
    exit_on_signals()
    spec = WorldSpec.of(params)
    scn = scenario_of(spec)
    options = WorldOptions(
        run=spec.run_id,
        expect=spec.expect,
        clock=spec.clock,
        speed=spec.speed,
        layer=spec.safety_layer,
        link=link_of(spec, scn),
        layer_epoch=spec.layer_epoch,
        start_timeout=spec.start_timeout,
    )
    check_plant(scn, spec.plant, spec.dynamics, spec.robots)
    if spec.safety_layer is not None:
        check_layer(scn, spec.safety_layer, spec.dynamics)
    with contextlib.ExitStack() as stack:
        plant = stack.enter_context(robots_of(spec, scn))
        if spec.plant != KINEMATICS:
            plant = simulated(scn, spec.plant, spec.dynamics)
        options = dataclasses.replace(
            options, plant=plant, plant_name=spec.plant, dynamics=spec.dynamics
        )
        session = stack.enter_context(client_session(spec, WORLD, "world"))
        try:
            with World(scn, options, ZenohBus(session)) as w:
                w.wait_for_everyone()
                summary = json_safe(w.run())
        except (WorldAbort, PlantError) as exc:
            raise click.ClickException(str(exc)) from None
    click.echo(json.dumps(summary) if as_json else render_summary(summary))
    if summary.get("aborted"):
        raise click.ClickException(f"the run ended early: {summary['aborted']}")
