"""Launching a whole run as separate OS processes and following it to its end.

Used by ``shoal run`` and by the benchmark. The order is what makes the start race-free: the
router (unless one is given), then the logger, the world and every agent at once; the world waits
for every agent's, the logger's and this monitor's liveliness tokens before its first tick.
"""

from __future__ import annotations

import os
import socket
import sys
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from shoal.bus import codec
from shoal.bus.acl import MONITOR
from shoal.bus.errors import DecodeError
from shoal.bus.keys import Keys
from shoal.bus.links import subscribe, watch_presence
from shoal.bus.report import reports_in
from shoal.bus.runtime import Arrival, ArrivalKind, Inbox, warn
from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.certs import make_material
from shoal.tools.log.replay import TickSink
from shoal.tools.procs.children import (
    AgentSpec,
    ChildSpec,
    GuardSpec,
    LoggerSpec,
    RouterSpec,
    WorldSpec,
)
from shoal.tools.procs.cpu import CpuWindow, swarm_processes
from shoal.tools.procs.session import PROMPT_CONNECT_MS, client_config, open_session
from shoal.tools.procs.swarm import ChildFailed, Swarm
from shoal.tools.progress import progress_bar
from shoal.tools.ros2.config import RosConfig
from shoal.world.scenario import Scenario


def _hand_over(scenario: Scenario, folder: Path) -> Path:
    """The scenario's text, as it was parsed, in a file for the world (which is also given the
    scenario's name: a scenario without ``name:`` is named after the file it came from)."""
    path = folder / "scenario.yaml"
    path.write_text(scenario.source, encoding="utf-8")
    return path


def fresh_run_id() -> str:
    """A run id nobody has used: 8 random hex digits."""
    return uuid.uuid4().hex[:8]


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nobody listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass(frozen=True)
class RunPlan:
    """What to run and how, every fact resolved once, by the caller: ``scenario`` parsed (the
    world is handed its text, written into the run's folder, never the file it came from,
    which may change) and ``ros``, the ROS 2 robots the world drives and its guard stops. The
    fields keep the names of the options they come from and go to (tools/procs/children.py)."""

    scenario: Scenario
    out: Path
    run_id: str
    clock: Clock = Clock.LOCKSTEP
    speed: float = 1.0
    safety_layer: SafetyLayer | None = None  # None: onboard in realtime, referee in lockstep
    layer_epoch: float = 0.1  # onboard: s between the robots' snapshots
    connect: str | None = None  # a router's endpoint; None starts one
    start_timeout: float = 60.0
    progress: bool = False
    drop_rate: float = 0.0  # fault injection, for the agents and the world (FaultSpec)
    drop_seed: int = 0
    delay_ms: float = 0.0
    jitter_ms: float = 0.0
    secure: bool = False  # TLS, passwords and the router's ACL (docs/security.md)
    secure_dir: Path | None = None  # their material; None makes a fresh one in the run folder
    measure_cpu: bool = (
        False  # account each process's CPU per tick (tools/procs/cpu.py; the benchmark)
    )
    force: bool = False  # the logger may replace an existing ``out``
    ros: RosConfig | None = None  # ROS 2 robots (tools/ros2/config.py); None: simulated ones
    plant: str = "kinematics"  # what moves simulated robots (world/plant.py)
    dynamics: str | None = None  # --plant mujoco: the robots' preset (world/dynamics.py)

    @property
    def faults(self) -> dict[str, Any]:
        """The injected faults, as the agents' and the world's options."""
        return {"delay_ms": self.delay_ms, "jitter_ms": self.jitter_ms,
                "drop_rate": self.drop_rate, "drop_seed": self.drop_seed}  # fmt: skip

    @property
    def agents(self) -> int:
        return self.scenario.n

    @property
    def steps(self) -> int:
        return self.scenario.steps


