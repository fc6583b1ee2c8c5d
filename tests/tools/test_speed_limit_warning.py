"""A scenario without a speed limit gets the largest the safety theorem admits; the command line
says once what that costs (world/assumptions.py ``unlimited``). The built-ins carry one."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from shoal.tools.cli import main
from shoal.world.assumptions import unlimited
from shoal.world.loader import builtin_names, load_scenario

BUILTINS = Path(__file__).parents[2] / "world" / "scenarios"


@pytest.mark.parametrize("name", builtin_names())
def test_every_builtin_carries_a_speed_limit(name: str) -> None:
    assert unlimited(load_scenario(name)) is None


def test_a_file_without_a_limit_is_told_what_it_costs(tmp_path: Path) -> None:
    text = (BUILTINS / "sinusoid.yaml").read_text()
    lines = [line for line in text.splitlines() if not line.lstrip().startswith("speed_limit")]
    bare = tmp_path / "bare.yaml"
    bare.write_text("\n".join(lines) + "\n")
    said = unlimited(load_scenario(str(bare)))
    assert said is not None and "230 m/s" in said and "control.speed_limit" in said
    result = CliRunner().invoke(main, ["simulate", str(bare), "--json"])
    assert result.exit_code == 0, result.output
    assert result.stderr.count(f"warning: {said}") == 1
    quiet = CliRunner().invoke(main, ["simulate", "sinusoid", "--json"])
    assert "speed_limit" not in quiet.stderr
