"""The floor a lockstep run is held against: the same processes exchanging the same messages
over the same router, with no control math, no codec and no log file.

Per tick the floor world sends every agent a sensing-sized payload, each floor agent answers its
neighbours with a state-sized payload and, once it has every neighbour's, the world with a
command-sized payload; the world then sends a tick-record-sized payload. A floor recorder
subscribes to the run's whole key space and a floor monitor to the tick records, as the logger
and ``shoal run`` do. Payloads carry the tick in their first 4 bytes.
"""

from __future__ import annotations

import math
import struct
import time
from collections import deque

import zenoh

from shoal.bus.keys import Keys, agent_of
from shoal.bus.links import collect, publisher, subscribe, watch_presence
from shoal.bus.runtime import ArrivalKind, Inbox, announce_ready
from shoal.tools.log.logger import BATCH_S

_TICK = struct.Struct("<i")


def payload(tick: int, size: int) -> bytes:
    return _TICK.pack(tick) + bytes(max(size - _TICK.size, 0))


def tick_of(data: bytes) -> int:
    return int(_TICK.unpack_from(data)[0])


def floor_world(
    session: zenoh.Session,
    *,
    run: str,
    agents: int,
    ticks: int,
    sizes: dict[str, int],
    period: float = 0.0,
) -> dict[str, float]:
    """Tick the floor: in lockstep (``period`` 0) each tick ends once every agent's command is
    in; with a ``period`` (s) each tick ends on the wall clock, as a realtime run's world does
    (world/process.py's _Clock): a command not in by then is a missed deadline, and the time
    from sending a tick's sensing to each command of that tick is its latency."""
    keys = Keys(run)
    inbox = Inbox()
    held = [
        subscribe(session, keys.commands, inbox),
        watch_presence(session, keys.alive_everyone, inbox),
    ]
    out = {i: publisher(session, keys.sensing(i)) for i in range(1, agents + 1)}
    tick_out = publisher(session, keys.tick)
    token = session.liveliness().declare_token(keys.alive_world)
    wanted = {keys.alive_agent(i) for i in out} | {
        keys.alive_process(p) for p in ("logger", "monitor")
    }
    up: set[str] = set()
    while not wanted <= up:
        a = inbox.wait()
        if a.kind == ArrivalKind.UP:
            up.add(a.key)
    announce_ready("floor ticking")  # a benchmark opens its CPU window here
    start = time.monotonic()
    if period > 0:
        result = _realtime(inbox, out, tick_out, agents, ticks, sizes, period)
    else:
        for k in range(ticks):
            for i in out:
                out[i].put(payload(k, sizes["sensing"]))
            answered: set[int] = set()
            while len(answered) < agents:
                a = inbox.wait()
                sender = agent_of(a.key)
                if a.kind == ArrivalKind.DATA and tick_of(a.payload) == k and sender is not None:
                    answered.add(sender)
            tick_out.put(payload(k, sizes["tick"]))
        result = {}
    wall = time.monotonic() - start
    del held, token
    return {"ticks": ticks, "ticks_per_s": ticks / wall, **result}


def _realtime(
    inbox: Inbox,
    out: dict[int, zenoh.Publisher],
    tick_out: zenoh.Publisher,
    agents: int,
    ticks: int,
    sizes: dict[str, int],
    period: float,
) -> dict[str, float]:
    sent_at: dict[int, float] = {}
    heard: dict[int, set[int]] = {}
    latencies: list[float] = []
    missed = overruns = 0
    deadline = time.monotonic()
    for k in range(ticks):
        now = time.monotonic()
        sent_at[k] = now
        sent_at.pop(k - 64, None)
        heard.pop(k - 64, None)
        deadline += period
        if deadline < now:
            overruns += 1
            deadline = now + period
        for i in out:
            out[i].put(payload(k, sizes["sensing"]))
        while (left := deadline - time.monotonic()) > 0:
            a = inbox.get(timeout=left)
            if a is None:
                break
            sender = agent_of(a.key)
            if a.kind != ArrivalKind.DATA or sender is None:
                continue
            t = tick_of(a.payload)
            if t in sent_at and sender not in heard.setdefault(t, set()):
                heard[t].add(sender)
                latencies.append(time.monotonic() - sent_at[t])
        missed += agents - len(heard.get(k, ()))
        tick_out.put(payload(k, sizes["tick"]))
    lat = sorted(latencies)
    return {
        "latency_p50_ms": round(_quantile(lat, 0.50) * 1e3, 3),
        "latency_p99_ms": round(_quantile(lat, 0.99) * 1e3, 3),
        "missed_deadlines": missed,
        "overruns": overruns,
    }


def _quantile(ordered: list[float], q: float) -> float:
    """Linear-interpolated quantile of sorted values (numpy's default), nan for none."""
    if not ordered:
        return math.nan
    x = q * (len(ordered) - 1)
    lo = math.floor(x)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (x - lo)


def floor_agent(
    session: zenoh.Session, *, run: str, agent_id: int, neighbours: list[int], sizes: dict[str, int]
) -> None:
    keys = Keys(run)
    inbox = Inbox()
    held = [subscribe(session, keys.sensing(agent_id), inbox)]
    held += [subscribe(session, keys.state(j), inbox) for j in neighbours]
    held.append(watch_presence(session, keys.alive_world, inbox))
    state_out = publisher(session, keys.state(agent_id))
    cmd_out = publisher(session, keys.command(agent_id))
    token = session.liveliness().declare_token(keys.alive_agent(agent_id))
    heard: dict[int, set[int]] = {}
    pending = -1  # the tick sensed and not yet answered; -1 for none
    while True:
        a = inbox.wait()
        if a.kind == ArrivalKind.DOWN:
            break
        if a.kind != ArrivalKind.DATA:
            continue
        k = tick_of(a.payload)
        if a.key.endswith("/sensing"):
            state_out.put(payload(k, sizes["state"]))
            pending = k
        else:  # a neighbour's state
            heard.setdefault(k, set()).add(agent_of(a.key) or 0)
        if pending >= 0 and len(heard.get(pending, ())) == len(neighbours):
            cmd_out.put(payload(pending, sizes["cmd"]))
            heard.pop(pending, None)
            pending = -1
    del held, token


def floor_listener(session: zenoh.Session, *, run: str, role: str) -> int:
    """The recorder (role "logger": every key, queued by the callback and drained every
    ``BATCH_S``, as the logger does) or the monitor (role "monitor": tick records, one wakeup
    each, as ``shoal run``'s progress bar); counts messages until the world's token vanishes."""
    keys = Keys(run)
    inbox = Inbox()
    received: deque[tuple[str, bytes, int]] = deque()
    if role == "logger":
        data = collect(session, keys.everything, received)
    else:
        data = subscribe(session, keys.tick, inbox)
    held = [data, watch_presence(session, keys.alive_world, inbox)]
    token = session.liveliness().declare_token(keys.alive_process(role))
    announce_ready(f"floor {role}")
    count, seen_world = 0, False
    while True:
        a = inbox.get(timeout=BATCH_S) if role == "logger" else inbox.wait()
        while received:
            received.popleft()
            count += 1
        if a is None:
            continue
        if a.kind == ArrivalKind.UP:
            seen_world = True
        elif a.kind == ArrivalKind.DOWN and seen_world:
            break
        elif a.kind == ArrivalKind.DATA:
            count += 1
    del held, token
    return count
