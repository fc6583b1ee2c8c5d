"""``shoal robots``: simulated ROS 2 robots on rmw_zenoh's protocol (docs/ros2.md)."""

from __future__ import annotations

import threading
from typing import Any

import click

from shoal.bus.runtime import announce_ready, exit_on_signals
from shoal.tools.commands.options import check_plant, load_for_cli
from shoal.tools.extras import require
from shoal.tools.procs.children import RobotsSpec, click_options
from shoal.tools.procs.session import open_session, session_config
from shoal.tools.ros2.config import ros_config
from shoal.tools.ros2.fleet import Fleet, drivers_for
from shoal.tools.ros2.node import RosSession
from shoal.tools.ros2.rmw import RmwError
from shoal.world.plant import KINEMATICS


@click.command()
@click_options(RobotsSpec)
def robots(**params: Any) -> None:
    """Start simulated ROS 2 robots for SCENARIO's agents until SIGINT/SIGTERM.

    Robot i (namespace /robot<i>, or as the scenario's robots: section names it) starts where
    agent i does, takes geometry_msgs/msg/Twist on
    /robot<i>/cmd_vel (a unicycle: linear x and angular z, clamped to the scenario's limits; a
    holonomic robot: linear x and y) and publishes nav_msgs/msg/Odometry on /robot<i>/odom,
    over rmw_zenoh's keys, liveliness tokens and attachments: a ROS 2 node on rmw_zenoh sees
    them as robots. Each stops after --cmd-timeout s without a command."""
    exit_on_signals()
    require("ros2", "shoal robots")
    spec = RobotsSpec.of(params)
    if spec.jitter_ms > spec.latency_ms:
        raise click.BadParameter(
            f"{spec.jitter_ms:g} ms is more than --latency-ms {spec.latency_ms:g}",
            param_hint="--jitter-ms",
        )
    scn = load_for_cli(spec.scenario)
    check_plant(scn, spec.plant, spec.dynamics)
    try:
        drivers = drivers_for(scn, spec.count, spec.cmd_timeout)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="SCENARIO / --count") from None
    bodies = None
    if spec.plant != KINEMATICS:  # robots with mass: one engine moves them all
        from shoal.tools.ros2.physics import EngineBodies

        bodies = EngineBodies(scn, spec.dynamics, spec.cmd_timeout)
        drivers = [bodies.driver(i) for i in range(len(drivers))]  # type: ignore[misc]
    ros_conf = ros_config(
        scn, connect=spec.connect, domain=spec.domain, distro=spec.distro, prefix=spec.prefix
    )
    if spec.listen:
        conf = session_config("router", listen=spec.listen, connect=spec.connect)
    else:
        conf = session_config("client", connect=ros_conf.connect, connect_ms=5_000)
    names = list(ros_conf.namespaces[: len(drivers)])
    with open_session(conf, "robots") as session:
        try:
            ros = RosSession(session, ros_conf.domain, ros_conf.distro)
            fleet = Fleet(ros, names, drivers, rate=spec.rate, latency=spec.latency_ms / 1e3,
                          jitter=spec.jitter_ms / 1e3, seed=spec.seed)  # fmt: skip
        except RmwError as exc:
            raise click.BadParameter(str(exc), param_hint="--prefix") from None
        kinds = "unicycles" if not drivers[0].holonomic else "holonomic robots"
        announce_ready(
            f"robots {len(drivers)} {kinds} {names[0]}…{names[-1]} domain {ros_conf.domain}"
        )
        try:
            fleet.run(threading.Event())  # until a signal turns into SystemExit
        finally:
            fleet.close()
            click.echo(
                f"robots: {fleet.heard} commands heard, {fleet.dropped} malformed dropped, "
                f"{fleet.published} odometry messages published",
                err=True,
            )
            if bodies is not None:
                click.echo(f"robots: {_judged(bodies)}", err=True)


def _judged(bodies: Any) -> str:
    """What the engine saw of the robots with mass, the line ``shoal robots`` ends with."""
    got = bodies.engine.report()
    guard, apart = got.get("guard_margin"), got.get("separation_margin")
    return (
        f"mujoco ({got['dynamics']}), {got['physics_steps']} physics steps, "
        f"{bodies.lagged_s:.3f} s lost to a slow machine; engine contacts "
        f"{got['engine_contacts']} (deepest {abs(got['engine_deepest_contact']):.4f} m); "
        f"margins guard {'—' if guard is None else f'{guard:+.4f} m'}, separation "
        f"{'—' if apart is None else f'{apart:+.4f} m'}"
    )
