"""A logger killed with SIGKILL mid-run: everything up to its last complete chunk is
recovered into a finished file, and what is recovered is exactly the run's beginning."""

from __future__ import annotations

import json
import os
import re
import signal
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import client, shortened, start_run, unique
from mcap.reader import make_reader

from shoal.tools.cli import main
from shoal.tools.log.reader import read_ticks, read_trajectory
from shoal.tools.log.salvage import inspect_file, is_finished
from shoal.tools.log.writer import McapLog
from shoal.tools.procs.swarm import Swarm
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario

pytestmark = pytest.mark.integration


def test_killed_logger_is_recovered_up_to_its_last_complete_chunk(
    router: str, tmp_path: Path
) -> None:
    # The first 12 s of obstacles (1200 ticks, not 6200: CI waited 25 s more for the run to
    # end without its logger): the kill comes at tick 600, and the run goes on for as long again.
    scenario, broken = shortened(tmp_path, "obstacles", 12.0), tmp_path / "broken.mcap"
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), unique("salvage"), broken)
        watcher, logger, world = r.watcher, r.logger, r.world
        watcher.until_tick(600)
        logger.done = True
        os.kill(logger.popen.pid, signal.SIGKILL)
        logger.popen.wait(timeout=10)
        watcher.until_summary()  # the run goes on without its logger
        assert world.popen.wait(timeout=30) == 0
        for c in swarm.children:
            c.done = True

    assert not is_finished(broken)
    info = inspect_file(broken)
    assert info["finished"] is False and info["messages"] > 0

    fixed = tmp_path / "fixed.mcap"
    result = CliRunner().invoke(main, ["recover", str(broken), "-o", str(fixed), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["was_finished"] is False and report["messages"] == info["messages"]
    with fixed.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == info["messages"]
    again = CliRunner().invoke(main, ["recover", str(broken), "-o", str(fixed)])
    assert again.exit_code == 1 and "exists; pass --force" in again.output  # never silently
    told = CliRunner().invoke(main, ["recover", str(broken), "-o", str(fixed), "--force"])
    assert told.exit_code == 0, told.output  # for a person: what was recovered, and what next
    assert f"{info['messages']} messages on " in told.output and "not finished" in told.output
    assert f"shoal inspect {fixed}" in told.output

    # What survived is the run's beginning, bit for bit: at least the first 300 ticks
    # (the writer flushes every 0.5 s; the kill came after tick 600).
    ticks = read_ticks(fixed)
    assert [t.tick for t in ticks] == list(range(len(ticks)))
    assert len(ticks) >= 300
    scn = load_scenario(scenario)
    got = read_trajectory(fixed, dt=scn.dt)
    ref = simulate(scn)
    k = len(ticks)
    assert got.positions[:k].tobytes() == ref.positions[:k].tobytes()
    assert got.velocities.tobytes() == ref.velocities[:k].tobytes()
    assert inspect_file(fixed)["scenario"] == "obstacles"


def test_inspect_a_finished_run(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    result = CliRunner().invoke(
        main, ["run", str(short_file(tmp_path)), "--json", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    shown = CliRunner().invoke(main, ["inspect", str(out), "--json"])
    info = json.loads(shown.output)
    assert info["finished"] is True and info["stopped"] is None
    assert info["scenario"] == "sinusoid" and info["attachments"] == ["scenario.yaml"]
    summary = info["summary"]  # the world's document: numbers are numbers, not strings
    assert summary["collisions"] == 0 and summary["steps"] == 100
    assert isinstance(summary["min_interagent_distance"], float)
    ticks = [n for topic, n in info["channels"].items() if topic.endswith("/world/tick")]
    assert ticks == [100]
    text = CliRunner().invoke(main, ["inspect", str(out)])
    assert "finished" in text.output and "/world/tick" in text.output


def short_file(tmp_path: Path) -> Path:
    text = load_scenario("sinusoid").source.replace("duration: 30.0", "duration: 1.0")
    path = tmp_path / "short.yaml"
    path.write_text(text)
    return path


def test_verify_accepts_a_true_log_and_names_the_first_forged_tick(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    ran = CliRunner().invoke(main, ["run", str(short_file(tmp_path)), "--json", "--out", str(out)])
    assert ran.exit_code == 0, ran.output
    ok = CliRunner().invoke(main, ["verify", str(out)])
    assert ok.exit_code == 0, ok.output
    assert "100 of 100 recorded ticks match" in ok.output

    forged = tmp_path / "forged.mcap"
    _copy_with(out, forged, tick=37)
    bad = CliRunner().invoke(main, ["verify", str(forged)])
    assert bad.exit_code == 1
    assert "99 of 100" in bad.output and "first mismatch at tick 37" in bad.output


def _copy_with(src: Path, dst: Path, *, tick: int) -> None:
    """Copy a log, moving agent 2 by 1 mm in the record of ``tick``."""
    from dataclasses import replace

    from mcap.records import Channel, Message, Metadata, Schema
    from mcap.writer import Writer

    from shoal.bus import codec
    from shoal.tools.log.salvage import Scan, records

    scan, ids = Scan(), {}
    with dst.open("wb") as f:
        w = Writer(f)
        w.start()
        for r in records(src, scan):
            if isinstance(r, Schema):
                w.register_schema(r.name, r.encoding, r.data)
            elif isinstance(r, Channel):
                ids[r.id] = w.register_channel(r.topic, r.message_encoding, r.schema_id, r.metadata)
            elif isinstance(r, Message):
                data = r.data
                if scan.channels[r.channel_id].topic.endswith("/world/tick"):
                    rec = codec.decode_tick(data)
                    if rec.tick == tick:
                        moved = list(rec.positions)
                        moved[1] = (moved[1][0] + 1e-3, moved[1][1])
                        data = codec.encode_tick(replace(rec, positions=tuple(moved)))
                w.add_message(ids[r.channel_id], r.log_time, data, r.publish_time, r.sequence)
            elif isinstance(r, Metadata):
                w.add_metadata(r.name, r.metadata)
        w.finish()  # type: ignore[no-untyped-call]


def test_a_later_scenario_on_the_runs_key_does_not_replace_the_worlds(tmp_path: Path) -> None:
    """Without --secure anyone can publish on the run's keys: a second valid scenario document
    (here `obstacles`, after the world's `sinusoid`) is recorded as a message but neither
    attached nor read back as the run's scenario, so `shoal verify` checks the real one."""
    from collections import deque

    from shoal.bus import codec
    from shoal.bus.keys import Keys
    from shoal.tools.log.logger import _write
    from shoal.tools.log.reader import read_documents
    from shoal.tools.log.writer import McapLog

    keys, out = Keys("forged"), tmp_path / "run.mcap"
    received = deque(
        (keys.scenario, codec.encode_document("scenario", {"name": n, "yaml": y}), t)
        for t, (n, y) in enumerate(
            (name, load_scenario(name).source) for name in ("sinusoid", "obstacles")
        )
    )
    received.append((keys.summary, codec.encode_document("summary", {"steps": 0}), 2))
    with McapLog(out, run="forged") as log:
        assert _write(log, keys, received)  # True: the summary ends the run
    assert read_documents(out)["scenario"]["name"] == "sinusoid"
    with out.open("rb") as f:
        reader = make_reader(f)
        names = [a.name for a in reader.iter_attachments()]
        counts = reader.get_summary().statistics.channel_message_counts  # type: ignore[union-attr]
    assert names == ["scenario.yaml"] and sum(counts.values()) == 3


def test_a_log_is_created_exclusively_so_two_runs_never_share_one(tmp_path: Path) -> None:
    """Two runs given the same --out: the second logger finds the file taken at the instant it
    creates it (not by a check made before), and the first run's log stays whole."""
    path = tmp_path / "run.mcap"
    with McapLog(path, run="first") as first:
        first.add("shoal/first/world/event", b"first", 1)
        with pytest.raises(FileExistsError):
            McapLog(path, run="second")
    kept = path.read_bytes()
    assert is_finished(path) and b"first" in kept
    with pytest.raises(FileExistsError):
        McapLog(path, run="third")
    assert path.read_bytes() == kept
    with McapLog(path, run="fourth", overwrite=True):
        pass
    assert is_finished(path) and b"first" not in path.read_bytes()


def _bad_logs(tmp_path: Path) -> dict[str, Path]:
    """Files a new user may hand to shoal as logs: random bytes, text, nothing, and a real log
    cut in the middle (what a killed logger leaves)."""
    rng = np.random.default_rng(7)
    files = {
        "random": rng.integers(0, 256, size=5000, dtype=np.uint8).tobytes(),
        "text": b"not a log\n",
        "empty": b"",
    }
    whole = tmp_path / "whole.mcap"
    with McapLog(whole, run="cut") as log:
        for k in range(2000):
            log.add("shoal/cut/world/tick", rng.bytes(64), k)
    files["cut"] = whole.read_bytes()[: whole.stat().st_size // 2]
    paths = {}
    for name, data in files.items():
        paths[name] = tmp_path / f"{name}.mcap"
        paths[name].write_bytes(data)
    return paths


READERS = {
    "verify": [],
    "plot": ["--out", "{tmp}/figs"],
    "export": ["-o", "{tmp}/views.mcap"],
    "replay": ["--connect", "tcp/127.0.0.1:9"],  # the file is judged before any connection
    "inspect": [],
    "recover": ["-o", "{tmp}/fixed.mcap"],
}


@pytest.mark.parametrize("command", sorted(READERS))
def test_a_file_that_is_no_log_gets_one_clear_error_and_a_non_zero_exit(
    command: str, tmp_path: Path
) -> None:
    for kind, path in _bad_logs(tmp_path).items():
        extra = [a.replace("{tmp}", str(tmp_path)) for a in READERS[command]]
        result = CliRunner().invoke(main, [command, str(path), *extra])
        if kind == "cut" and command in ("inspect", "recover"):
            assert result.exit_code == 0, result.output  # what these two are for
            continue
        assert result.exit_code == 1, (kind, result.output)
        assert result.exception is None or isinstance(result.exception, SystemExit), kind
        expected = "not a finished MCAP file" if kind == "cut" else "not an MCAP file"
        assert f"Error: {path}: {expected}" in result.output, (kind, result.output)
        assert not (tmp_path / "fixed.mcap").exists(), kind  # nothing written from it
    if command == "recover":  # the cut log, and only it, was recovered
        assert is_finished(tmp_path / "fixed.mcap")


@pytest.mark.parametrize(
    ("ticks", "problem"),
    [((0, 1, 3, 4), "1 missing (first 2)"), ((0, 1, 1, 2), "1 recorded twice (first 1)")],
)
def test_a_log_with_a_gap_in_its_ticks_is_refused_not_read_shifted(
    tmp_path: Path, ticks: tuple[int, ...], problem: str
) -> None:
    """A logger that lost its session for a while (a router stalled by a dead link did that)
    leaves a gap: read as rows, every later tick would sit one row early and compare wrongly
    with the reference. The reader names the gap instead."""
    from shoal.bus import codec
    from shoal.bus.keys import Keys
    from shoal.bus.messages import TickRecord

    out = tmp_path / "gap.mcap"
    with McapLog(out, run="gap") as log:
        for t in ticks:
            one = ((float(t), 0.0),)
            rec = TickRecord(t, one, ((1.0, 0.0),), (False,), (1.0,), (1.0,), (0.0,), (True,),
                             (False,))  # fmt: skip
            log.add(Keys("gap").tick, codec.encode_tick(rec), t)
    wanted = re.escape(f"not ticks 0..{ticks[-1]} once each: {problem}")
    with pytest.raises(ValueError, match=wanted):
        read_trajectory(out, dt=0.01)
