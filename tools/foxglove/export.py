"""Writing a run's Foxglove views (tools/foxglove/views.py) into an MCAP file beside its raw log.

Why a sibling file, ``X.foxglove.mcap`` next to ``X.mcap``, and not the views inside the raw log:

- Foxglove cannot decode msgpack, and it reports every channel it cannot decode as an error when
  it opens a file (one per agent and key: 19 for five agents). The views file holds only what
  Foxglove draws, and opens clean.
- The raw log stays byte for byte what the logger wrote. Nothing rewrites it, so ``shoal
  verify``, ``replay`` and ``recover`` see the same file, and an export that fails or is
  interrupted cannot damage it (the views file is written as ``OUT.part``, then renamed).
- It is cheap: only the world's tick, event, scenario and summary channels are read, through the
  raw file's index; the agents' traffic (most of the file) is never decompressed or copied.

The views file explains itself: the scenario attachment and the ``scenario`` and ``summary``
metadata records as the logger wrote them, plus ``foxglove`` metadata naming its source.
"""

from __future__ import annotations

import json
import os
import struct
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Chunk, ChunkIndex
from mcap.stream_reader import get_chunk_data_stream
from mcap.writer import CompressionType, Writer

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.messages import Event, PlantRecord, TickRecord
from shoal.bus.runtime import warn
from shoal.tools.foxglove.views import (
    PHYSICS_TOPICS,
    SCHEMAS_VERSION,
    TOPICS,
    RunLog,
    ViewOptions,
    schema_text,
    views,
)
from shoal.tools.log.reader import recorded_scenario
from shoal.tools.log.salvage import LogError, check_log
from shoal.tools.progress import advance_to, progress_bar
from shoal.world.errors import ScenarioError

CHUNK_BYTES = 1024 * 1024  # mcap's default: a reader (Foxglove) seeks in steps of one chunk
SUFFIX = ".foxglove.mcap"
WORLD_KINDS = ("tick", "event", "scenario", "summary", "plant")
_U16, _U64 = struct.Struct("<H"), struct.Struct("<Q")
# Compact UTF-8 JSON; a NaN or infinity (not JSON) is an error, not a silent "NaN" token.
_ENCODE = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, check_circular=False
).encode


class ExportError(ValueError):
    """The log cannot be turned into views (unfinished, no scenario, no tick records)."""


@dataclass
class Source:
    """A raw log's world channels, read back."""

    run: str = ""
    scenario: dict[str, Any] = field(default_factory=dict)  # the scenario document's body
    scenario_ns: int = 0
    summary: dict[str, Any] | None = None
    ticks: dict[int, tuple[int, TickRecord]] = field(default_factory=dict)  # tick → (ns, record)
    events: list[tuple[int, Event]] = field(default_factory=list)
    plants: dict[int, PlantRecord] = field(default_factory=dict)  # tick → a physics plant's
    skipped: int = 0  # messages on the world's keys that did not decode or did not fit


@dataclass(frozen=True)
class ExportResult:
    out: Path
    messages: int
    ticks: int
    seconds: float
    bytes: int


def sibling(raw: Path) -> Path:
    """``runs/x.mcap`` → ``runs/x.foxglove.mcap``: where ``shoal run`` puts the views."""
    stem = raw.name.removesuffix(".mcap")
    return raw.with_name(stem + SUFFIX)


def read_source(path: Path) -> Source:
    """The world's channels of a finished raw log."""
    try:
        check_log(path)
    except LogError as exc:
        raise ExportError(str(exc)) from None
    src = Source()
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
        assert summary is not None  # check_log: finished
        wanted = {
            c.id: c
            for c in summary.channels.values()
            if c.message_encoding == "msgpack" and _world_kind(c.topic)
        }
        for channel_id, ns, data in _messages(f, summary.chunk_indexes, set(wanted)):
            channel = wanted[channel_id]
            src.run = src.run or channel.metadata.get("run", "")
            _take(src, _world_kind(channel.topic), data, ns)
    src.events.sort(key=lambda e: e[0])
    return src


def _world_kind(topic: str) -> str:
    """ "tick" for ``shoal/<run>/world/tick`` (and event, scenario, summary); else ""."""
    parent, _, kind = topic.rpartition("/")
    return kind if parent.endswith("/world") and kind in WORLD_KINDS else ""


def _messages(
    f: BinaryIO, chunks: list[ChunkIndex], wanted: set[int]
) -> Iterator[tuple[int, int, bytes]]:
    """(channel id, log time, payload) of the messages on ``wanted`` channels, in file order.

    mcap's reader builds a record object for every message of a chunk it reads; the world's
    channels carry one message in sixteen, so this walks each decompressed chunk and unpacks
    only theirs (a Message record: opcode 0x05, u64 length, then channel u16, sequence u32,
    log time u64, publish time u64, payload). 30 times faster on a long run. Every shoal
    writer (logger, recover) puts its messages in chunks, which is all this reads.
    """
    for index in chunks:
        offsets = index.message_index_offsets  # empty if the writer kept no message index
        if offsets and not wanted & offsets.keys():
            continue  # no message of ours in this chunk
        f.seek(index.chunk_start_offset + 1 + 8)  # past the chunk record's opcode and length
        stream, size = get_chunk_data_stream(Chunk.read(ReadDataStream(f)))
        data = stream.read(size)
        pos = 0
        while pos < size:
            (length,) = _U64.unpack_from(data, pos + 1)
            body = pos + 9
            if data[pos] == Opcode.MESSAGE:
                (channel,) = _U16.unpack_from(data, body)
                if channel in wanted:
                    (log_time,) = _U64.unpack_from(data, body + 6)
                    yield channel, log_time, bytes(data[body + 22 : body + length])
            pos = body + length


