"""agent/latency.py: late messages for fault injection — each held back by its seeded delay,
sent in the order of its release, counted; none early; what is held when the agent closes is
dropped; and a lockstep swarm under any delay still equals the reference bit for bit."""

from __future__ import annotations

import dataclasses
import threading
import time

import pytest

from shoal.agent.latency import Delayer


class Recorder:
    """An outbox that notes when each payload went out, and says when ``want`` have."""

    def __init__(self, want: int) -> None:
        self.sent: list[tuple[float, bytes]] = []
        self.want = want
        self.done = threading.Event()

    def put(self, payload: bytes) -> None:
        self.sent.append((time.monotonic(), payload))
        if len(self.sent) >= self.want:
            self.done.set()


def test_no_delay_sends_at_once_on_the_callers_thread() -> None:
    out = Recorder(1)
    late = Delayer(0.0, 0.0, seed=0, agent_id=1)
    late.put(out, b"now")
    assert [p for _t, p in out.sent] == [b"now"] and late.held == 0
    late.close()


def test_each_message_waits_its_delay_and_leaves_in_release_order() -> None:
    delay, jitter, n = 0.02, 0.015, 40
    out = Recorder(n)
    late = Delayer(delay, jitter, seed=7, agent_id=3)
    put_at = {}
    for k in range(n):
        payload = k.to_bytes(2, "big")
        put_at[payload] = time.monotonic()
        late.put(out, payload)
    assert out.done.wait(timeout=10.0)
    late.close()
    assert late.held == n and delay - jitter <= late.longest <= delay + jitter
    for sent, payload in out.sent:
        assert sent - put_at[payload] >= delay - jitter - 1e-4  # never early
    order = [int.from_bytes(p, "big") for _t, p in out.sent]
    assert sorted(order) == list(range(n)) and order != list(range(n))  # jitter 15 ms, 0 apart


def test_the_same_seed_draws_the_same_delays() -> None:
    def order(seed: int) -> list[int]:
        out = Recorder(20)
        late = Delayer(0.01, 0.01, seed=seed, agent_id=2)
        for k in range(20):
            late.put(out, bytes([k]))
        assert out.done.wait(timeout=10.0)
        late.close()
        return [p[0] for _t, p in out.sent]

    assert order(1) == order(1)  # all put at once: release order is the drawn delays' order


def test_what_is_held_at_close_is_dropped_and_bad_figures_are_refused() -> None:
    out = Recorder(1)
    late = Delayer(5.0, 0.0, seed=0, agent_id=1)
    late.put(out, b"never")
    late.close()
    assert out.sent == [] and late.held == 1
    for delay, jitter in ((-0.1, 0.0), (0.01, 0.02), (0.01, -0.001)):
        with pytest.raises(ValueError, match="jitter"):
            Delayer(delay, jitter, seed=0, agent_id=1)


def test_a_lockstep_swarm_with_late_messages_equals_the_reference_bit_for_bit() -> None:
    """Every state and command 0–4 ms late, reordered among themselves: a lockstep run waits
    for each and gives the reference's bits."""
    from memoryrun import RUN, recorded, run_in_memory

    from shoal.agent.process import AgentOptions
    from shoal.bus.memory import MemoryBus
    from shoal.tools.simulator import simulate
    from shoal.world.loader import load_scenario

    scn = dataclasses.replace(load_scenario("obstacles"), duration=0.5)
    bus = MemoryBus()
    late = dataclasses.replace(AgentOptions(run=RUN, agent_id=1), delay_ms=2.0, jitter_ms=2.0)
    summary, errors = run_in_memory(scn, bus, agent_options=late)
    assert not errors, errors
    assert recorded(bus, scn.dt).equals(simulate(scn))
    assert summary["agent_2.delayed_messages"] == 2 * scn.steps
