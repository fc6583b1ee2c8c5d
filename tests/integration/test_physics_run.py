"""A distributed lockstep run whose world steps MuJoCo (``shoal run --plant mujoco``): real OS
processes over a real Zenoh router. It equals the reference with the same plant bit for bit, and
`shoal verify` checks it from the log alone (which records the plant)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from conftest import json_of, run_cli
from physics_cases import mixed_robotarium

from shoal.tools.commands.report import json_safe
from shoal.tools.log.reader import read_ticks
from shoal.tools.simulator import reference, run
from shoal.world.loader import parse_scenario
from shoal.world.metrics import summarize

pytestmark = pytest.mark.integration
pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")


def test_a_physics_run_of_wheels_and_bases_equals_the_reference(tmp_path: Path) -> None:
    """GRITSbots as TurtleBot3s with two holonomic bases among them: both drives in one engine,
    stepped by the world process, the agents on the bus."""
    text = mixed_robotarium(8.0)
    path = tmp_path / "mixed.yaml"
    path.write_text(text)
    out = tmp_path / "run.mcap"
    proc = run_cli(["run", str(path), "--plant", "mujoco", "--dynamics", "turtlebot3", "--json",
                    "--no-foxglove", "--out", str(out)])  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    got = json_of(proc)
    scn = parse_scenario(text, default_name="mixed")
    traj, judged = reference(scn, plant="mujoco", dynamics="turtlebot3")
    # every tick record as the reference makes it (the log's readers integrate the pose after
    # the last tick kinematically, so the trajectory's last row is compared by the summary)
    records = read_ticks(out)
    assert len(records) == traj.ticks
    assert [replace(t, alive=r.alive) for t, r in zip(run(scn, "mujoco", "turtlebot3"), records,
                                                      strict=True)] == records  # fmt: skip
    expected = json_safe({**summarize(scn, traj).as_dict(), **judged})
    assert {k: got[k] for k in expected if k != "scenario"} == {
        k: v for k, v in expected.items() if k != "scenario"
    }
    assert got["dynamics"] == "holonomic, turtlebot3"
    verified = run_cli(["verify", str(out)])
    assert verified.returncode == 0, verified.stdout + verified.stderr
    assert "match the reference" in verified.stdout and "first mismatch" not in verified.stdout