def _take(src: Source, kind: str, data: bytes, ns: int) -> None:
    try:
        if kind == "tick":
            record = codec.decode_tick(data)
            src.ticks.setdefault(record.tick, (ns, record))
        elif kind == "event":
            src.events.append((ns, codec.decode_event(data)))
        elif kind == "plant":
            plant = codec.decode_plant(data)
            src.plants.setdefault(plant.tick, plant)
        elif kind == "scenario" and not src.scenario:
            src.scenario, src.scenario_ns = codec.decode_document("scenario", data), ns
        elif kind == "summary":
            src.summary = codec.decode_document("summary", data)
    except DecodeError:
        src.skipped += 1  # someone else's garbage on the run's keys


def run_log(path: Path, src: Source) -> RunLog:
    """The views' input: the recorded scenario and the tick records that fit it."""
    if not src.scenario:
        raise ExportError(f"{path}: no scenario document in the log: nothing to draw the run in")
    try:
        scenario = recorded_scenario(src.scenario)
    except ScenarioError as exc:
        raise ExportError(f"{path}: the recorded scenario does not load: {exc}") from None
    ticks = []
    for k in sorted(src.ticks):
        ns, r = src.ticks[k]
        if len(r.positions) == scenario.n and all(len(p) == scenario.dim for p in r.positions):
            ticks.append((ns, r))
        else:
            src.skipped += 1
    if not ticks:
        raise ExportError(f"{path}: no tick records")
    plants = {k: p for k, p in src.plants.items() if len(p.bodies) == scenario.n}
    src.skipped += len(src.plants) - len(plants)
    return RunLog(scenario, src.scenario_ns or ticks[0][0], ticks, src.events, plants)


def export(
    raw: Path,
    out: Path | None = None,
    *,
    options: ViewOptions | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ExportResult:
    """Write the views of ``raw`` to ``out`` (default: its sibling). ``progress(done, total)``
    counts tick records."""
    began = time.monotonic()
    options = options or ViewOptions()
    out = out or sibling(raw)
    if out.resolve() == raw.resolve():
        raise ExportError(f"{out}: the views go to another file than the raw log")
    src = read_source(raw)
    run = run_log(raw, src)
    total = len(run.ticks)
    part = out.with_name(out.name + ".part")
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with part.open("wb") as f:
            messages = _write(
                f, raw, src, run, options, (lambda k: progress(k + 1, total)) if progress else None
            )
            f.flush()
            os.fsync(f.fileno())
        os.replace(part, out)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    return ExportResult(out, messages, total, time.monotonic() - began, out.stat().st_size)


def _write(
    f: Any,
    raw: Path,
    src: Source,
    run: RunLog,
    options: ViewOptions,
    progress: Callable[[int], None] | None,
) -> int:
    writer = Writer(f, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
    writer.start(profile="", library="shoal export")
    schemas: dict[str, int] = {}
    channels: dict[str, int] = {}
    sequence: dict[int, int] = {}
    meta = {"run": src.run, "source": raw.name}
    count = 0
    for view in views(run, options, progress):
        channel = channels.get(view.topic)
        if channel is None:
            name = {**TOPICS, **PHYSICS_TOPICS}[view.topic]
            if name not in schemas:
                schemas[name] = writer.register_schema(name, "jsonschema", schema_text(name))
            channel = channels[view.topic] = writer.register_channel(
                view.topic, "json", schemas[name], meta
            )
        seq = sequence.get(channel, 0)
        sequence[channel] = seq + 1
        writer.add_message(channel, view.ns, _ENCODE(view.message).encode(), view.ns, seq)
        count += 1
    _documents(writer, raw, src, run, options)
    writer.finish()  # type: ignore[no-untyped-call]  # mcap's Writer.finish has no annotations
    return count


def _documents(writer: Writer, raw: Path, src: Source, run: RunLog, options: ViewOptions) -> None:
    yaml_text = str(src.scenario.get("yaml", ""))
    ns = run.start_ns
    writer.add_attachment(ns, ns, "scenario.yaml", "application/yaml", yaml_text.encode())
    name = str(src.scenario.get("name"))
    writer.add_metadata("scenario", {"name": name, "run": src.run, "yaml": yaml_text})
    if src.summary is not None:
        writer.add_metadata("summary", {k: str(v) for k, v in src.summary.items()})
    writer.add_metadata(
        "foxglove",
        {
            "source": raw.name,
            "schemas": f"@foxglove/schemas {SCHEMAS_VERSION}",
            "time": "log time of the raw record each view shows (ns since the epoch)",
            "scene_hz": str(options.scene_hz),
            "trail_hz": str(options.trail_hz),
            "plot_hz": str(options.plot_hz),
            "skipped": str(src.skipped),
        },
    )


def with_progress(
    raw: Path, out: Path | None, options: ViewOptions, *, show: bool = True
) -> ExportResult:
    """Export with a progress bar on stderr (shown only on a terminal, as other commands do)."""
    with progress_bar(1, "foxglove views", show=show) as bar:
        return export(raw, out, options=options, progress=lambda k, n: advance_to(bar, k, n))


def export_beside(raw: Path, *, progress: bool) -> ExportResult | None:  # replaces old views
    """``shoal run``'s last step. A failure is reported and not fatal: the raw log is complete
    and untouched either way, and ``shoal export`` can be run on it later."""
    try:
        return with_progress(raw, None, ViewOptions(), show=progress)
    except Exception as exc:  # any bug here must not turn a good run into a failed one
        warn(f"shoal run: no Foxglove views ({type(exc).__name__}: {exc}); the log is complete")
        return None
