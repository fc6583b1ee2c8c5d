"""Inspecting a run's MCAP file, and salvaging one whose writer was killed.

A finished file has a summary section; an unfinished one (a SIGKILLed logger) ends wherever the
writer stopped. Both are read here by a linear scan that stops at the first incomplete record,
so everything in complete chunks is kept: the logger's 64 KiB chunks, flushed every 0.5 s, bound
what is lost (docs/wire.md, "The log").
"""

from __future__ import annotations

import contextlib
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.records import Attachment, Channel, McapRecord, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from shoal.bus import codec
from shoal.bus.errors import DecodeError

MAGIC = b"\x89MCAP0\r\n"  # what every MCAP file starts with (and a finished one ends with)


class LogError(ValueError):
    """A file that cannot be read as a run's log; the message names it and says what to do."""


def check_log(path: Path, *, finished: bool = True) -> None:
    """Raise :class:`LogError` unless ``path`` is a readable MCAP file and, with ``finished``,
    a finished one (an unfinished log, from a killed logger, needs ``shoal recover`` first)."""
    try:
        with path.open("rb") as f:
            head = f.read(len(MAGIC))
    except OSError as exc:
        raise LogError(f"{path}: cannot be read ({exc.strerror})") from None
    if head != MAGIC:
        what = "empty" if not head else "it does not start with MCAP's magic bytes"
        raise LogError(f"{path}: not an MCAP file ({what})")
    if finished and not is_finished(path):
        raise LogError(
            f"{path}: not a finished MCAP file (a killed logger?); "
            f"`shoal recover {path} -o FIXED.mcap` first, then use FIXED.mcap"
        )


def is_finished(path: Path) -> bool:
    """True if the file has its summary section (the writer called finish())."""
    try:
        with path.open("rb") as f:
            return make_reader(f).get_summary() is not None
    except Exception:  # mcap raises several types on a cut file
        return False


@dataclass
class Scan:
    """What a linear scan found; ``stopped`` says why it ended early, if it did."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    counts: Counter[int] = field(default_factory=Counter)
    first_ns: int | None = None
    last_ns: int | None = None
    attachments: list[str] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    stopped: str | None = None


def records(path: Path, scan: Scan) -> Iterator[McapRecord]:
    """Every complete record in file order; a broken tail ends the iteration (noted in
    ``scan.stopped``) instead of raising."""
    with path.open("rb") as f:
        stream = StreamReader(f, record_size_limit=64 * 1024 * 1024).records
        while True:
            try:
                record = next(stream)
            except StopIteration:
                return
            except Exception as exc:  # truncated record, garbage where the footer should be
                scan.stopped = f"{type(exc).__name__} after the last complete record"
                return
            _note(scan, record)
            yield record


def _note(scan: Scan, record: McapRecord) -> None:
    if isinstance(record, Schema):
        scan.schemas[record.id] = record
    elif isinstance(record, Channel):
        scan.channels[record.id] = record
    elif isinstance(record, Message):
        scan.counts[record.channel_id] += 1
        t = record.log_time
        scan.first_ns = t if scan.first_ns is None else min(scan.first_ns, t)
        scan.last_ns = t if scan.last_ns is None else max(scan.last_ns, t)
    elif isinstance(record, Attachment):
        scan.attachments.append(record.name)
    elif isinstance(record, Metadata):
        scan.metadata[record.name] = dict(record.metadata)


def inspect_file(path: Path) -> dict[str, Any]:
    """Channels, message counts, duration, scenario, summary and whether the file is finished;
    LogError if it is not an MCAP file at all."""
    check_log(path, finished=False)
    scan = Scan()
    summary: dict[str, Any] | None = None
    for record in records(path, scan):
        if summary is None and isinstance(record, Message):
            topic = scan.channels[record.channel_id].topic
            if topic.endswith("/world/summary"):
                with contextlib.suppress(DecodeError):  # someone else's garbage on the key
                    summary = codec.decode_document("summary", record.data)
    duration = (
        (scan.last_ns - scan.first_ns) / 1e9
        if scan.first_ns is not None and scan.last_ns is not None
        else 0.0
    )
    scenario = scan.metadata.get("scenario", {})
    return {
        "file": str(path),
        "finished": is_finished(path),
        "stopped": scan.stopped,
        "messages": sum(scan.counts.values()),
        "duration_s": round(duration, 3),
        "channels": {scan.channels[c].topic: n for c, n in sorted(scan.counts.items())},
        "scenario": scenario.get("name"),
        "run": scenario.get("run"),
        "attachments": scan.attachments,
        # the world's document, with its numbers as numbers (the MCAP metadata record, the
        # other copy, holds strings only)
        "summary": summary if summary is not None else scan.metadata.get("summary"),
    }


def recover(src: Path, dst: Path) -> dict[str, Any]:
    """Copy every complete record of ``src`` into a finished file ``dst``; LogError (and
    nothing written) if ``src`` is not an MCAP file at all."""
    check_log(src, finished=False)
    scan = Scan()
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    written = 0
    with dst.open("wb") as out:
        writer = Writer(out, compression=CompressionType.ZSTD)
        writer.start(profile="", library="shoal recover")
        for record in records(src, scan):
            if isinstance(record, Schema) and record.id not in schema_ids:
                schema_ids[record.id] = writer.register_schema(
                    record.name, record.encoding, record.data
                )
            elif isinstance(record, Channel) and record.id not in channel_ids:
                channel_ids[record.id] = writer.register_channel(
                    record.topic,
                    record.message_encoding,
                    schema_ids.get(record.schema_id, 0),
                    dict(record.metadata),
                )
            elif isinstance(record, Message) and record.channel_id in channel_ids:
                writer.add_message(
                    channel_ids[record.channel_id],
                    record.log_time,
                    record.data,
                    record.publish_time,
                    record.sequence,
                )
                written += 1
            elif isinstance(record, Attachment):
                writer.add_attachment(
                    record.create_time, record.log_time, record.name, record.media_type, record.data
                )
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
        writer.finish()
    return {
        "from": str(src),
        "to": str(dst),
        "was_finished": is_finished(src),
        "messages": written,
        "channels": len(channel_ids),
        "stopped": scan.stopped,
    }
