"""The agent process: one robot's controller as an OS process on the bus.

A thin loop around :class:`shoal.agent.controller.Controller`. It needs only the run id, its own id
and an endpoint: it waits for the world's liveliness token, fetches its configuration from the
world's queryable, subscribes to its own sensing and to its neighbours' states, and declares its
own token once ready. Per tick (lockstep): sensing arrives → ``announce`` → publish the state;
once every neighbour that is still present has announced the same tick → ``act`` → publish the
command. A neighbour whose token vanishes is treated as gone (its edges dropped). When the
world's token vanishes the agent stops commanding motion and exits.

Realtime (docs/wire.md §3, §4): the agent acts at once on its sensing with the freshest state of
each neighbour, provided it is at most ``max_age`` ticks old (agent/delivery.py); a neighbour
that vanished and comes back is followed again as soon as its states flow. ``--drop-rate``
throws away a seeded random fraction of incoming neighbour states, to measure how the formation
copes with lost messages.
"""

from __future__ import annotations

import resource
import time
from collections import defaultdict
from dataclasses import dataclass

from shoal.agent.controller import Controller
from shoal.agent.delivery import MAX_AGE, AgeStats, Dropper, freshest
from shoal.agent.latency import Delayer
from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.keys import Keys, agent_of
from shoal.bus.messages import AgentState, Sensing
from shoal.bus.report import pss_kb, report_body
from shoal.bus.runtime import Arrival, ArrivalKind, Inbox, warn
from shoal.bus.seam import Answer, Bus, Declarations
from shoal.bus.types import STALE_AFTER, AgentConfig, Clock


class AgentAbort(RuntimeError):
    """The agent cannot take part (no world, no configuration)."""


@dataclass(frozen=True)
class AgentOptions:
    run: str
    agent_id: int
    start_timeout: float = 60.0  # s to wait for the world and its configuration
    drop_rate: float = 0.0  # fault injection: fraction of incoming neighbour states thrown away
    drop_seed: int = 0  # seeds the drops and the delays (with the agent id)
    delay_ms: float = 0.0  # fault injection: outgoing states and commands held back this long
    jitter_ms: float = 0.0  # … ± this much (uniform, ≤ delay_ms)
    max_age: int = MAX_AGE  # realtime: ticks after which a neighbour's state is not followed
    stale_after: int = STALE_AFTER  # realtime: how far a neighbour's state may be ahead of ours


def fetch_config(bus: Bus, keys: Keys, agent_id: int, timeout: float) -> tuple[AgentConfig, str]:
    """Ask the world's queryable for this agent's configuration and the run's clock. The world
    answers with an error when it will not take this agent (back): that text is the abort's."""
    for answer in bus.ask([keys.config(agent_id)], timeout=timeout):
        if answer.error is not None:
            raise AgentAbort(f"agent {agent_id}: the world refuses it: {answer.error}")
        try:
            config, clock = codec.decode_assignment(answer.payload)
        except DecodeError as exc:
            raise AgentAbort(f"agent {agent_id}: bad configuration: {exc}") from None
        if config.agent_id == agent_id:
            return config, clock
    raise AgentAbort(f"agent {agent_id}: the world has no configuration for this agent")


