"""The `shoal` command line, through click's runner (same code path as the console script)."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner

from shoal.tools.cli import main
from shoal.tools.commands.report import render_summary
from shoal.tools.procs.launch import free_port
from shoal.tools.simulator import simulate
from shoal.world.loader import builtin_names, load_scenario, parse_scenario
from shoal.world.trajectory import Trajectory

KEYS = {
    "scenario", "agents", "steps", "dt", "collisions", "min_clearance",
    "min_interagent_distance", "convergence_time", "convergence_bound", "sigma",
    "sigma_rounds", "sigma_disagreement", "omega_episodes", "guard_margin", "separation_margin",
    "contact_slack", "arrived", "arrival_time", "arrival_tolerance", "not_arrived",
    "slot_distance", "livelocks", "longest_livelock",
}  # fmt: skip


def test_simulate_json_has_the_documented_keys(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["simulate", "passage", "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary.keys() >= KEYS
    assert summary["scenario"] == "passage"
    assert summary["agents"] == 5
    assert summary["steps"] == 4500
    assert summary["collisions"] == 0
    assert summary["sigma"] > 3.9


def test_simulate_out_saves_the_exact_trajectory(tmp_path: Path) -> None:
    out = tmp_path / "run.npz"
    result = CliRunner().invoke(main, ["simulate", "sinusoid", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "collisions" in result.output and "convergence" in result.output
    assert Trajectory.load(out).equals(simulate(load_scenario("sinusoid")))


def test_unknown_scenario_is_a_clear_error() -> None:
    result = CliRunner().invoke(main, ["simulate", "nowhere"])
    assert result.exit_code == 1
    assert "no file 'nowhere' and no built-in" in result.output
    assert "sinusoid" in result.output


def test_bad_scenario_file_names_the_field(tmp_path: Path) -> None:
    text = load_scenario("default").source.replace("beta: 2.0", "beta: -1")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    result = CliRunner().invoke(main, ["simulate", str(bad)])
    assert result.exit_code == 1
    assert "control.beta: must be > 0, got -1.0" in result.output


def test_fast_leader_warns_but_runs(tmp_path: Path) -> None:
    text = load_scenario("sinusoid").source.replace("beta: 2.0", "beta: 1.1")
    fast = tmp_path / "fast.yaml"
    fast.write_text(text)
    result = CliRunner().invoke(main, ["simulate", str(fast), "--json"])
    assert result.exit_code == 0
    assert "warning:" in result.stderr and "Theorem 1" in result.stderr
    shown = CliRunner().invoke(main, ["simulate", str(fast)])  # the text summary, too
    assert shown.exit_code == 0, shown.output
    assert "no bound: β ≤ leader speed" in shown.output and "within bound" not in shown.output


def test_scenarios_lists_every_builtin_and_prints_one() -> None:
    listed = CliRunner().invoke(main, ["scenarios"])
    assert listed.exit_code == 0
    for name in ("default", "sinusoid", "passage", "obstacles"):
        assert name in listed.output
    said = CliRunner().invoke(main, ["scenarios", "list"])  # not a scenario called "list"
    assert said.exit_code == 0 and said.output == listed.output
    assert [line.split()[0] for line in said.output.splitlines()] == builtin_names()
    assert "5 agents, 2-D" in said.output
    shown = CliRunner().invoke(main, ["scenarios", "passage"])
    assert shown.exit_code == 0


def test_a_printed_builtin_saved_as_a_file_runs_under_the_files_name(tmp_path: Path) -> None:
    """`shoal scenarios passage > mine.yaml` used to keep `name: passage`, so mine's logs and
    figures took the built-in's names and replaced them."""
    shown = CliRunner().invoke(main, ["scenarios", "passage"])
    mine = tmp_path / "mine.yaml"
    mine.write_text(shown.output, encoding="utf-8")
    copy, builtin = load_scenario(mine), load_scenario("passage")
    assert (copy.name, builtin.name) == ("mine", "passage")
    assert dataclasses.replace(copy, name="passage", source=builtin.source) == builtin


def test_a_split_sigma_is_reported_not_hidden() -> None:
    """A realtime passage ended with σ flipping between 1 and 4 while the summary said
    'agreed σ 4.000': the ticks in which the agents applied different σ are now shown."""
    base = {"scenario": "x", "agents": 5, "steps": 10, "dt": 0.01, "collisions": 0,
            "min_clearance": None, "min_interagent_distance": 1.0, "convergence_time": 0.1,
            "convergence_bound": 1.0, "tolerance": 0.2, "final_formation_error": 0.0,
            "sigma": 4.0, "sigma_rounds": 2, "omega_episodes": 0}  # fmt: skip
    agreed = render_summary({**base, "sigma_disagreement": 0})
    split = render_summary({**base, "sigma_disagreement": 59})
    assert "different σ" not in agreed
    contracted = "4.000 (rounds 2): Algorithm 1 contracted the formation to pass a gap"
    assert f"{contracted}; agents applied different σ in 59 ticks" in split


