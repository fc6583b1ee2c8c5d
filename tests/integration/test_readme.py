"""The README's commands, run in order as a newcomer would in a fresh folder: each exits 0 and
prints no Python traceback. Each command must appear in the README word for word, so a README
edit that drops or changes one fails here until this list follows it.

Left out: the long ones (`shoal campaign`, `shoal bench`, each minutes) and the processes that
serve until stopped (`shoal router`, `shoal world`); their own tests cover them.

The two swarms it runs (`default`, `obstacles`) are checked here against the reference simulator
bit for bit, as tests/integration/test_run_swarm.py checks every other built-in: one distributed
run of each in CI, not two."""

from __future__ import annotations

import shlex
import subprocess
from pathlib import Path

import pytest
from conftest import PYTHON, ROOT

from shoal.tools.log.reader import read_trajectory
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario

pytestmark = pytest.mark.integration

COMMANDS = (
    "shoal run default",
    "shoal plot",
    "shoal inspect",
    "shoal simulate default",
    "shoal scenarios list",
    "shoal scenarios passage > mine.yaml",
    "shoal simulate mine.yaml",
    "shoal scenarios new -n 20 --shape grid --obstacles 5 -o grid20.yaml",
    "shoal run obstacles --out runs/obstacles.mcap && shoal plot runs/obstacles.mcap",
)
RUN_HERE = ("default", "obstacles")  # the built-ins these commands run as swarms


def test_every_command_is_the_readmes_own() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for command in COMMANDS:
        assert command in readme, command


def _run(command: str, cwd: Path) -> None:
    """One shell line of `shoal …` commands (joined by && and with a > redirection)."""
    for part in command.split(" && "):
        words, out = part, None
        if " > " in part:
            words, target = part.split(" > ")
            out = cwd / target
        argv = [*PYTHON, *shlex.split(words)[1:]]
        proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=600)
        said = proc.stdout + proc.stderr
        assert proc.returncode == 0, (part, said[-2000:])
        assert "Traceback" not in said, (part, said[-2000:])
        if out is not None:
            out.write_text(proc.stdout, encoding="utf-8")


def test_the_readmes_commands_run_in_order_in_a_fresh_folder(tmp_path: Path) -> None:
    for command in COMMANDS:
        _run(command, tmp_path)
    assert sorted(p.name for p in (tmp_path / "plots").glob("obstacles-*.png"))  # the last plot
    runs = tmp_path / "runs"
    (default,) = (p for p in runs.glob("default-*.mcap") if not p.name.endswith(".foxglove.mcap"))
    for log, name in ((default, "default"), (runs / "obstacles.mcap", "obstacles")):
        scn = load_scenario(name)
        assert read_trajectory(log, dt=scn.dt).equals(simulate(scn)), name