@dataclass(frozen=True)
class RunResult:
    summary: dict[str, Any]  # the world's summary (metrics and timing)
    startup_s: float  # from launch until every agent's token was up
    wall_s: float
    agent_peak_rss_mb: list[float]  # one per agent that reported it
    lost: tuple[str, ...] = ()  # agents that died during the run, e.g. "agent 3 (exit code -9)"
    agent_reports: dict[int, dict[str, Any]] = field(default_factory=dict)  # bus/report.py
    processes: int = 0  # OS processes started for the run (agents' fork server included)
    cpu_us_per_tick: dict[str, float] = field(default_factory=dict)  # with plan.measure_cpu

    @property
    def agent_pss_mb(self) -> list[float]:
        """Each reporting agent's proportional set size at the end, MB (bus/report.py)."""
        return [r["pss_kb"] / 1024 for r in self.agent_reports.values() if r.get("pss_kb")]


def launch(plan: RunPlan, sink: TickSink | None = None) -> RunResult:
    """Run ``plan`` to its end; raises tools.swarm.ChildFailed if a process fails. ``sink``
    is handed every tick record and world event as the monitor receives them."""
    started = time.monotonic()
    with Swarm() as swarm:
        if plan.secure and plan.secure_dir is None:  # removed with the run folder at the end
            made = make_material(swarm.log_dir / "secure", run=plan.run_id, agents=plan.agents)
            plan = replace(plan, secure_dir=made.root)
        endpoint = _router(swarm, plan)
        common: dict[str, Any] = {
            "run_id": plan.run_id, "connect": (endpoint,), "secure": plan.secure_dir
        }  # fmt: skip
        logging = LoggerSpec(out=plan.out, force=plan.force, **common)
        logger = swarm.spawn("logger", "logger", logging.argv(), ready_pipe=True)
        if plan.ros is not None:  # stops the robots if the world dies without doing so
            guarding = GuardSpec(**_ros_options(plan.ros, GuardSpec), **common)
            guard = swarm.spawn("guard", "guard", guarding.argv(), ready_pipe=True)
            swarm.wait_ready(guard, plan.start_timeout)
        swarm.spawn("world", "world", _world(plan, swarm.log_dir, common).argv())
        for i in range(1, plan.agents + 1):
            agent = AgentSpec(agent_id=i, **plan.faults, **common)
            swarm.spawn(f"agent {i}", "agent", agent.argv())
        swarm.wait_ready(logger, plan.start_timeout)
        lost: list[str] = []
        window = None
        if plan.measure_cpu:
            window = CpuWindow(lambda: swarm_processes(swarm, monitor=os.getpid()))
        summary, startup = _monitor(
            swarm, Keys(plan.run_id), endpoint, plan, started, lost, window, sink
        )
        swarm.expect_exit({"world", "agent", "guard"}, timeout=10.0)
        swarm.expect_exit({"logger"}, timeout=10.0)
        reports = reports_in(summary)  # each agent's own figures, via the world (bus/report.py)
        rss = [r["peak_rss_kb"] / 1024 for r in reports.values() if r.get("peak_rss_kb")]
        wall = time.monotonic() - started
        processes = len(swarm.children)
        cpu = window.figures if window is not None else {}
        return RunResult(summary, startup, wall, rss, tuple(lost), reports, processes, cpu)


def _router(swarm: Swarm, plan: RunPlan) -> str:
    """The endpoint of the run's router: ``plan.connect``'s, once it answers, or that of a
    router started here."""
    if plan.connect is not None:
        _probe(plan.connect, plan)
        return plan.connect
    scheme = "tls" if plan.secure_dir else "tcp"
    endpoint = f"{scheme}/127.0.0.1:{free_port()}"
    routing = RouterSpec(listen=(endpoint,), secure=plan.secure_dir)
    router = swarm.spawn("router", "router", routing.argv(), ready_pipe=True)
    swarm.wait_ready(router, plan.start_timeout)
    return endpoint


def _world(plan: RunPlan, folder: Path, common: Mapping[str, Any]) -> WorldSpec:
    """The world's options: the scenario's text handed over in ``folder``, and with ROS 2
    robots every ``--ros-*`` option as ``plan.ros`` resolved it (the world looks nothing up)."""
    robots = {} if plan.ros is None else {"robots": "ros2", **_ros_options(plan.ros, WorldSpec)}
    return WorldSpec(
        scenario=str(_hand_over(plan.scenario, folder)), name=plan.scenario.name,
        expect=("logger", "monitor"), clock=plan.clock, speed=plan.speed,
        safety_layer=plan.safety_layer, layer_epoch=plan.layer_epoch,
        plant=plan.plant, dynamics=plan.dynamics,
        start_timeout=plan.start_timeout, **plan.faults, **robots, **common,
    )  # fmt: skip


