"""In realtime a neighbour's state may run ahead of this agent's own sensing (its sensing late or
lost while the neighbour's came): up to the world's watchdog (bus/types.py STALE_AFTER) it is
kept and followed, not counted as a bad message; further ahead it is refused, by name. Lockstep
keeps its one tick. One agent on an in-memory bus, a stand-in world feeding it by hand."""

from __future__ import annotations

import threading
from dataclasses import dataclass

import pytest

from shoal.agent.process import AgentNode, AgentOptions
from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus
from shoal.bus.messages import AgentState, Sensing
from shoal.bus.seam import Answer
from shoal.bus.types import STALE_AFTER, Clock
from shoal.world.loader import load_scenario

RUN = "ahead"
ME, NEIGHBOUR = 2, 1  # in `default`, agent 2 senses and talks to agent 1


@dataclass
class Fed:
    """What the agent made of what it was fed, once its loop has ended."""

    bad: int
    latest_tick: int | None
    commands: int
    age_max: int | None


def _sensing(tick: int) -> bytes:
    return codec.encode_sensing(Sensing(tick, (0.0, 0.0), (), (), ()))


def _state(tick: int) -> bytes:
    return codec.encode_state(AgentState(NEIGHBOUR, tick, (1.0, 0.0), False, 1.0, 1.0, 0.0))


def _feed(clock: Clock, messages: list[tuple[str, int]]) -> Fed:
    """Agent ME under ``clock`` fed ``messages`` in order — ("sensing", tick) for its own sensing,
    ("state", tick) for its neighbour's — then the world's token goes down and its loop ends."""
    bus, keys = MemoryBus(), Keys(RUN)
    config = codec.encode_config(load_scenario("default").agent_config(ME, clock), clock=clock)
    world = bus.token(keys.alive_world)
    served = bus.serve(keys.configs, lambda key: Answer(key, config))
    options = AgentOptions(run=RUN, agent_id=ME, start_timeout=5.0)
    errors: list[BaseException] = []
    with AgentNode(options, bus) as node:

        def loop() -> None:
            try:
                node.run()
            except BaseException as exc:  # reported to the test, not lost in the thread
                errors.append(exc)

        thread = threading.Thread(target=loop, daemon=True)
        thread.start()
        for kind, tick in messages:
            key = keys.sensing(ME) if kind == "sensing" else keys.state(NEIGHBOUR)
            bus.put(key, _sensing(tick) if kind == "sensing" else _state(tick))
        world.undeclare()
        thread.join(timeout=10.0)
        assert not thread.is_alive() and errors == []
        latest = node.latest.get(NEIGHBOUR)
        report = node.report()
        fed = Fed(
            bad=node.dropped,
            latest_tick=None if latest is None else latest.tick,
            commands=sum(1 for k, _ in bus.published if k == keys.command(ME)),
            age_max=report["age_max"],
        )
    served.undeclare()
    return fed


def test_a_state_a_few_ticks_ahead_in_realtime_is_followed_not_counted_bad(
    capsys: pytest.CaptureFixture[str],
) -> None:
    ahead = 3  # our sensing of ticks 1 and 2 lost; the neighbour's state of tick 3 came
    assert 1 < ahead <= STALE_AFTER
    fed = _feed(Clock.REALTIME, [("sensing", 0), ("state", ahead), ("sensing", ahead)])
    assert fed.bad == 0, capsys.readouterr().err
    assert fed.latest_tick == ahead
    assert fed.commands == 2  # acted at ticks 0 and 3, the second on the state of tick 3
    assert fed.age_max == 0  # … which was of its own tick: fresh
    assert "dropped a bad message" not in capsys.readouterr().err


def test_a_state_as_far_ahead_as_the_watchdog_allows_is_kept() -> None:
    fed = _feed(Clock.REALTIME, [("sensing", 0), ("state", STALE_AFTER)])
    assert (fed.bad, fed.latest_tick) == (0, STALE_AFTER)


def test_a_state_beyond_the_watchdog_is_refused_and_says_why(
    capsys: pytest.CaptureFixture[str],
) -> None:
    fed = _feed(Clock.REALTIME, [("sensing", 0), ("state", STALE_AFTER + 1), ("sensing", 1)])
    assert fed.bad == 1
    assert fed.latest_tick is None  # not kept: a stray future tick cannot pin the neighbour
    assert fed.age_max is None  # the command of tick 1 had no neighbour state to use
    err = capsys.readouterr().err
    assert (
        f"state of tick {STALE_AFTER + 1} while at tick 0: more than {STALE_AFTER} ticks "
        "ahead, beyond the world's watchdog" in err
    ), err


def test_lockstep_still_refuses_a_state_two_ticks_ahead(
    capsys: pytest.CaptureFixture[str],
) -> None:
    fed = _feed(Clock.LOCKSTEP, [("sensing", 0), ("state", 2)])
    assert fed.bad == 1
    assert "state of tick 2 while at tick 0" in capsys.readouterr().err
