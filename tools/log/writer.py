"""The MCAP file a run is recorded in: one channel per Zenoh key, raw msgpack bytes.

Layout (docs/wire.md, "The log"): a channel's topic is the Zenoh key; its message encoding is
``msgpack``; its schema is named after the message kind (``shoal.AgentState`` …) with the empty
encoding (msgpack has no schema language); the channel metadata holds ``zenoh_key`` and ``run``.
Times are integer nanoseconds. The scenario is an attachment (``scenario.yaml``) and a metadata
record (``scenario``); the summary is a metadata record (``summary``).

Crash safety: chunks are small (64 KiB) and the writer flushes at least every half second, so
a SIGKILL loses at most the last half second or 64 KiB of messages, whichever is less; SIGINT
and SIGTERM finish the file properly.
"""

from __future__ import annotations

import time
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

from mcap.writer import CompressionType, Writer

CHUNK_BYTES = 64 * 1024
FLUSH_EVERY_S = 0.5
SCHEMAS = {
    "sensing": "shoal.Sensing",
    "state": "shoal.AgentState",
    "cmd": "shoal.Report",
    "tick": "shoal.TickRecord",
    "event": "shoal.Event",
    "summary": "shoal.Summary",
    "scenario": "shoal.Scenario",
}


class McapLog:
    """An MCAP writer for one run; a context manager whose exit finishes the file."""

    def __init__(self, path: Path, *, run: str, overwrite: bool = False) -> None:
        """Raises FileExistsError if ``path`` exists, unless ``overwrite``: two runs given the
        same file must not both write it (created exclusively, so even at the same instant)."""
        self.path = path
        self.run = run
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file: BinaryIO = path.open("wb" if overwrite else "xb")
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library="shoal")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self._last_flush = time.monotonic()
        self.messages = 0
        self._finished = False
        self._scenario_attached = False

    def __enter__(self) -> McapLog:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.finish()

    def _channel(self, key: str) -> int:
        if key not in self._channels:
            kind = key.rsplit("/", 1)[-1]
            name = SCHEMAS.get(kind, "shoal.Unknown")
            if name not in self._schemas:
                self._schemas[name] = self._writer.register_schema(name, "", b"")
            self._channels[key] = self._writer.register_channel(
                key, "msgpack", self._schemas[name], {"zenoh_key": key, "run": self.run}
            )
        return self._channels[key]

    def add(self, key: str, payload: bytes, time_ns: int) -> None:
        """Record one message as it came off the bus."""
        channel = self._channel(key)
        seq = self._sequence.get(channel, 0)
        self._sequence[channel] = seq + 1
        self._writer.add_message(channel, time_ns, payload, time_ns, seq)
        self.messages += 1

    def flush_if_due(self) -> None:
        """Flush chunk and file if the last flush is ``FLUSH_EVERY_S`` old (the writer's owner
        calls this at least that often: it bounds what a SIGKILL loses)."""
        if time.monotonic() - self._last_flush >= FLUSH_EVERY_S:
            self._writer.flush()
            self._file.flush()
            self._last_flush = time.monotonic()

    @property
    def has_scenario(self) -> bool:
        return self._scenario_attached

    def attach_scenario(self, name: str, yaml_text: str, time_ns: int) -> None:
        self._scenario_attached = True
        self._writer.add_attachment(
            time_ns, time_ns, "scenario.yaml", "application/yaml", yaml_text.encode()
        )
        self._writer.add_metadata("scenario", {"name": name, "run": self.run, "yaml": yaml_text})

    def add_summary(self, summary: dict[str, Any]) -> None:
        self._writer.add_metadata("summary", {k: str(v) for k, v in summary.items()})

    def finish(self) -> None:
        """Write the summary section and footer; safe to call more than once."""
        if self._finished:
            return
        self._finished = True
        try:
            self._writer.finish()
        finally:
            self._file.close()
