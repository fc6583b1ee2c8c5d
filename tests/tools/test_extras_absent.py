"""`pip install shoal` with no extra: the real console script, in a subprocess where the extras'
modules cannot be imported. Every command's help works; a command that needs an extra says which
and how to install it, in one line, with no traceback."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import click
import pytest

from shoal.tools.cli import main

SHOAL = Path(sys.executable).parent / "shoal"  # the console script of this environment

# Top-level modules of every optional dependency (pyproject.toml's extras, and dev's own):
# plot, cluster (distributed, and the dask it brings), live (the foxglove-sdk distribution),
# ros2, and dev's mcap-ros2-support, zenoh-ros2-sdk, jsonschema.
BLOCKED = (
    "matplotlib", "distributed", "dask", "foxglove", "rosbags",
    "mcap_ros2", "zenoh_ros2_sdk", "jsonschema",
)  # fmt: skip

# Imported by the interpreter at start-up from PYTHONPATH: any import of a blocked module, or of
# one inside it, fails as it does when the distribution is not installed.
SITECUSTOMIZE = f"""
import sys

BLOCKED = {BLOCKED!r}


class NotInstalled:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None


sys.meta_path.insert(0, NotInstalled())
"""


def _paths(
    group: click.Group, ctx: click.Context, prefix: tuple[str, ...] = ()
) -> list[tuple[str, ...]]:
    """Every command line that names a command, subcommands of groups included."""
    out: list[tuple[str, ...]] = []
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        assert command is not None, name
        out.append((*prefix, name))
        if isinstance(command, click.Group):
            sub = click.Context(command, parent=ctx, info_name=name)
            out.extend(_paths(command, sub, (*prefix, name)))
    return out


COMMANDS = _paths(main, click.Context(main, info_name="shoal"))


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("no-extras")
    (folder / "sitecustomize.py").write_text(SITECUSTOMIZE, encoding="utf-8")
    return folder


def _shoal(site: Path, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(site), "COLUMNS": "200"}
    return subprocess.run(
        [str(SHOAL), *args], env=env, cwd=cwd, capture_output=True, text=True, timeout=120
    )


def test_the_blocked_names_are_the_extras_real_modules() -> None:
    """Each name is importable here (the dev install has every extra): a misspelt one would
    block nothing and the tests below would prove nothing."""
    assert SHOAL.exists(), f"no console script at {SHOAL}: pip install -e '.[dev]'"
    assert [m for m in BLOCKED if importlib.util.find_spec(m) is None] == []


def test_the_extras_are_unimportable_in_the_subprocess(site: Path) -> None:
    code = "import importlib\nfor m in {!r}:\n    try:\n        importlib.import_module(m)\n"
    code += "    except ImportError:\n        continue\n    print(m)\n"
    env = {**os.environ, "PYTHONPATH": str(site)}
    done = subprocess.run(
        [sys.executable, "-c", code.format(BLOCKED)], env=env, capture_output=True, text=True
    )
    assert done.returncode == 0 and done.stdout == "", done.stdout + done.stderr


def test_shoal_help_lists_every_command(site: Path) -> None:
    done = _shoal(site, "--help")
    assert done.returncode == 0, done.stderr
    assert "Usage: shoal" in done.stdout
    ctx = click.Context(main)
    for name in main.list_commands(ctx):
        command = main.get_command(ctx, name)
        assert command is not None
        assert (f"  {name} " in done.stdout) != command.hidden, name  # floor: a developer's
    assert "Traceback" not in done.stderr


def test_shoal_alone_shows_the_usage(site: Path) -> None:
    done = _shoal(site)
    assert "Usage: shoal" in done.stdout + done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_each_command_help(site: Path, command: tuple[str, ...]) -> None:
    done = _shoal(site, *command, "--help")
    assert done.returncode == 0, done.stderr
    assert f"Usage: shoal {' '.join(command)}" in done.stdout
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize(
    ("args", "extra"),
    [
        (("guard", "--run", "r", "--ros-namespace", "/robot1"), "ros2"),
        (("robots", "default"), "ros2"),
        (("run", "default", "--robots", "ros2", "--clock", "realtime"), "ros2"),
        (("run", "default", "--live"), "live"),
        (("campaign", "--fields", "2", "--dask", "tcp://127.0.0.1:9"), "cluster"),
    ],
    ids=lambda v: v if isinstance(v, str) else " ".join(v[:2]),
)
def test_a_command_that_needs_a_missing_extra_names_it(
    site: Path, tmp_path: Path, args: tuple[str, ...], extra: str
) -> None:
    done = _shoal(site, *args, cwd=tmp_path)
    assert done.returncode != 0, done.stdout
    assert "Traceback" not in done.stderr, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert f"pip install 'shoal[{extra}]'" in lines[0], done.stderr
