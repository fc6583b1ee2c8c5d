"""`shoal campaign --plant mujoco`: every field on robots with mass, judged by the engine.

The fields are the kinematic campaign's, with a ``dynamics:`` section that names their robots;
the report takes collisions and margins from the engine and adds its contacts, the fields that
entered the guard or the separation band, and the tracking error; a saved field reruns to the
same figures with ``shoal simulate --plant mujoco``. Small campaigns (short paths, one or two
fields) keep this module well under a minute.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner, Result

from shoal.tools.campaign.fields import FieldOptions, make_field, robots_section
from shoal.tools.campaign.hard import hard_field
from shoal.tools.cli import main
from shoal.world.dynamics import Drive
from shoal.world.loader import load_scenario, parse_scenario

pytest.importorskip("mujoco")

OBSTACLES = load_scenario("obstacles")
SHORT = ["--length", "8", "--jobs", "2"]  # 1,300 ticks a field: a few CPU seconds in MuJoCo
ENGINE_KEYS = (
    "engine_contacts", "engine_contact_fields", "engine_deepest_contact", "entered_guard",
    "entered_separation", "tracking_error_p50", "tracking_error_p99", "tracking_error_max",
)  # fmt: skip


def shoal(*args: str) -> Result:
    result = CliRunner().invoke(main, list(args))
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def without_robots(source: str) -> Any:
    """A field's YAML as data, its robots and comments left out."""
    data = yaml.safe_load(source)
    data.pop("dynamics", None)
    return data


def test_a_field_on_robots_with_mass_is_the_kinematic_field_with_its_robots() -> None:
    opts = FieldOptions(plant="mujoco", dynamics="holonomic-heavy", latency=0.03)
    field = make_field(OBSTACLES, 3, "inside", opts)
    assert without_robots(field.source) == without_robots(make_field(OBSTACLES, 3).source)
    assert "# Reproduce: shoal simulate --plant mujoco THIS_FILE" in field.source
    assert yaml.safe_load(field.source)["dynamics"] == {
        "preset": "holonomic-heavy",
        "latency": 0.03,
    }
    robots = parse_scenario(field.source).robot_dynamics()
    assert {(r.preset, r.latency) for r in robots} == {("holonomic-heavy", 0.03)}
    # without --dynamics the file still names its robots: the default for its agents
    unicycles = make_field(
        OBSTACLES, 3, "inside", FieldOptions(plant="mujoco", kinematics="unicycle")
    )
    assert yaml.safe_load(unicycles.source)["dynamics"] == {"preset": "gritsbot"}
    assert {r.drive for r in unicycles.robot_dynamics()} == {Drive.DIFFERENTIAL}
    # the kinematic campaign's fields carry none
    assert "dynamics" not in yaml.safe_load(make_field(OBSTACLES, 3).source)


def test_a_hard_field_on_robots_with_mass_carries_them_too() -> None:
    robots = robots_section(FieldOptions(plant="mujoco", dynamics="turtlebot3"), True)
    field = hard_field(5, 2, unicycles=True, robots=robots)
    plain = hard_field(5, 2, unicycles=True)
    assert without_robots(field.source) == without_robots(plain.source)
    assert "# Reproduce: shoal simulate --plant mujoco THIS_FILE" in field.source
    assert {r.preset for r in field.robot_dynamics()} == {"turtlebot3"}  # read from its text
    in_space = hard_field(5, 3, robots=robots_section(FieldOptions(plant="mujoco"), False))
    assert {r.preset for r in in_space.robot_dynamics()} == {"holonomic"}


def test_a_physics_campaign_reports_the_engine_and_its_fields_rerun(tmp_path: Path) -> None:
    failures, lagging = tmp_path / "failures", tmp_path / "lagging"
    result = shoal(
        "campaign", "--fields", "2", *SHORT, "--plant", "mujoco", "--latency-ms", "30",
        "--json", "--save-failures", str(failures), "--save-lagging", str(lagging),
    )  # fmt: skip
    rep = json.loads(result.stdout)
    assert (rep["plant"], rep["dynamics"], rep["latency"]) == ("mujoco", "holonomic", 0.03)
    inside = rep["sets"]["inside"]
    assert inside["fields"] == 2 and inside["plant"] == "mujoco"
    assert all(key in inside for key in ENGINE_KEYS)
    assert inside["obstacle_collided"] is None and inside["agent_collided"] is None
    # the baseline as it stands: 4 m/s² bases cannot follow the law's dashes
    assert inside["collided"] >= 1 and inside["engine_contacts"] >= inside["collisions"] >= 1
    assert inside["engine_deepest_contact"] < 0
    assert inside["guard_margin"] < 0 and inside["entered_guard"] >= 1
    assert 0 < inside["tracking_error_p50"] < inside["tracking_error_p99"]
    assert inside["tracking_error_p99"] <= inside["tracking_error_max"]
    assert result.exit_code == 1  # an inside field collided (on robots with mass)
    assert "on robots with mass" in result.stderr
    # each field's row is the engine's, and the set's figures are the rows'
    rows = rep["failures"]
    assert len(rows) == inside["collided"]
    assert sum(f["collisions"] for f in rows) == inside["collisions"]
    assert min(f["guard_margin"] for f in rows) >= inside["guard_margin"]
    assert min(f["engine_deepest_contact"] for f in rows) == inside["engine_deepest_contact"]
    # a saved field reruns to the same figures
    row = rows[0]
    assert row["rerun"] == "simulate --plant mujoco"
    saved = Path(row["file"])
    assert yaml.safe_load(saved.read_text())["dynamics"] == {"preset": "holonomic", "latency": 0.03}
    rerun = json.loads(shoal("simulate", str(saved), "--plant", "mujoco", "--json").stdout)
    for key in ("collisions", "engine_contacts", "engine_deepest_contact", "min_clearance",
                "min_interagent_distance", "guard_margin", "separation_margin"):  # fmt: skip
        assert rerun[key] == row[key], key
    assert rerun["dynamics"] == "holonomic"
    again = json.loads(
        shoal("campaign", "--rerun", str(saved), "--plant", "mujoco", "--json").stdout
    )
    assert {k: again[k] for k in rerun} == rerun