def test_simulate_prints_arrival_and_the_theorems_margins() -> None:
    result = CliRunner().invoke(main, ["simulate", "obstacles"])
    assert result.exit_code == 0, result.output
    rows = dict(line.split(None, 1) for line in result.output.splitlines())
    assert rows["arrival"].startswith("yes at 59.81 s (leader home, formation within 0.200 m)")
    # obstacles carries 4 m/s since 2026-12-08 (before: +0.02372 m, +2.89 m)
    assert rows["margins"].startswith("guard +0.03122 m, separation +2.907 m (the filter's")


def test_a_run_that_did_not_arrive_says_why() -> None:
    base = {"scenario": "x", "agents": 2, "steps": 10, "dt": 0.01, "collisions": 0,
            "min_clearance": None, "min_interagent_distance": 1.0, "convergence_time": None,
            "convergence_bound": 1.0, "tolerance": 0.2, "final_formation_error": 0.0,
            "sigma": 1.0, "sigma_rounds": None, "omega_episodes": 0, "arrived": False,
            "arrival_time": None, "arrival_tolerance": 0.2, "leader_shortfall": 21.6,
            "slot_distance": 2.41, "livelocks": 2, "longest_livelock": 31.5}  # fmt: skip
    trapped = render_summary({**base, "not_arrived": "leader trapped"})
    assert "no: leader trapped (leader 21.60 m short; tolerance 0.200 m)" in trapped
    stuck = render_summary({**base, "not_arrived": "deadlock"})
    assert "no: deadlock (a follower 2.41 m off its slot; tolerance 0.200 m)" in stuck
    assert "livelocks                 2 (longest 31.50 s)" in stuck
    old = render_summary({k: v for k, v in base.items() if k != "arrived"})  # an older log
    assert "arrival" not in old and "margins" not in old


def test_run_on_an_unreachable_router_says_so_and_starts_nothing(tmp_path: Path) -> None:
    """`shoal run --connect X` with no router at X said "logger not ready" after half a
    minute; it now names the router, before any process is started or any file written."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    out = tmp_path / "never.mcap"
    result = subprocess.run(
        [sys.executable, "-m", "shoal.tools", "run", "default", "--connect", endpoint,
         "--out", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 1
    assert f"the router at {endpoint}: cannot open a Zenoh session" in result.stderr
    assert "is a router running there?" in result.stderr and "logger" not in result.stderr
    assert not out.exists()


def test_simulate_out_names_the_file_it_writes_and_never_overwrites_unasked(
    tmp_path: Path,
) -> None:
    named = tmp_path / "run.mcap"  # not .npz: numpy would add it, so the path said is the real one
    first = CliRunner().invoke(main, ["simulate", "sinusoid", "--out", str(named)])
    assert first.exit_code == 0, first.output
    real = tmp_path / "run.mcap.npz"
    assert f"trajectories written to {real}" in first.output and real.exists()
    assert not named.exists() and not list(tmp_path.glob("*.part"))
    again = CliRunner().invoke(main, ["simulate", "sinusoid", "--out", str(real)])
    assert again.exit_code == 1 and "exists; pass --force" in again.output
    forced = CliRunner().invoke(main, ["simulate", "sinusoid", "--out", str(real), "--force"])
    assert forced.exit_code == 0, forced.output
    nowhere = CliRunner().invoke(main, ["simulate", "sinusoid", "--out", str(tmp_path / "a/b.npz")])
    assert nowhere.exit_code == 1 and "is not a folder" in nowhere.output


def test_summary_rows_that_could_look_like_faults_say_what_they_mean() -> None:
    """A bound of 0 s (agents start on their slots) and Assumption 2 counted in the run read
    as errors on a good run."""
    base = json.loads(CliRunner().invoke(main, ["simulate", "passage", "--json"]).stdout)
    rows = dict(
        line.split(None, 1) if not line.startswith("Assumption") else line.split("  ", 1)
        for line in render_summary(
            {**base, "convergence_time": 0.0, "convergence_bound": 0.0,
             "assumption2_violations": 54}
        ).splitlines()
    )  # fmt: skip
    assert rows["convergence"].startswith("0.00 s: the agents started within tolerance")
    a2 = rows["Assumption 2 in the run"].strip()
    assert a2.startswith("54 ticks in which an evading agent and all its neighbours evaded")


def test_scenarios_new_makes_unicycles_in_the_plane_only() -> None:
    made = CliRunner().invoke(main, ["scenarios", "new", "-n", "5", "--kinematics", "unicycle"])
    assert made.exit_code == 0, made.output
    s = parse_scenario(made.stdout)
    assert s.unicycle is not None and s.control.safety_margin >= s.body_reach
    refused = CliRunner().invoke(
        main, ["scenarios", "new", "-n", "5", "--dim", "3", "--kinematics", "unicycle"]
    )
    assert refused.exit_code == 1 and "drive in the plane" in refused.output
