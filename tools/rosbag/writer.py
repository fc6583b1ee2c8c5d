"""Writing a run's ROS 2 bag: a rosbag2 directory (``metadata.yaml`` and one MCAP file, CDR
messages with ``ros2msg`` schemas), by the ``rosbags`` package, which needs no ROS install.

The bag is written in a hidden directory beside DIR and renamed into place when complete, so an
export that fails or is interrupted leaves no half-written bag. An existing DIR is replaced only
when asked (``force``), and only if it is a bag (it holds ``metadata.yaml`` and no folder): a
mistyped ``--ros2 runs --force`` cannot delete a folder of logs.

Format: rosbag2 version 9 (ROS 2 Jazzy and later), storage ``mcap`` (chunks compressed with
zstd, which rosbag2's MCAP plugin reads; message indexes and statistics), type definitions from
rosbags' ROS 2 Jazzy store. The message types used are the same in Humble, but Humble's
``ros2 bag`` may refuse a newer bag version (docs/ros2.md).
"""

from __future__ import annotations

import importlib
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from shoal.tools.foxglove.export import ExportError, Source, read_source, run_log
from shoal.tools.foxglove.views import RunLog
from shoal.tools.progress import advance_to, progress_bar

INSTALL = "pip install 'shoal[ros2]'"
BAG_VERSION: Literal[9] = 9  # rosbag2's metadata version (Jazzy); rosbags writes 8 or 9
TIME = "simulated time of the tick, tick × dt, ns from the start of the run"


class Ros2Error(ValueError):
    """The bag cannot be written: the log is not a finished run, or DIR is in the way."""


class Ros2Missing(Ros2Error):
    """The optional dependency ``rosbags`` is not installed."""

    def __init__(self, reason: str) -> None:
        super().__init__(f"--ros2 needs the rosbags package ({reason}); install it with: {INSTALL}")


@dataclass(frozen=True)
class BagResult:
    out: Path  # the bag directory
    messages: int
    ticks: int
    seconds: float
    bytes: int  # of the MCAP file
    topics: dict[str, int] = field(default_factory=dict)  # topic → messages


def require_rosbags() -> None:
    """Ros2Missing unless rosbags (and the message module built on it) import."""
    try:
        for module in ("rosbags.rosbag2", "rosbags.typesys", "shoal.tools.rosbag.msgs"):
            importlib.import_module(module)
    except ImportError as exc:
        raise Ros2Missing(str(exc)) from None


def is_bag(path: Path) -> bool:
    """A rosbag2 directory: ``metadata.yaml`` and files beside it, no folder."""
    if not path.is_dir() or not (path / "metadata.yaml").is_file():
        return False
    return all(p.is_file() and not p.is_symlink() for p in path.iterdir())


def check_target(raw: Path, out: Path, *, force: bool) -> None:
    """Ros2Error unless ``out`` may be written: absent, or (with ``force``) a bag to replace
    that does not hold ``raw``."""
    if out.name in ("", ".", ".."):
        raise Ros2Error(f"{out}: name the bag's own directory, e.g. {raw.stem}-bag")
    if not out.exists() and not out.is_symlink():
        return
    if not force:
        raise Ros2Error(f"{out} exists; pass --force to replace it")
    if not is_bag(out) or out.is_symlink():
        raise Ros2Error(f"{out} exists and is not a rosbag2 directory; not replacing it")
    if raw.resolve().parent == out.resolve():
        raise Ros2Error(f"{out} holds the log {raw.name}; write the bag elsewhere")


def export_bag(
    raw: Path,
    out: Path,
    *,
    force: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> BagResult:
    """Write the bag of the run logged in ``raw`` to the directory ``out``. ``progress(done,
    total)`` counts tick records."""
    began = time.monotonic()
    require_rosbags()
    check_target(raw, out, force=force)
    try:
        src = read_source(raw)
        run = run_log(raw, src)
    except ExportError as exc:
        raise Ros2Error(str(exc)) from None
    total = len(run.ticks)
    out.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".part", dir=out.parent))
    try:
        bag = work / out.name  # the MCAP file inside is named after the directory
        counts = _write(
            bag, raw, src, run, (lambda k: progress(k + 1, total)) if progress else None
        )
        size = sum(p.stat().st_size for p in bag.glob("*.mcap"))
        _move_into_place(bag, out, work / "replaced")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    seconds = time.monotonic() - began
    return BagResult(out, sum(counts.values()), total, seconds, size, counts)


def _write(
    bag: Path, raw: Path, src: Source, run: RunLog, progress: Callable[[int], None] | None
) -> dict[str, int]:
    from rosbags.interfaces import Connection
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from shoal.tools.rosbag.msgs import messages

    store = get_typestore(Stores.ROS2_JAZZY)
    connections: dict[str, Connection] = {}
    counts: dict[str, int] = {}
    writer = Writer(bag, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)  # MCAP chunks
    with writer:
        s = run.scenario
        for key, value in {
            "shoal.source": raw.name,
            "shoal.run": src.run,
            "shoal.scenario": s.name,
            "shoal.dt_s": repr(s.dt),
            "shoal.time": TIME,
        }.items():
            writer.set_custom_data(key, value)
        for m in messages(run, progress):
            connection = connections.get(m.topic)
            if connection is None:
                connection = writer.add_connection(m.topic, m.msgtype, typestore=store)
                connections[m.topic] = connection
            writer.write(connection, m.ns, store.serialize_cdr(m.message, m.msgtype))
            counts[m.topic] = counts.get(m.topic, 0) + 1
    return counts


def _move_into_place(bag: Path, out: Path, aside: Path) -> None:
    """Rename the finished ``bag`` to ``out``; an old ``out`` (checked: a bag) is first moved
    ``aside`` (inside the work directory, removed with it), and back if the rename fails."""
    if out.exists():
        os.rename(out, aside)
        try:
            os.rename(bag, out)
        except BaseException:
            os.rename(aside, out)
            raise
    else:
        os.rename(bag, out)


def with_progress(raw: Path, out: Path, *, force: bool, show: bool = True) -> BagResult:
    """Export with a progress bar on stderr (only on a terminal, as other commands do)."""
    with progress_bar(1, "ros2 bag", show=show) as bar:
        return export_bag(raw, out, force=force, progress=lambda k, n: advance_to(bar, k, n))
