"""The live view: a run's Foxglove views served over a Foxglove WebSocket server while it runs.

``shoal run --live`` opens a :class:`LiveView` in the supervisor, whose monitor already receives
every tick record; it hands each one (and each world event) to :meth:`LiveView.tick` /
:meth:`LiveView.event`, which only append it to a bounded queue and return (``shoal replay
--live`` hands over a log's records the same way, each when it is due: tools/log/replay.py). A
thread of its own turns the queue into the export's views (tools/foxglove/stream.py) and logs
them on ``foxglove-sdk`` channels. The server (its Rust core) queues per client and drops the oldest
message for a client that does not keep up, so a slow viewer costs the run nothing.

What it costs without a viewer: decoding the records (trails need their points). With one: the
views of the channels someone subscribed to, and no others; the scene at most ``frame_hz`` times
and the trails ``trail_hz`` times per second of wall clock, whatever the run's speed; the metrics
at most ``plot_rate`` ticks' worth per second of wall clock (of the ticks the export writes, the
latest of each ``1/plot_rate`` s: every one in a run slower than that, and the run's last),
computed in one batch per frame; the ticks in between are never computed. If the thread falls
behind, the queue keeps the newest ``BACKLOG`` records and drops older ones (``dropped``).

The messages are JSON on the export's topics with the export's schemas (Foxglove's own JSON
schemas for ``foxglove.*``): a live message and the exported one of the same tick are the same
bytes but for the timestamps, and one Foxglove layout serves both (docs/foxglove.md).
"""

from __future__ import annotations

import errno
import json
import threading
import time
import urllib.parse
from collections import deque
from types import TracebackType
from typing import Literal

import foxglove
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.tools.foxglove.front import Front, hint
from shoal.tools.foxglove.plots import TOPICS as METRICS
from shoal.tools.foxglove.plots import topics_of
from shoal.tools.foxglove.stream import Stream
from shoal.tools.foxglove.views import (
    MOVING,
    STATIC,
    TOPICS,
    TRAILS,
    View,
    ViewOptions,
    schema_text,
)
from shoal.world.scenario import Scenario

APP = "https://app.foxglove.dev"
DEFAULT_PORT = 8765  # Foxglove's own default for a WebSocket connection
FRAME_HZ = 30.0  # wall clock: agents, frames and graph, at most
TRAIL_HZ = 2.0  # wall clock: the trails (messages that grow with the run), at most
# Wall clock: the metrics, ticks a second at most (a message per topic each). As the scene: a
# Plot panel gains nothing from more points than frames, and the plots keep up with the scene's
# tick; a slower run (realtime at dt 0.05 s: 20 ticks/s) still has every tick plotted.
PLOT_RATE = FRAME_HZ
BACKLOG = 4096  # records waiting for the publisher thread; the oldest go beyond it
FLUSH_S = 0.5  # s for the server to send the last cycle's messages before it stops
STOP_WAIT_S = 1.0  # for the server to close its connections at the end
# Compact UTF-8 JSON, as the export writes it; a NaN (not JSON) is an error.
_ENCODE = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, check_circular=False
).encode


class LiveError(RuntimeError):
    """The server cannot start (its port is taken, its host is not ours)."""