def _ros_options(ros: RosConfig, spec: type[ChildSpec]) -> dict[str, Any]:
    """``ros`` as the options of ``spec`` (the world's or the guard's) that say it."""
    given = {"ros_namespaces": ros.namespaces, "ros_connect": ros.connect,
             "ros_domain": ros.domain, "ros_distro": ros.distro, "ros_pose": ros.pose,
             "pose_timeout": ros.pose_timeout}  # fmt: skip
    taken = {f.name for f in fields(spec)}
    return {name: value for name, value in given.items() if name in taken}


def _probe(endpoint: str, plan: RunPlan) -> None:
    """Raise SessionError, naming ``endpoint``, if no router answers there soon: the
    processes themselves keep trying for 30 s, which made an unreachable router look like
    "logger not ready" after half a minute."""
    conf = client_config(
        (endpoint,), secure=plan.secure_dir, name=MONITOR, connect_ms=PROMPT_CONNECT_MS
    )
    with open_session(conf, f"the router at {endpoint}"):
        pass


def _monitor(
    swarm: Swarm,
    keys: Keys,
    endpoint: str,
    plan: RunPlan,
    began: float,
    lost: list[str],
    window: CpuWindow | None = None,
    sink: TickSink | None = None,
) -> tuple[dict[str, Any], float]:
    """Follow the run from a client session until the world's summary arrives; also returns
    the seconds from ``began`` until every agent's token was up.

    An agent that dies does not end the run: the world owns membership (it holds the agent
    still, logs it, and ends the run itself if it was the leader); the agent is noted in
    ``lost`` and on stderr. Any other child that exits early fails the run, unless the world's
    summary is already on its way (the world exits right after publishing it). A CPU
    ``window`` is opened at the first tick record and closed at the last one. A ``sink`` gets
    every tick record and world event (the latter subscribed to only for it)."""
    inbox = Inbox()
    conf = client_config((endpoint,), secure=plan.secure_dir, name=MONITOR)
    with open_session(conf, "shoal run") as session:
        held = [
            subscribe(session, keys.tick, inbox),
            subscribe(session, keys.summary, inbox),
            watch_presence(session, keys.alive_agents, inbox),
            *([subscribe(session, keys.event, inbox)] if sink is not None else []),
        ]
        token = session.liveliness().declare_token(keys.alive_process("monitor"))
        counted = None if sink is None else _Counted(sink)
        show = plan.progress and sys.stderr.isatty()
        with progress_bar(plan.steps, "simulated time", show=show) as bar:
            follow = _Following(keys, plan, began, window, counted, bar if show else None)
            summary = _until_summary(swarm, inbox, lost, follow)
        if counted is not None:
            _trailing_events(inbox, keys, counted, summary.get("events"), within=2.0)
        del held, token
    return summary, follow.startup


def _until_summary(
    swarm: Swarm, inbox: Inbox, lost: list[str], follow: _Following
) -> dict[str, Any]:
    """The world's summary, once it arrives; meanwhile every arrival goes to ``follow`` and
    the children are looked at every 0.2 s (not once per tick: that is soon enough)."""
    checked = 0.0
    while True:
        if time.monotonic() - checked >= 0.2:
            late = _check_children(swarm, inbox, lost, follow)
            if late is not None:
                return late
            checked = time.monotonic()
        arrival = inbox.get(timeout=0.2)
        if arrival is None:
            continue
        if arrival.kind == ArrivalKind.UP:
            follow.agent_up(arrival.key)
            continue
        if arrival.kind != ArrivalKind.DATA:
            continue
        try:
            if arrival.key == follow.keys.summary:
                return codec.decode_document("summary", arrival.payload)
            follow.data(arrival)
        except DecodeError:
            continue  # a stranger's garbage on our keys does not stop the run


