"""``shoal guard``: the robots' last line when the world itself dies (docs/ros2.md).

The world stops every robot however its run ends, but a SIGKILLed or crashed world sends
nothing. This small process, started beside it by ``shoal run --robots ros2``, watches the
world's liveliness token on the run's router; once it has been up and vanishes (the process
gone, or its router), the guard sends a zero Twist to every robot and exits. It does the same
when it is itself asked to stop.
"""

from __future__ import annotations

import time
from typing import Any

import click

from shoal.bus.acl import MONITOR
from shoal.bus.keys import Keys
from shoal.bus.links import still_present, watch_presence
from shoal.bus.runtime import ArrivalKind, Inbox, announce_ready, exit_on_signals, warn
from shoal.tools.extras import require
from shoal.tools.procs.children import GuardSpec, click_options
from shoal.tools.procs.session import (
    PROMPT_CONNECT_MS,
    client_session,
    open_session,
    session_config,
)
from shoal.tools.ros2 import rmw
from shoal.tools.ros2.bridge import zero
from shoal.tools.ros2.node import RMW_ZENOHD, RosSession


@click.command()
@click_options(GuardSpec)
def guard(**params: Any) -> None:
    """Send run RUN's ROS 2 robots a zero Twist when its world goes away, then exit."""
    exit_on_signals()
    require("ros2", "shoal guard")
    spec = GuardSpec.of(params)
    keys = Keys(spec.run_id)
    endpoints = spec.ros_connect or (RMW_ZENOHD,)
    ros_conf = session_config("client", connect=endpoints, connect_ms=PROMPT_CONNECT_MS)
    with (
        client_session(spec, MONITOR, "guard") as session,
        open_session(ros_conf, f"the ROS 2 router at {' '.join(endpoints)}") as ros_session,
    ):
        ros = RosSession(ros_session, spec.ros_domain, spec.ros_distro)
        node = ros.node("shoal_guard")
        names = list(spec.ros_namespaces)
        stops = [node.publisher(f"{ns}/cmd_vel", rmw.TWIST) for ns in names]
        inbox = Inbox()
        held = watch_presence(session, keys.alive_world, inbox)
        announce_ready(f"guard {names[0]}…{names[-1]}")
        gone = False
        try:
            seen = False
            while True:
                arrival = inbox.wait()
                if arrival.kind == ArrivalKind.UP:
                    seen = True
                elif seen and not still_present(session, keys.alive_world):
                    gone = True
                    break  # down, and a second look agrees
        finally:
            halt = zero()
            for stop in stops:
                stop.put(halt)
            warn(f"guard: the world of run {spec.run_id} is gone; {len(stops)} robots stopped")
            if gone:  # a world cut from its router may still send a tick or two: outlast it
                _hold(stops, halt)
            held.undeclare()
            node.close()


# s: after the world's token vanishes, the guard keeps sending zero Twists this long. A world
# that lost its router (not its process) holds its robots once its agents' commands are
# STALE_AFTER ticks old, and may send the commands it had until then: 5 ticks, 50 ms at 100 Hz.
# This outlasts that for ticks up to 0.2 s, so the guard's zero is the last command a robot gets.
HOLD = 1.0
HOLD_PERIOD = 0.02  # s between the held zeros


def _hold(stops: list[Any], halt: bytes) -> None:
    """Send ``halt`` on every publisher of ``stops`` every :data:`HOLD_PERIOD` s for
    :data:`HOLD` s."""
    end = time.monotonic() + HOLD
    while time.monotonic() < end:
        time.sleep(HOLD_PERIOD)  # a pace, not a wait for anything
        for stop in stops:
            stop.put(halt)
