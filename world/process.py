"""The world process: the lockstep clock, kinematics and sensing for every agent, over Zenoh.

A thin loop of I/O around the run's tick (:class:`shoal.world.step.Step`, which the reference
simulator drives too):
each tick it sends every live agent its sensing, waits until every live agent's command for the
tick is in, publishes the tick's ground truth, and integrates. It serves each agent its
configuration (a queryable) and follows agents' presence by liveliness: an agent whose token
vanishes is held still, its departure logged, and the run goes on without it. In realtime a
restarted agent is taken back when its token reappears; in lockstep it is refused (its
configuration query gets an error), because the tick protocol cannot admit it without every
neighbour agreeing on the tick it rejoins at. If the leader vanishes, the formation has lost its
only reference to the path: the world holds every agent still and ends the run (docs/wire.md §4).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.keys import Keys, agent_of
from shoal.bus.messages import AgentState, Command, Event, RobotsRecord
from shoal.bus.report import REPORT_TIMEOUT_S, summary_entries
from shoal.bus.runtime import Arrival, ArrivalKind, Inbox, warn
from shoal.bus.seam import Answer, Bus, Declarations
from shoal.bus.types import STALE_AFTER, AgentConfig, Clock, SafetyLayer
from shoal.geometry.vectors import FloatArray
from shoal.world.layers import make_layer
from shoal.world.metrics import summarize
from shoal.world.onboard import Link, OnboardLayers, epoch_ticks
from shoal.world.plant import KINEMATICS, Kinematics, Observed, Plant, PlantError, bodily
from shoal.world.reach_layer import reach_inputs
from shoal.world.scenario import Scenario
from shoal.world.start import misplaced
from shoal.world.step import Report, Step
from shoal.world.trajectory import Trajectory
from shoal.world.watch import LeaderWatch


class WorldAbort(RuntimeError):
    """The run cannot go on (agents never came up, or stopped answering)."""


@dataclass(frozen=True)
class WorldOptions:
    run: str
    expect: tuple[str, ...] = ()  # other processes (logger, monitor) to wait for
    clock: Clock = Clock.LOCKSTEP
    speed: float = 1.0  # realtime: simulated seconds per wall-clock second
    stale_after: int = STALE_AFTER  # realtime: a command older than this many ticks is held
    layer: SafetyLayer | None = None  # None: onboard in realtime, the referee in lockstep
    link: Link | None = None  # onboard: the robots' own radio (ticks late, lost)
    layer_epoch: float = 0.1  # onboard: s of simulated time between the robots' snapshots
    start_timeout: float = 60.0  # s to wait for every agent (and the logger) to come up
    answer_timeout: float = 30.0  # s to wait for a live agent's command before giving up
    plant: Plant | None = (
        None  # robots or a physics plant in place of the kinematics (world/plant.py)
    )
    # The simulated plant's name and --dynamics, as the log records them for `shoal verify`.
    plant_name: str = KINEMATICS
    dynamics: str | None = None


class World(Declarations):
    """The world's state between ticks; all I/O goes through ``bus`` (bus/seam.py). A context
    manager: leaving it undeclares what the world declared."""

    def __init__(self, scenario: Scenario, options: WorldOptions, bus: Bus) -> None:
        super().__init__()
        self.scenario = scenario
        self.options = options
        self.keys = Keys(options.run)
        self.bus = bus
        self.inbox = Inbox()
        self.dropped = 0  # malformed or stale messages counted and dropped
        self.events = 0  # world events published (the summary says how many, see _event)
        self.alive = set(range(1, scenario.n + 1))
        self.departed: dict[int, int] = {}  # agent → the tick its token vanished at
        self.aborted: str | None = None  # why the run ended early (the leader is gone)
        self.latest: dict[int, tuple[AgentState, Command]] = {}  # each agent's newest command
        self.up: set[str] = set()
        configs = {i: codec.encode_config(self._config(i), clock=options.clock) for i in self.alive}

        def serve(key: str) -> Answer | None:  # on the bus's thread: reads, never writes, state
            last = key.rsplit("/", 1)[-1]
            i = int(last) if last.isascii() and last.isdigit() else None
            if i is None or i not in configs:
                return None
            left = self.departed.get(i)
            if left is not None and options.clock == Clock.LOCKSTEP:
                self.inbox.put(Arrival(ArrivalKind.REFUSED, self.keys.alive_agent(i)))
                return Answer(
                    key,
                    error=f"agent {i} left at tick {left}; a lockstep run does not take agents "
                    "back (its neighbours no longer wait for it)",
                )
            return Answer(self.keys.config(i), configs[i])

        if self.robots and (options.clock != Clock.REALTIME or options.speed != 1):
            raise WorldAbort("robots move on the wall clock: drive them in realtime at speed 1")
        k = self.keys
        if bus.present(k.alive_world, timeout=1.0):
            raise WorldAbort(f"another world already serves run {options.run!r}")
        self._held += [
            bus.serve(k.configs, serve),
            bus.subscribe(k.commands, self.inbox),
            bus.watch(k.alive_everyone, self.inbox),
        ]
        lossy = options.clock == Clock.REALTIME  # bus/links.py: one cut agent must not stall all
        self.sensing_out = {i: bus.publisher(k.sensing(i), lossy=lossy) for i in self.alive}
        self.tick_out = bus.publisher(k.tick)
        self.event_out = bus.publisher(k.event)
        self.summary_out = bus.publisher(k.summary)
        self.scenario_out = bus.publisher(k.scenario)
        self._held += [*self.sensing_out.values(), self.tick_out, self.event_out]
        self._held += [self.summary_out, self.scenario_out]
        self.robots_out = bus.publisher(k.robots) if self.robots else None
        physics = options.plant is not None and options.plant.simulated
        self.plant_out = bus.publisher(k.plant) if physics else None
        self._held += [out for out in (self.robots_out, self.plant_out) if out is not None]
        self._held.append(bus.token(k.alive_world))

    @property
    def robots(self) -> bool:
        """Real robots (moving on the wall clock) in place of a simulated plant."""
        return self.options.plant is not None and not self.options.plant.simulated

    @property
    def layer(self) -> SafetyLayer:
        return SafetyLayer.of(self.options.layer, self.options.clock)

    def _config(self, i: int) -> AgentConfig:
        """Agent ``i``'s configuration; for bodies (robots, a physics plant) world/plant.py's
        :func:`bodily` one."""
        config = self.scenario.agent_config(i, self.options.clock)
        return config if self.options.plant is None else bodily(config)

    # -- start ----------------------------------------------------------------------------------

    def wait_for_everyone(self) -> None:
        """Block until every agent (and the logger, if expected) holds a liveliness token."""
        k = self.keys
        wanted = {k.alive_agent(i) for i in self.alive}
        wanted |= {k.alive_process(name) for name in self.options.expect}
        deadline = time.monotonic() + self.options.start_timeout
        while not wanted <= self.up:
            left = deadline - time.monotonic()
            arrival = self.inbox.get(timeout=max(left, 0.0)) if left > 0 else None
            if arrival is None:
                missing = ", ".join(sorted(wanted - self.up))
                raise WorldAbort(f"not up after {self.options.start_timeout:g} s: {missing}")
            if arrival.kind == ArrivalKind.DATA:  # no agent can command before it has sensed tick 0
                self._drop(f"{arrival.key}: a command before tick 0")
            else:
                self._note_presence(arrival)
        if self.options.plant is not None:
            try:
                self.options.plant.wait_ready(max(deadline - time.monotonic(), 1.0))
            except PlantError as exc:
                raise WorldAbort(str(exc)) from None
        self.scenario_out.put(codec.encode_document("scenario", self._scenario_document()))

    def _check_starts(self, positions: FloatArray) -> None:
        """Real robots far from their scenario starts (world/start.py), judged on the poses of
        tick 0 (the plant's first observation, before any sensing or command goes out): a
        warning event for each beyond its body's reach; a refusal for any beyond the sensing
        radius or halfway to another agent's start. Simulated plants start exactly there."""
        if not self.robots:
            return
        found = misplaced(positions, self.scenario)
        for m in found:
            self._event(0, 4 if m.refused else 3, m.agent, m.text())
        refused = [m.text() for m in found if m.refused]
        if refused:
            raise WorldAbort("; ".join(refused))

    def _scenario_document(self) -> dict[str, Any]:
        """The scenario as the log records it: its text, under the name it ran as, and the
        simulated plant that moved it unless the world's own kinematics did, and the reach
        layer when it certified the steps (a log cut before its summary still re-runs with it)."""
        doc: dict[str, Any] = {"name": self.scenario.name, "yaml": self.scenario.source}
        if self.options.plant_name != KINEMATICS:
            doc |= {"plant": self.options.plant_name, "dynamics": self.options.dynamics}
        if self.layer == SafetyLayer.REACH:
            doc |= {"safety_layer": str(self.layer), "dynamics": self.options.dynamics}
        return doc

    # -- ticks ----------------------------------------------------------------------------------

    def run(self) -> dict[str, Any]:
        """Run every tick; returns (and publishes) the summary with the run's timing. Real
        robots (``options.plant``) are stopped however the run ends: finished, the leader lost,
        an error, Ctrl-C."""
        step = self._step()
        try:
            return self._run(step)
        finally:
            step.plant.stop()

    def _step(self) -> Step:
        """The run's tick: its safety layer and what moves the agents, configured once."""
        s, options = self.scenario, self.options
        params = s.params()
        epoch = epoch_ticks(options.layer_epoch, s.dt)
        far = OnboardLayers.far_for(params, s.dt, epoch)
        if self.layer == SafetyLayer.ONBOARD and far > s.control.sensing_radius:
            self._event(
                0, 2, 0,
                f"onboard layer: with a speed limit of {s.speed_limit:g} m/s any two robots "
                f"within {far:.1f} m may meet within an epoch, so robots near each other "
                "stand at every snapshot until it arrives; set control.speed_limit to your "
                "robots' own (docs/safety.md, Without a referee)",
            )  # fmt: skip
        bounds, largest = reach_inputs(s, options.dynamics)
        layer = make_layer(
            self.layer, params, s.n, s.dt, s.limits, epoch=epoch, link=options.link,
            bounds=bounds, largest_obstacle=largest,
        )  # fmt: skip
        plant = options.plant or Kinematics(
            s.initial_positions, s.initial_headings, s.lookaheads, s.dt
        )
        return Step(s, layer, plant)

    def _run(self, step: Step) -> dict[str, Any]:
        """The tick loop: I/O around :class:`Step`."""
        s = self.scenario
        clock = _Clock(
            realtime=self.options.clock == Clock.REALTIME, period=s.dt / self.options.speed
        )
        watch = LeaderWatch(s)
        for k in range(s.steps):
            clock.sent(k)
            sensings = step.sense(k)
            if k == 0:
                self._check_starts(step.seen.positions)
            for i in sorted(step.newly_stale):
                self._event(k, 3, i, f"robot {i}'s pose is stale; held still until it reports")
            said = watch.update(k, step.seen.positions[0])
            if said is not None:
                self._event(k, 3 if watch.trapped else 2, 1, said)
            for i in sorted(self.alive):
                self.sensing_out[i].put(codec.encode_sensing(sensings[i - 1]))
            self._collect(k, clock)
            record = step.act_recorded(k, self._reports(k, clock), self.alive)
            self.tick_out.put(codec.encode_tick(record))
            self._publish_plant(k, step)
            if self.aborted is not None:
                break
        return self._summarize(step, step.finish(), clock)

    def _publish_plant(self, k: int, step: Step) -> None:
        """Tick k's record of what moved the agents: what the robots reported and were sent,
        or the bodies, motors and contacts of a physics plant."""
        if self.robots_out is not None and step.sent is not None:
            self.robots_out.put(codec.encode_robots(_robots_record(k, step.seen, step.sent)))
        if self.plant_out is not None and (moved := step.plant.record(k)) is not None:
            self.plant_out.put(codec.encode_plant(moved))

    def _reports(self, k: int, clock: _Clock) -> dict[int, Report]:
        """The commands that move the agents over tick k: each live agent's latest, unless it
        is older than the watchdog allows (as on a real robot: no fresh command, no motion) or
        the leader is gone (nobody moves any more, and this tick is the last)."""
        latest = self.latest
        clock.missed += sum(1 for i in self.alive if i not in latest or latest[i][1].tick != k)
        if self.aborted is not None:
            return {}
        reports = {i: latest[i] for i in sorted(self.alive) if i in latest}
        stale = [i for i, r in reports.items() if k - r[1].tick > self.options.stale_after]
        for i in stale:
            del reports[i]
        clock.stale_holds += len(stale)
        return reports

    def _summarize(self, step: Step, traj: Trajectory, clock: _Clock) -> dict[str, Any]:
        """The run's summary (published, and returned), and its closing event."""
        summary = {
            **summarize(self.scenario, traj, clock=self.options.clock).as_dict(),
            **clock.report(traj.ticks),  # the ticks run: fewer than planned if it ended early
            "dropped_messages": self.dropped,
            **step.layer.report(),
            "aborted": self.aborted,
            **({"pose_holds": step.pose_holds} if self.robots else {}),
            **step.plant.report(),
            **self._agent_reports(),
        }
        if self.aborted is None:
            self._event(
                self.scenario.steps, 2, 0, f"run finished; {self.dropped} bad messages dropped"
            )
        else:
            end = traj.ticks
            why = f"run ended early at tick {end}: {self.aborted}"
            self._event(end, 4, 0, f"{why}; {self.dropped} bad messages dropped")
        # A subscriber to both keys may get the summary first: Zenoh keeps a publisher's order
        # per subscriber, not across two. The count lets it wait for the last event.
        summary["events"] = self.events
        self.summary_out.put(codec.encode_document("summary", summary))
        return summary

    def _agent_reports(self) -> dict[str, Any]:
        """Every live agent's report (bus/report.py), as summary entries; a bad one is counted
        and dropped like any bad message."""
        out: dict[str, Any] = {}
        # One query per agent, all in flight at once: under the run's ACL (bus/acl.py) agent i
        # is asked only on its own key, so a wildcard query would reach nobody.
        asked = [self.keys.report(i) for i in sorted(self.alive)]
        for answer in self.bus.ask(asked, timeout=REPORT_TIMEOUT_S):
            i = agent_of(answer.key)
            if answer.error is not None or i is None or i not in self.alive:
                continue
            try:
                body = codec.decode_document("report", answer.payload)
            except DecodeError as exc:
                self._drop(f"{answer.key}: {exc}")
                continue
            out.update(summary_entries(i, body))
        return out

    def _collect(self, k: int, clock: _Clock) -> None:
        """Take commands into ``self.latest`` until tick k may end: in lockstep once every live
        agent's command for tick k is in; in realtime when the tick's wall-clock period ends;
        in either, at once when the leader is gone."""
        latest = self.latest
        silent = self._silent(k)  # kept up to date, not recomputed per arrival (n² per tick)
        while self.aborted is None:
            if clock.realtime:
                left = clock.deadline - time.monotonic()
                if left <= 0:
                    return
                arrival = self.inbox.get(timeout=left)
                if arrival is None:
                    return
            else:
                if not silent:
                    return
                arrival = self.inbox.get(timeout=self.options.answer_timeout)
                if arrival is None:
                    raise WorldAbort(f"tick {k}: no command from agent(s) {sorted(silent)} in time")
            if arrival.kind != ArrivalKind.DATA:
                self._note_presence(arrival, tick=k)
                silent = self._silent(k)  # an agent may have gone (or come back)
                continue
            report = self._valid_report(arrival, k)
            if report is None:
                continue
            i, tick = report[1].agent_id, report[1].tick
            if i in self.alive and (i not in latest or latest[i][1].tick < tick):
                latest[i] = report
                clock.answered(tick)
                if tick == k:
                    silent.discard(i)

    def _silent(self, k: int) -> set[int]:
        """The live agents whose command for tick k is not in yet."""
        latest = self.latest
        return {i for i in self.alive if i not in latest or latest[i][1].tick != k}

    def _valid_report(self, arrival: Arrival, k: int) -> tuple[AgentState, Command] | None:
        try:
            state, command = codec.decode_report(arrival.payload)
        except DecodeError as exc:
            self._drop(f"{arrival.key}: {exc}")
            return None
        if command.agent_id != agent_of(arrival.key) or not 0 <= command.tick <= k:
            self._drop(f"{arrival.key}: agent {command.agent_id} tick {command.tick} at {k}")
            return None
        if len(command.velocity) != self.scenario.dim:
            self._drop(f"{arrival.key}: velocity has {len(command.velocity)} coordinates")
            return None
        return state, command

    def _note_presence(self, arrival: Arrival, *, tick: int | None = None) -> None:
        """Follow a token going up or down (``tick`` None: before tick 0, when a token that
        goes down is simply waited for again), or a refused configuration query."""
        i = agent_of(arrival.key)
        if i is None or arrival.key != self.keys.alive_agent(i):
            i = None  # not an agent's token (logger, monitor) or not ours
        if arrival.kind == ArrivalKind.UP:
            self.up.add(arrival.key)
            if i is not None and i in self.departed and tick is not None:
                self._back(i, tick)
        elif arrival.kind == ArrivalKind.DOWN:
            self.up.discard(arrival.key)
            if i is not None and i in self.alive and tick is not None:
                # Held from this tick while the token is looked at again: a router that died
                # takes every token down at once, and the guard stops the robots then; the
                # commands the world still had must not follow its zero.
                self.latest.pop(i, None)
                if self.bus.present(arrival.key):
                    self._event(tick, 2, i, f"agent {i}'s token went down but it still answers; "
                                "kept")  # fmt: skip
                else:
                    self._gone(i, tick)
        elif arrival.kind == ArrivalKind.REFUSED and i is not None:
            self._event(
                tick or 0, 3, i, f"agent {i} asked to rejoin at tick {tick}; refused (lockstep)"
            )

    def _gone(self, i: int, tick: int) -> None:
        self.alive.discard(i)
        self.departed[i] = tick
        self.latest.pop(i, None)
        if self.scenario.agent_config(i).is_leader:  # the one agent with the path
            self.aborted = f"the leader (agent {i}) is gone at tick {tick}"
            self._event(tick, 4, i, f"{self.aborted}; every agent held still and the run ends here")
        elif self.options.clock == Clock.REALTIME:
            self._event(tick, 3, i, f"agent {i} gone at tick {tick}; held still until it rejoins")
        else:
            self._event(tick, 3, i, f"agent {i} gone at tick {tick}; held still from now on")

    def _back(self, i: int, tick: int) -> None:
        """A departed agent's token is up again: in realtime take it back (it gets sensing from
        the next tick on and moves once its first command is in); in lockstep log and ignore it
        (it normally never gets this far: its configuration query was refused)."""
        if self.options.clock != Clock.REALTIME:
            self._event(tick, 3, i, f"agent {i} back at tick {tick}; not taken back (lockstep)")
            return
        del self.departed[i]
        self.alive.add(i)
        self._event(tick, 2, i, f"agent {i} back at tick {tick}; taken back")

    def _drop(self, why: str) -> None:
        self.dropped += 1
        if self.dropped <= 10:
            warn(f"world: dropped a bad message ({why})")

    def _event(self, tick: int, level: int, agent: int, text: str) -> None:
        self.event_out.put(codec.encode_event(Event(tick, level, agent, text)))
        self.events += 1
        warn(f"world: {text}")


def _robots_record(k: int, seen: Observed, twists: np.ndarray[Any, Any]) -> RobotsRecord:
    """What the robots reported (their poses' ages) and were sent at tick ``k``."""
    ages = () if seen.ages is None else tuple(seen.ages.tolist())
    sent: list[tuple[float, ...]] = [tuple(t) for t in twists.tolist()]
    return RobotsRecord(k, tuple(sent), ages)


class _Clock:
    """Wall-clock bookkeeping of a run: tick deadlines (realtime) and command latency."""

    def __init__(self, *, realtime: bool, period: float) -> None:
        self.realtime = realtime
        self.period = period
        self.start = time.monotonic()
        self.deadline = self.start
        self.sent_at: dict[int, float] = {}
        self.latencies: list[float] = []
        self.missed = 0  # agent-ticks that ended without that agent's command for the tick
        self.overruns = 0  # realtime ticks that began after their deadline had passed
        self.stale_holds = 0  # agent-ticks held still because the latest command was too old

    def sent(self, k: int) -> None:
        now = time.monotonic()
        self.sent_at[k] = now
        self.sent_at.pop(k - 64, None)
        if self.realtime:
            self.deadline += self.period
            if self.deadline < now:
                self.overruns += 1
                self.deadline = now + self.period

    def answered(self, tick: int) -> None:
        if tick in self.sent_at:
            self.latencies.append(time.monotonic() - self.sent_at[tick])

    def report(self, steps: int) -> dict[str, Any]:
        wall = time.monotonic() - self.start
        lat = np.asarray(self.latencies) * 1e3
        return {
            "clock": Clock.REALTIME if self.realtime else Clock.LOCKSTEP,
            "ticks_per_s": round(steps / wall, 2) if wall > 0 else None,
            "latency_p50_ms": round(float(np.percentile(lat, 50)), 3) if lat.size else None,
            "latency_p99_ms": round(float(np.percentile(lat, 99)), 3) if lat.size else None,
            "missed_deadlines": self.missed if self.realtime else 0,
            "overruns": self.overruns,
            "stale_holds": self.stale_holds,
        }
