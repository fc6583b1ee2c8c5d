"""Late messages, for fault injection (``--delay-ms``, ``--jitter-ms``): an agent's outgoing states
and commands held back by a seeded random delay before they go on the bus, as a slow or
congested radio link delivers them. Unlike agent/delivery.py this has a clock and a thread: it
is I/O. A lockstep run stays exact under any delay (it only waits longer); a realtime run gets
commands that arrive ticks late, which the world holds (and, with its referee, filters again)."""

from __future__ import annotations

import heapq
import random
import threading
import time
from typing import Protocol


class Outbox(Protocol):
    def put(self, payload: bytes) -> None: ...


class Delayer:
    """Holds each outgoing message back by ``delay`` ± ``jitter`` seconds before it goes out
    (uniform, drawn from a source seeded with (seed, agent id)), for fault injection: late
    messages, reordered when the jitter exceeds their spacing, as a lossy radio link has them.

    Its own thread sends each message at its release time; with no delay and no jitter,
    :meth:`put` sends at once on the caller's thread. :meth:`close` drops what is still held
    (the run is over). ``held`` counts the messages delayed, ``longest`` the longest delay, s.
    """

    def __init__(self, delay: float, jitter: float, seed: int, agent_id: int) -> None:
        if delay < 0 or jitter < 0 or jitter > delay:
            raise ValueError(f"need 0 ≤ jitter ≤ delay, got delay {delay} s, jitter {jitter} s")
        self.delay, self.jitter = delay, jitter
        self.held = 0
        self.longest = 0.0
        self._rng = random.Random(f"shoal-delay-{seed}-{agent_id}")
        self._queue: list[tuple[float, int, Outbox, bytes]] = []
        self._wake = threading.Condition()
        self._closed = False
        self._thread: threading.Thread | None = None
        if delay > 0:
            self._thread = threading.Thread(target=self._send, name="delayer", daemon=True)
            self._thread.start()

    def put(self, out: Outbox, payload: bytes) -> None:
        if self._thread is None:
            out.put(payload)
            return
        wait = self.delay + self._rng.uniform(-self.jitter, self.jitter)
        with self._wake:
            self.held += 1
            self.longest = max(self.longest, wait)
            heapq.heappush(self._queue, (time.monotonic() + wait, self.held, out, payload))
            self._wake.notify()

    def _send(self) -> None:
        while True:
            with self._wake:
                while not self._closed and (
                    not self._queue or self._queue[0][0] > time.monotonic()
                ):
                    left = self._queue[0][0] - time.monotonic() if self._queue else None
                    self._wake.wait(timeout=left)
                if self._closed:
                    return
                _at, _n, out, payload = heapq.heappop(self._queue)
            out.put(payload)

    def close(self) -> None:
        with self._wake:
            self._closed = True
            self._queue.clear()
            self._wake.notify()
        if self._thread is not None:
            self._thread.join(timeout=1.0)

    def undeclare(self) -> None:
        """As the bus's handles: the agent closes it with what it declared (bus/seam.py)."""
        self.close()
