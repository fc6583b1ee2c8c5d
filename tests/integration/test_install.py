"""shoal installed as a user installs it: one top-level package, ``shoal``, that neither
shadows nor is shadowed by a user's own ``tools``, ``world``, ``agent`` or ``bus`` packages."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from shoal.world.loader import load_scenario

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def crowded(tmp_path: Path) -> Path:
    """A user's project folder with packages of the names shoal used to install."""
    for name in ("tools", "world", "agent", "bus", "geometry"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text(f"MINE = {name!r}\n")
    return tmp_path


def _env(site: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(site)}


def test_the_wheel_ships_one_top_level_package(installed: Path) -> None:
    packages = {p.name for p in installed.iterdir() if (p / "__init__.py").exists()}
    assert packages == {"shoal"}
    assert (installed / "shoal" / "py.typed").exists()
    assert (installed / "shoal" / "world" / "scenarios" / "default.yaml").exists()


def test_import_shoal_works_beside_a_users_own_packages(installed: Path, crowded: Path) -> None:
    script = (
        "import tools, world, shoal\n"
        "assert tools.MINE == 'tools' and world.MINE == 'world'\n"
        "s = shoal.load('default')\n"
        "print(s.n, shoal.summarize(s, shoal.simulate(s)).collisions)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", script], cwd=crowded, env=_env(installed),
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["5", "0"]


@pytest.mark.integration
def test_shoal_run_works_from_a_folder_with_a_users_own_packages(
    installed: Path, crowded: Path
) -> None:
    shoal = installed / "bin" / "shoal"
    short = load_scenario("sinusoid").source.replace("duration: 30.0", "duration: 1.0")
    (crowded / "short.yaml").write_text(short, encoding="utf-8")  # the packages matter, not length
    out = subprocess.run(
        [str(shoal), "run", "short.yaml", "--out", "runs/d.mcap", "--no-foxglove", "--json"],
        cwd=crowded, env=_env(installed), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["collisions"] == 0
    assert (crowded / "runs" / "d.mcap").stat().st_size > 0
