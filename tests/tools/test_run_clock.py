"""``shoal run --robots ros2`` picks its clock: realtime unless told otherwise, and a clock or
a speed that cannot drive robots is refused by name before anything starts."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from shoal.bus.types import Clock
from shoal.tools.cli import main
from shoal.tools.commands import run as run_command
from shoal.tools.commands.run import RunConfig
from shoal.tools.procs.launch import RunResult


@pytest.fixture
def launched(monkeypatch: pytest.MonkeyPatch) -> list[RunConfig]:
    """What `shoal run` would launch, caught before anything starts."""
    seen: list[RunConfig] = []

    def catch(config: RunConfig) -> RunResult:
        seen.append(config)
        raise SystemExit(0)

    monkeypatch.setattr(run_command, "run_swarm", catch)
    return seen


def _run(tmp_path: Path, *args: str) -> tuple[int, str]:
    out = str(tmp_path / "run.mcap")
    result = CliRunner().invoke(main, ["run", "default", "--out", out, *args])
    return result.exit_code, result.output


def test_robots_ros2_without_a_clock_runs_realtime_at_speed_one(
    tmp_path: Path, launched: list[RunConfig]
) -> None:
    pytest.importorskip("rosbags")  # the ros2 extra, which `--robots ros2` requires
    code, output = _run(tmp_path, "--robots", "ros2")
    assert code == 0, output
    (config,) = launched
    assert config.plan.clock is Clock.REALTIME
    assert config.plan.speed == 1.0
    assert config.plan.ros is not None


def test_without_robots_the_default_clock_is_still_lockstep(
    tmp_path: Path, launched: list[RunConfig]
) -> None:
    code, output = _run(tmp_path)
    assert code == 0, output
    (config,) = launched
    assert config.plan.clock is Clock.LOCKSTEP
    assert config.plan.ros is None


@pytest.mark.parametrize("flag", ["--clock", "--mode"])
def test_robots_ros2_with_an_explicit_lockstep_is_refused_by_name(
    tmp_path: Path, launched: list[RunConfig], flag: str
) -> None:
    code, output = _run(tmp_path, "--robots", "ros2", flag, "lockstep")
    assert code == 2, output
    assert "Invalid value for --robots: robots move on the wall clock: --clock lockstep " in output
    assert "leave --clock out, or give --clock realtime" in output
    assert launched == []


@pytest.mark.parametrize("clock", [(), ("--clock", "realtime")], ids=["implied", "given"])
def test_robots_ros2_at_another_speed_is_refused(
    tmp_path: Path, launched: list[RunConfig], clock: tuple[str, ...]
) -> None:
    code, output = _run(tmp_path, "--robots", "ros2", *clock, "--speed", "2")
    assert code == 2, output
    assert "Invalid value for --robots: robots move on the wall clock: --speed 2 " in output
    assert launched == []
