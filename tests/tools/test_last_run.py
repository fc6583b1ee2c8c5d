"""The last run one step away: the log commands with no FILE, globs that catch the Foxglove views
file, a views file named alone, a scenario from a file keeping its name (tools/commands/logs.py).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from shoal.tools.cli import main
from shoal.tools.plot.save import load_view
from shoal.world.loader import load_scenario


def _run(name: str) -> Path:
    """A half-second run of ``name``.yaml (the sinusoid), logged where `shoal run` logs it."""
    text = load_scenario("sinusoid").source.replace("duration: 30.0", "duration: 0.5")
    text = text.replace("name: sinusoid", "")  # a file's scenario is named after the file
    Path(f"{name}.yaml").write_text(text, encoding="utf-8")
    ran = CliRunner().invoke(main, ["run", f"{name}.yaml", "--json"])
    assert ran.exit_code == 0, ran.output
    log = Path(json.loads(ran.stdout)["mcap"])
    assert log.parent == Path("runs") and log.name.startswith(f"{name}-")
    return log


def test_the_log_commands_read_the_last_run_and_keep_a_files_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    nothing = CliRunner().invoke(main, ["inspect"])
    assert nothing.exit_code == 2 and "no run logs in runs/" in nothing.output
    first = _run("wedge")
    second = _run("other")
    os.utime(first, ns=(1, 1))  # the order does not rest on the clock's resolution
    inspected = CliRunner().invoke(main, ["inspect"])
    assert inspected.exit_code == 0, inspected.output
    assert f"the last run, {second}" in inspected.stderr
    assert f"{second}: finished" in inspected.stdout
    rows = {line.strip().split("  ")[0] for line in inspected.stdout.splitlines()}
    assert {"collisions", "arrival", "margins", "clock"} <= rows  # the summary as a table
    assert "tolerance=" not in inspected.stdout  # not a line of raw floats
    verified = CliRunner().invoke(main, ["verify"])
    assert verified.exit_code == 0, verified.output
    assert verified.stdout.startswith(f"{second}: other, 50 of 50 recorded ticks match")
    assert load_view(second).label == "other (lockstep)"  # the plot titles' name


def test_a_glob_of_runs_leaves_out_the_views_and_a_views_file_alone_names_its_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    log = _run("wedge")
    views = log.with_name(log.name.removesuffix(".mcap") + ".foxglove.mcap")
    assert views.exists()
    globbed = sorted(str(p) for p in Path("runs").glob("wedge-*.mcap"))  # what a shell passes
    assert len(globbed) == 2
    verified = CliRunner().invoke(main, ["verify", *globbed])
    assert verified.exit_code == 0, verified.output
    assert f"left out 1 Foxglove views file(s), not logs: {views}" in verified.stderr
    assert len(verified.stdout.splitlines()) == 1
    for command in ("plot", "inspect", "verify", "export", "replay"):
        alone = CliRunner().invoke(main, [command, str(views)])
        assert alone.exit_code == 2, (command, alone.output)
        said = " ".join(alone.output.split())  # click wraps the message
        assert f"{views} is the Foxglove views file of a run" in said, (command, said)
        assert f"its log is {log}" in said, (command, said)
