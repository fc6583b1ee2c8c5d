"""Reading a run back from its MCAP file."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.messages import TickRecord
from shoal.world.loader import parse_scenario
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory
from shoal.world.unicycle import Lookahead


def iter_channel(path: Path, topic_suffix: str) -> Iterator[tuple[str, bytes, int]]:
    """(topic, payload, log_time_ns) of every message whose topic ends with ``topic_suffix``,
    in log-time order."""
    with path.open("rb") as f:
        reader = make_reader(f)
        topics = [c.topic for c in reader.get_summary().channels.values()]  # type: ignore[union-attr]
        wanted = [t for t in topics if t.endswith(topic_suffix)]
        for _schema, channel, message in reader.iter_messages(topics=wanted):
            yield channel.topic, message.data, message.log_time


def read_ticks(path: Path) -> list[TickRecord]:
    """Every tick record of the run, in tick order. Messages on the tick channel that do not
    decode (someone else's garbage on the run's key) are skipped."""
    records = []
    for _topic, data, _ns in iter_channel(path, "/world/tick"):
        try:
            records.append(codec.decode_tick(data))
        except DecodeError:
            continue
    return sorted(records, key=lambda r: r.tick)


def read_trajectory(path: Path, *, dt: float, lookahead: Lookahead | None = None) -> Trajectory:
    """The run's trajectory as the world recorded it; the last positions are integrated from
    the last record exactly as the world does (positions + dt * velocities; a unicycle's arc
    with ``lookahead``, :attr:`Scenario.lookaheads`)."""
    records = read_ticks(path)
    if not records:
        raise ValueError(f"{path}: no tick records")
    ticks = [r.tick for r in records]
    if ticks != list(range(len(ticks))):  # a gap would shift every later row by a tick
        raise ValueError(f"{path}: the tick records are not ticks 0..{ticks[-1]} once each: "
                         f"{_gaps(ticks)}")  # fmt: skip
    if records[0].headings and lookahead is None:  # unicycles: l is in the recorded scenario
        lookahead = _recorded_lookahead(path)
    return Trajectory.from_records(records, dt, lookahead)


def _recorded_lookahead(path: Path) -> Lookahead:
    document = read_documents(path).get("scenario")
    if document is None:
        raise ValueError(f"{path}: tick records of unicycles but no scenario to say their l")
    lookahead = recorded_scenario(document).lookaheads
    if lookahead is None:
        raise ValueError(f"{path}: tick records with headings from a scenario without unicycles")
    return lookahead


def _gaps(ticks: list[int]) -> str:
    """What is wrong with a sorted list of tick numbers, for an error message."""
    counts = Counter(ticks)
    missing = [t for t in range(ticks[-1] + 1) if t not in counts]
    twice = sorted(t for t, c in counts.items() if c > 1)
    parts = []
    if missing:
        parts.append(f"{len(missing)} missing (first {', '.join(map(str, missing[:5]))})")
    if twice:
        parts.append(f"{len(twice)} recorded twice (first {', '.join(map(str, twice[:5]))})")
    return "; ".join(parts)


def recorded_scenario(document: Mapping[str, Any]) -> Scenario:
    """The scenario of a world's ``scenario`` document, under the name it ran as: the YAML of a
    scenario from a file has no ``name:`` (the file's name gave it), the document does.
    Raises ScenarioError if it does not load."""
    name = document.get("name")
    return parse_scenario(
        str(document.get("yaml", "")), default_name=str(name) if name else "scenario"
    )


def read_documents(path: Path) -> dict[str, dict[str, Any]]:
    """The scenario and summary documents the world published, by kind: the first valid one of
    each (the world publishes each once, the scenario before tick 0 and the summary last, and
    the logger stops at the summary; a later scenario on the run's key is someone else's)."""
    docs: dict[str, dict[str, Any]] = {}
    for kind in ("scenario", "summary"):
        for _topic, data, _ns in iter_channel(path, f"/world/{kind}"):
            try:
                docs[kind] = codec.decode_document(kind, data)
            except DecodeError:
                continue  # someone else's garbage on the run's key
            break
    return docs