class AgentNode(Declarations):
    """The agent's state between arrivals; all I/O goes through ``bus`` (bus/seam.py). A context
    manager: leaving it undeclares what the agent declared."""

    def __init__(self, options: AgentOptions, bus: Bus) -> None:
        self.options = options
        self.keys = Keys(options.run)
        self.bus = bus
        self.inbox = Inbox()
        self.dropped = 0
        super().__init__()
        try:
            self._join()
        except BaseException:  # nothing declared outlives a failed start
            self.close()
            raise

    def _join(self) -> None:
        """Wait for the world, fetch the configuration, declare what the agent needs and,
        last, its token."""
        bus, k, options = self.bus, self.keys, self.options
        self._held.append(bus.watch(k.alive_world, self.inbox))
        self._await_world()
        config, self.clock = fetch_config(bus, k, options.agent_id, options.start_timeout)
        self.controller = Controller(config)  # valid: the codec refused any other
        me = options.agent_id
        if options.drop_rate > 0 and self.clock != Clock.REALTIME:
            raise AgentAbort(
                f"agent {me}: --drop-rate needs the realtime clock (a lockstep run would wait "
                "for a dropped state forever)"
            )
        self.dropper = Dropper(options.drop_rate, options.drop_seed, me)
        self.ages = AgeStats()
        self._held.append(bus.subscribe(k.sensing(me), self.inbox))
        self._held += [bus.subscribe(k.state(j), self.inbox) for j in self.controller.listens_to]
        self._held.append(bus.watch(k.alive_agents, self.inbox))
        lossy = self.clock == Clock.REALTIME  # bus/links.py: a cut neighbour must not stall us
        self.state_out = bus.publisher(k.state(me), lossy=lossy)
        self.command_out = bus.publisher(k.command(me), lossy=lossy)
        try:  # closed before the publishers it sends on
            self.late = Delayer(
                options.delay_ms / 1e3, options.jitter_ms / 1e3, options.drop_seed, me
            )
        except ValueError as exc:
            raise AgentAbort(f"agent {me}: {exc}") from None
        self._held += [self.late, self.state_out, self.command_out]
        self.memory = self.controller.start()
        self.gone: set[int] = set()
        self.heard: dict[int, dict[int, AgentState]] = defaultdict(dict)
        self.latest: dict[int, AgentState] = {}  # realtime: the freshest state of each neighbour
        self.pending: tuple[Sensing, AgentState] | None = None
        self.tick = -1  # the last tick sensed
        self._held.append(bus.serve(k.report(me), self._answer_report))
        self._held.append(bus.token(k.alive_agent(me)))

    def _await_world(self) -> None:
        deadline = time.monotonic() + self.options.start_timeout
        while True:
            arrival = self.inbox.get(timeout=max(deadline - time.monotonic(), 0.0))
            if arrival is None:
                raise AgentAbort(
                    f"no world for run {self.options.run!r} after {self.options.start_timeout:g} s"
                )
            if arrival.kind == ArrivalKind.UP:
                return

    def run(self) -> None:
        """Serve ticks until the world goes away."""
        while True:
            arrival = self.inbox.wait()
            if arrival.kind == ArrivalKind.DOWN and arrival.key == self.keys.alive_world:
                if not self.bus.present(arrival.key):
                    return
                warn(f"agent {self.options.agent_id}: the world's token went down but it still "
                     "answers; going on")  # fmt: skip
                continue
            self._take(arrival)
            self._maybe_act()

    def _take(self, arrival: Arrival) -> None:
        if arrival.kind in (ArrivalKind.UP, ArrivalKind.DOWN):
            self._presence(arrival)
            return
        if arrival.kind != ArrivalKind.DATA:
            return
        try:
            if arrival.key.endswith("/sensing"):
                self._sensed(codec.decode_sensing(arrival.payload))
            else:
                if self.dropper.drop():
                    return  # injected loss: as if the message never came
                state = codec.decode_state(arrival.payload)
                if self.clock == Clock.REALTIME and self.tick < 0:
                    return  # heard before our first sensing (we are rejoining): not yet usable
                self._check_state(state, arrival.key)
                if self.clock == Clock.REALTIME:
                    old = self.latest.get(state.agent_id)
                    if old is None or old.tick < state.tick:
                        self.latest[state.agent_id] = state
                else:
                    self.heard[state.tick][state.agent_id] = state
        except DecodeError as exc:
            self.dropped += 1
            if self.dropped <= 10:
                warn(
                    f"agent {self.options.agent_id}: dropped a bad message on {arrival.key}: {exc}"
                )

    def _presence(self, arrival: Arrival) -> None:
        """A neighbour's token vanished: stop following it and forget its last state. It came
        (back) up: in realtime, follow it again once its states flow (the world takes a
        restarted agent back); in lockstep a gone neighbour stays gone, because the world never
        takes it back and waiting for its state would stall this agent for good."""
        j = agent_of(arrival.key)
        if j is None or j == self.options.agent_id:
            return
        if arrival.kind == ArrivalKind.DOWN:
            self.gone.add(j)
            self.latest.pop(j, None)
        elif self.clock == Clock.REALTIME:
            self.gone.discard(j)

    def report(self) -> dict[str, int | None]:
        """The figures the world asks for at the end of the run (bus/report.py)."""
        d, a = self.dropper, self.ages
        return report_body(
            {
                "last_tick": self.tick,
                "bad_messages": self.dropped,
                "states_heard": d.offered,
                "injected_drops": d.dropped,
                "delayed_messages": self.late.held,
                "age_p50": a.quantile(0.5),
                "age_p99": a.quantile(0.99),
                "age_max": max(a.histogram, default=None),
                "stale_edges": a.stale_edges,
                "peak_rss_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                "pss_kb": pss_kb(),
            }
        )

    def _answer_report(self, key: str) -> Answer | None:  # the bus's thread: reads state only
        for _ in range(3):  # the main loop may be adding an age to the histogram right now
            try:
                figures = self.report()
                break
            except RuntimeError:
                continue
        else:
            return None
        body = codec.encode_document("report", figures)
        return Answer(self.keys.report(self.options.agent_id), body)

    def stats(self) -> str:
        """One line for stderr at exit: neighbour states heard and dropped, and their ages."""
        d, a = self.dropper, self.ages
        return (
            f"agent {self.options.agent_id}: neighbour states heard {d.offered}, "
            f"injected drops {d.dropped} of {d.offered}, age p50 {a.quantile(0.5)} "
            f"p99 {a.quantile(0.99)} max {max(a.histogram, default=None)} ticks, "
            f"stale edges {a.stale_edges}"
        )

    def _check_state(self, state: AgentState, key: str) -> None:
        """A neighbour's state must be its own, of our dimension, and of a tick it can have
        reached. In lockstep that is the tick before our last sensing, that one, or the next
        (the world does not send tick k+1 before our command of tick k). In realtime our own
        sensing may be late or lost while the neighbour's came: a state up to ``stale_after``
        ticks ahead of our last sensing is as new as a command the world's watchdog still
        applies (bus/types.py STALE_AFTER), and is kept; one further ahead is refused, so that
        a stray tick far in the future cannot pin a neighbour's freshest state for good."""
        if state.agent_id != agent_of(key):
            raise DecodeError(f"state of agent {state.agent_id} on another agent's key")
        if len(state.position) != self.controller.config.dim:
            raise DecodeError(f"state position has {len(state.position)} coordinates")
        if self.clock == Clock.LOCKSTEP:
            if not self.tick - 1 <= state.tick <= self.tick + 1:
                raise DecodeError(f"state of tick {state.tick} while at tick {self.tick}")
            return
        ahead = max(self.options.stale_after, 1)
        if not 0 <= state.tick <= self.tick + ahead:
            raise DecodeError(
                f"state of tick {state.tick} while at tick {self.tick}: more than {ahead} "
                "ticks ahead, beyond the world's watchdog (a command that late is held)"
            )

    def _sensed(self, sensing: Sensing) -> None:
        dim = self.controller.config.dim
        if len(sensing.position) != dim or any(len(c) != dim for c in sensing.obstacle_centres):
            raise DecodeError(f"sensing is not {dim}-D")
        if sensing.tick <= self.tick:
            raise DecodeError(f"sensing of tick {sensing.tick} after tick {self.tick}")
        if any(r <= 0 for r in sensing.obstacle_radii):
            raise DecodeError("sensing has an obstacle radius ≤ 0")
        if self.pending is not None:
            raise DecodeError(
                f"sensing of tick {sensing.tick} before tick {self.pending[0].tick} was answered"
            )
        self.tick = sensing.tick
        self.memory, state = self.controller.announce(self.memory, sensing)
        self.late.put(self.state_out, codec.encode_state(state))
        self.pending = (sensing, state)

    def _maybe_act(self) -> None:
        """Lockstep: act once every present neighbour has announced this tick. Realtime: act at
        once, on the freshest state heard from each present neighbour that is at most
        ``max_age`` ticks old (agent/delivery.py)."""
        if self.pending is None:
            return
        sensing, state = self.pending
        needed = [j for j in self.controller.listens_to if j not in self.gone]
        if self.clock == Clock.REALTIME:
            max_age = self.options.max_age
            use, ages = freshest(self.latest, needed, sensing.tick, max_age)
            self.ages.add(ages, max_age)
        else:
            heard = self.heard[sensing.tick]
            if any(j not in heard for j in needed):
                return
            use = {j: heard[j] for j in needed}
        self.memory, command = self.controller.act(self.memory, sensing, use)
        self.late.put(self.command_out, codec.encode_report(state, command))
        self.pending = None
        for tick in [t for t in self.heard if t <= sensing.tick]:
            del self.heard[tick]