def _check_children(
    swarm: Swarm, inbox: Inbox, lost: list[str], follow: _Following
) -> dict[str, Any] | None:
    """None while the run goes on (an agent that died is noted in ``lost``); the world's
    summary if a child's exit came with it (the world exits right after publishing it);
    else ChildFailed."""
    _note_lost_agents(swarm, lost)
    try:
        swarm.check()
    except ChildFailed:
        late = _late_summary(inbox, follow.keys, within=2.0, sink=follow.sink)
        if late is None:
            raise
        return late
    return None


@dataclass
class _Following:
    """What the monitor keeps of a run until its summary: when every agent was up, and the
    tick records, counted for the CPU ``window``, handed to the ``sink`` (with the world's
    events) and shown on the ``bar`` (None: no bar, and no record decoded for it)."""

    keys: Keys
    plan: RunPlan
    began: float
    window: CpuWindow | None
    sink: _Counted | None
    bar: Any | None
    records: int = 0
    agents_up: set[str] = field(default_factory=set)
    startup: float = float("nan")  # s from ``began`` until every agent's token was up

    def agent_up(self, key: str) -> None:
        self.agents_up.add(key)
        if len(self.agents_up) == self.plan.agents:
            self.startup = round(time.monotonic() - self.began, 3)

    def data(self, arrival: Arrival) -> None:
        """A tick record or (with a sink) a world event; DecodeError if it is garbage."""
        if self.sink is not None:
            if arrival.key == self.keys.event:
                self.sink.event(arrival.time_ns, arrival.payload)
                return
            self.sink.tick(arrival.time_ns, arrival.payload)
        self.records += 1
        if self.window is not None and self.records == 1:
            self.window.open()
        elif self.window is not None and self.records == self.plan.steps:
            self.window.close(self.plan.steps - 1)
        if self.bar is not None:
            tick = codec.decode_tick(arrival.payload).tick
            self.bar.update(tick + 1 - self.bar.pos)


@dataclass
class _Counted:
    """A sink that counts the events handed to it."""

    sink: TickSink
    events: int = 0

    def tick(self, ns: int, payload: bytes) -> None:
        self.sink.tick(ns, payload)

    def event(self, ns: int, payload: bytes) -> None:
        self.events += 1
        self.sink.event(ns, payload)


def _trailing_events(
    inbox: Inbox, keys: Keys, sink: _Counted, published: object, within: float
) -> None:
    """Hand ``sink`` the world's events that trail its summary, until it has all ``published``
    (the summary's count) or ``within`` s passed: the event and summary subscribers deliver
    apart, so "run finished" can arrive after the summary that followed it."""
    if not isinstance(published, int):
        return  # a world too old to count its events
    deadline = time.monotonic() + within
    while sink.events < published:
        arrival = inbox.get(timeout=max(deadline - time.monotonic(), 0.0))
        if arrival is None:
            return
        if arrival.kind == ArrivalKind.DATA and arrival.key == keys.event:
            sink.event(arrival.time_ns, arrival.payload)


def _note_lost_agents(swarm: Swarm, lost: list[str]) -> None:
    """Mark agents that exited with an error as expected gone, and say so once each."""
    for c in swarm.children:
        code = c.popen.poll()
        if c.role == "agent" and not c.done and code is not None and code != 0:
            c.done = True
            lost.append(f"{c.name} (exit code {code})")
            warn(f"shoal run: {c.name} exited with code {code}; the world goes on without it")


def _late_summary(
    inbox: Inbox, keys: Keys, within: float, sink: TickSink | None = None
) -> dict[str, Any] | None:
    """The world's summary if it is in ``inbox`` or arrives within ``within`` seconds; the
    tick records and events before it still go to ``sink`` (a world that has exited after
    its summary is seen here first: its "run finished" event must reach the live view)."""
    deadline = time.monotonic() + within
    while (arrival := inbox.get(timeout=max(deadline - time.monotonic(), 0.0))) is not None:
        if arrival.kind != ArrivalKind.DATA:
            continue
        if arrival.key == keys.summary:
            try:
                return codec.decode_document("summary", arrival.payload)
            except DecodeError:
                continue
        if sink is not None:
            handed = sink.event if arrival.key == keys.event else sink.tick
            handed(arrival.time_ns, arrival.payload)
    return None