def test_unicycles_on_differential_drives_in_the_text_report() -> None:
    result = shoal(
        "campaign", "--fields", "1", *SHORT, "--plant", "mujoco", "--kinematics", "unicycle",
        "--dynamics", "turtlebot3",
    )  # fmt: skip
    assert result.exit_code in (0, 1), result.output
    text = result.stdout
    row = re.search(r"^inside\s+turtlebot3\s+(\d+)\s+(\d+)\s+(-?[\d.]+)\s+(\d+)\s+(\d+)\s+"
                    r"([\d.]+)\s+([\d.]+)\s+([\d.]+)$", text, re.MULTILINE)  # fmt: skip
    assert row is not None, text
    contacts, fields, deepest, guard, band = (float(x) for x in row.groups()[:5])
    assert fields <= contacts and deepest <= 0 and guard <= 1 and band <= 1
    p50, p99, top = (float(x) for x in row.groups()[5:])
    assert 0 < p50 <= p99 <= top
    assert "robots with mass: mujoco (turtlebot3)" in text
    assert "every agent a unicycle" in text


def test_the_kinematic_campaign_says_nothing_of_an_engine() -> None:
    result = shoal("campaign", "--fields", "1", "--length", "8", "--jobs", "1", "--json")
    rep = json.loads(result.stdout)
    assert "plant" not in rep and not any(key in rep["sets"]["inside"] for key in ENGINE_KEYS)
    assert isinstance(rep["sets"]["inside"]["obstacle_collided"], int)
    text = shoal("campaign", "--fields", "1", "--length", "8", "--jobs", "1").stdout
    assert "engine contacts" not in text and "robots with mass" not in text


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--latency-ms", "30"], r"--latency-ms: is for robots with mass: add --plant mujoco"),
        (["--dynamics", "holonomic"], r"--dynamics: is for robots with mass: add --plant mujoco"),
        (["--plant", "mujoco", "--dynamics", "gritsbot"],
         r"gritsbot is a differential drive, but the fields' agents are single integrators "
         r"\(--kinematics unicycle makes them unicycles\): choose one of holonomic, "
         r"holonomic-heavy"),
        (["--plant", "mujoco", "--kinematics", "unicycle", "--dynamics", "holonomic-heavy"],
         r"holonomic-heavy is a holonomic drive, but the fields' agents are unicycles: choose "
         r"one of gritsbot, turtlebot3"),
        (["--plant", "mujoco", "--kind", "hard", "--dynamics", "turtlebot3"],
         r"turtlebot3 is a differential drive, but the fields' agents are single integrators"),
        (["--rerun", __file__, "--latency-ms", "30"],
         r"--latency-ms: not with --rerun: the saved field's dynamics: section sets it"),
        (["--plant", "mujoco", "--swarm", "1"], r"not with --swarm or --people"),
        (["--plant", "mujoco", "--people", "2"], r"not with --swarm or --people"),
    ],
)  # fmt: skip
def test_options_that_cannot_run_are_refused_before_any_field(
    args: list[str], message: str
) -> None:
    result = shoal("campaign", "--fields", "1", "--length", "8", "--jobs", "1", *args)
    assert result.exit_code == 2, result.output
    assert re.search(message, " ".join(result.stderr.split())), result.stderr
    assert "fields/s" not in result.output  # nothing ran


def test_a_latency_of_zero_is_written_too() -> None:
    opts = FieldOptions(plant="mujoco", dynamics="gritsbot", latency=0.0, kinematics="unicycle")
    robots = yaml.safe_load(make_field(OBSTACLES, 0, "inside", opts).source)["dynamics"]
    assert robots == {"preset": "gritsbot", "latency": 0.0}