class _Subscriptions(ServerListener):
    """Which topics some client subscribes to (foxglove-sdk calls these from its own thread)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._count: dict[str, int] = {}
        self.static_due = False  # a client subscribed to a layer drawn once: draw it again
        self.viewer = threading.Event()  # set at the first subscription

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        with self._lock:
            self._count[channel.topic] = self._count.get(channel.topic, 0) + 1
            self.static_due |= channel.topic in STATIC
        self.viewer.set()

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        with self._lock:
            self._count[channel.topic] = max(self._count.get(channel.topic, 0) - 1, 0)

    def any(self, *topics: str) -> bool:
        with self._lock:
            return any(self._count.get(t, 0) > 0 for t in topics)

    def redraw_static(self) -> None:
        with self._lock:
            self.static_due = True

    def take_static(self) -> bool:
        with self._lock:
            due, self.static_due = self.static_due, False
            return due


class LiveView:
    """A Foxglove WebSocket server for one run; a context manager (the server is up inside)."""

    def __init__(
        self,
        scenario: Scenario,
        run_id: str,
        *,
        host: str = "127.0.0.1",
        port: int = DEFAULT_PORT,
        options: ViewOptions | None = None,
        frame_hz: float = FRAME_HZ,
        trail_hz: float = TRAIL_HZ,
        plot_rate: float = PLOT_RATE,
        source: str = "live",
    ) -> None:
        self.host, self.port = host, port
        self.stream = Stream(scenario, time.time_ns(), options or ViewOptions(), plot_rate)
        self.frame_s, self.trail_s = 1.0 / frame_hz, 1.0 / trail_hz
        self.dropped = 0  # records the publisher thread was too late for
        self.skipped = 0  # records on our keys that did not decode or fit the scenario
        self.published = 0  # messages handed to the server
        self._queue: deque[tuple[Literal["tick", "event"], int, bytes]] = deque(maxlen=BACKLOG)
        self._subs = _Subscriptions()
        self._context = foxglove.Context()
        meta = {"run": run_id, "source": source}
        has = topics_of(scenario)
        self._channels = {
            topic: foxglove.Channel(
                topic,
                schema=foxglove.Schema(name=name, encoding="jsonschema", data=schema_text(name)),
                message_encoding="json",
                context=self._context,
                metadata=meta,
            )
            for topic, name in TOPICS.items()
            if topic not in METRICS or topic in has
        }  # as in the export: no channel that would have nothing to say
        self._server: WebSocketServer | None = None
        self._front: Front | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="shoal live view", daemon=True)
        self._fresh = False  # a record taken since the scene was last drawn
        self._trailed = 0.0  # monotonic time the trails were last drawn

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    @property
    def app_url(self) -> str | None:
        """A link that opens this server in Foxglove's web app (None before it is up)."""
        if self._server is None:
            return None
        return f"{APP}?ds=foxglove-websocket&ds.url={urllib.parse.quote(self.url, safe='')}"

    def __enter__(self) -> LiveView:
        """The SDK's server on loopback, any free port; in front of it, on the port asked for,
        the front (tools/foxglove/front.py) that also answers a browser."""
        try:
            self._server = foxglove.start_server(
                name=f"shoal {self.stream.scenario.name}",
                host="127.0.0.1",
                port=0,
                server_listener=self._subs,
                context=self._context,
            )
        except RuntimeError as exc:
            raise LiveError(str(exc).removeprefix("FoxgloveError: ")) from None
        try:
            self._front = Front(self.host, self.port, self._server.port, self._hint)
        except OSError as exc:
            self._server.stop()
            self._server = None
            why = exc.strerror or str(exc)
            if exc.errno == errno.EADDRINUSE:
                why = f"{self.host}:{self.port} is in use; pick another port with --live-port"
            raise LiveError(why) from None
        self.port = self._front.port  # the port taken, if asked for any (0)
        self._front.__enter__()
        self._thread.start()
        return self

    def _hint(self) -> str:
        return hint(self.url, self.app_url)

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._stop.set()
        self._thread.join()
        if kind is None:
            self._cycle(final=True)  # the run's last state, drawn in full
            if self._subs.any(*self._channels):
                # The server has no flush: what it still queues when stop() begins is lost (a
                # replay ends right after its last record, and lost its last ticks' views).
                time.sleep(FLUSH_S)
        if self._front is not None:
            self._front.close()
        if self._server is not None:
            # stop() waits for each client to close, and a slow one reads its backlog first:
            # stopping goes on without us after STOP_WAIT_S (the process's exit ends it).
            stopping = threading.Thread(target=self._server.stop, name="stop", daemon=True)
            stopping.start()
            stopping.join(STOP_WAIT_S)

    def tick(self, ns: int, payload: bytes) -> None:
        """A tick record as it arrived (wall clock ``ns``): queued, never waited for."""
        self._put("tick", ns, payload)

    def event(self, ns: int, payload: bytes) -> None:
        """A world event as it arrived: queued, never waited for."""
        self._put("event", ns, payload)

    def wait_for_viewer(self, timeout: float | None = None) -> bool:
        """Until some client subscribes to a channel (``shoal replay --live`` plays the run
        for someone); False if ``timeout`` s passed first."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._subs.viewer.wait(0.2):  # short waits: a signal still ends the process
            if deadline is not None and time.monotonic() >= deadline:
                return False
        return True

    def _put(self, kind: Literal["tick", "event"], ns: int, payload: bytes) -> None:
        if len(self._queue) == BACKLOG:
            self.dropped += 1
        self._queue.append((kind, ns, payload))

    def _serve(self) -> None:
        while not self._stop.wait(self.frame_s):  # pacing at the frame rate
            self._cycle()

    def _cycle(self, *, final: bool = False) -> None:
        """Take what has arrived; draw what is subscribed to and due."""
        s = self.stream
        while self._queue:
            kind, ns, payload = self._queue.popleft()
            try:
                if kind == "event":
                    self._publish([s.event(ns, codec.decode_event(payload))])
                    continue
                record = codec.decode_tick(payload)
            except DecodeError:
                self.skipped += 1
                continue
            if not s.fits(record):
                self.skipped += 1
                continue
            if s.latest is not None and record.tick < s.latest.record.tick:
                # The run starts again (shoal replay --loop): so do its views and trails.
                s = self.stream = Stream(s.scenario, ns, s.options, s.plot_rate)
                self._subs.redraw_static()
            self._publish(s.take(ns, record))
            self._fresh = True
        if self._subs.take_static():
            self._publish(s.static())
        if self._fresh and self._subs.any(*MOVING):
            self._publish(s.scene())
            self._fresh = False
        now = time.monotonic()
        if (final or now - self._trailed >= self.trail_s) and self._subs.any(TRAILS):
            self._publish(s.trails())
            self._trailed = now
        if self._subs.any(*METRICS):
            self._publish(s.metrics(final=final))
        else:
            s.skip_metrics()

    def _publish(self, views: list[View]) -> None:
        for v in views:
            channel = self._channels.get(v.topic)
            if channel is not None and self._subs.any(v.topic):
                channel.log(_ENCODE(v.message).encode(), log_time=v.ns)
                self.published += 1
