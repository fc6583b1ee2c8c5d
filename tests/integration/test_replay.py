"""`shoal replay` republishes a log into a fresh router: a subscriber receives the same bytes
on the same keys in the same order."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from conftest import PYTHON, client

from shoal.bus.links import subscribe
from shoal.bus.runtime import Inbox
from shoal.tools.cli import main
from shoal.tools.log.replay import Selection, messages
from shoal.tools.log.writer import McapLog
from shoal.tools.procs.launch import free_port
from shoal.world.loader import load_scenario

pytestmark = pytest.mark.integration


def test_replay_delivers_the_same_bytes_in_the_same_order(router: str, tmp_path: Path) -> None:
    scenario = tmp_path / "short.yaml"
    scenario.write_text(load_scenario("passage").source.replace("duration: 45.0", "duration: 0.5"))
    log = tmp_path / "run.mcap"
    ran = CliRunner().invoke(main, ["run", str(scenario), "--json", "--out", str(log)])
    assert ran.exit_code == 0, ran.output
    expected = [(key, data) for key, data, _t in messages(log, Selection())]
    assert len(expected) > 50 * 15  # 50 ticks of sensing, states, commands, records

    inbox = Inbox()
    with client(router) as session:
        held = subscribe(session, "shoal/**", inbox)
        proc = subprocess.run(
            [*PYTHON, "replay", str(log), "--connect", router, "-r", "10"],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        assert f"{len(expected)} messages replayed" in proc.stderr
        got = []
        deadline = time.monotonic() + 30
        while len(got) < len(expected):
            arrival = inbox.get(timeout=max(deadline - time.monotonic(), 0.0))
            if arrival is None:
                break
            got.append((arrival.key, arrival.payload))
        del held
    assert got == expected

    nobody = f"tcp/127.0.0.1:{free_port()}"  # no router there: said at once, in plain words
    proc = subprocess.run(
        [*PYTHON, "replay", str(log), "--connect", nobody], capture_output=True, text=True,
        timeout=120,
    )  # fmt: skip
    assert proc.returncode == 1
    assert "replay: cannot open a Zenoh session" in proc.stderr and nobody in proc.stderr
    assert "is a router running there?" in proc.stderr and ".rs:" not in proc.stderr


def test_replay_needs_a_router_or_a_viewer(tmp_path: Path) -> None:
    log = tmp_path / "run.mcap"
    log.write_bytes(b"")
    nowhere = CliRunner().invoke(main, ["replay", str(log)])
    assert nowhere.exit_code == 2
    assert "say where to: --connect EP (a Zenoh router to republish onto), --live" in (
        nowhere.output
    )
    empty = tmp_path / "empty.mcap"
    with McapLog(empty, run="x"):  # finished, but nothing to draw the run in
        pass
    refused = CliRunner().invoke(main, ["replay", str(empty), "--live", "--live-port", "0"])
    assert refused.exit_code == 1
    assert refused.output.strip() == (
        f"Error: --live: {empty}: no scenario document in the log: nothing to draw the run in"
    )


def test_selection_filters_topics() -> None:
    only = Selection(topics=("shoal/r/world/tick",))
    assert only.wants("shoal/r/world/tick") and not only.wants("shoal/r/agent/1/state")
    states = Selection(include=r"/state$", exclude=r"/agent/2/")
    assert states.wants("shoal/r/agent/1/state")
    assert not states.wants("shoal/r/agent/2/state") and not states.wants("shoal/r/world/tick")
