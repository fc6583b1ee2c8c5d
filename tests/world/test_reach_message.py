"""The loader's reach errors (world/assumptions.py ``_safety``) print a formula, its terms and
its value: the value is the formula of the terms it prints, so a reader can check it by hand."""

from __future__ import annotations

import math
import re
from importlib import resources

import pytest
import yaml

from shoal.world.errors import ScenarioError
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.unicycle import arc_departure

NUMBER = r"([0-9.e+-]+)"


def _robotarium(**control: float) -> str:
    text = resources.files("shoal.world.scenarios").joinpath("robotarium.yaml").read_text()
    data = yaml.safe_load(text)
    data["control"].update(control)
    return yaml.safe_dump(data)


def _refusal(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text)
    return caught.value


def _terms(error: ScenarioError, field: str, formula: str, closing: str) -> tuple[float, ...]:
    """The reach's printed terms (agent_radius, l, l·x²/2) and value from ``error``, which must
    name ``field`` and print ``formula`` then the three terms, ``closing`` and the value."""
    assert error.field == field
    said = str(error)
    found = re.search(
        f"{re.escape(formula)}{NUMBER} \\+ {NUMBER} \\+ {NUMBER}{re.escape(closing)} = {NUMBER} m",
        said,
    )
    assert found, said
    return tuple(map(float, found.groups()))


def test_a_unicycles_separation_is_twice_its_printed_reach_and_says_so() -> None:
    s = load_scenario("robotarium")
    assert s.unicycle is not None
    error = _refusal(_robotarium(safety_margin=0.15, separation=0.25, sensing_radius=0.8,
                                 trigger_radius=0.6))  # fmt: skip
    said = str(error)
    radius, ell, departure, value = _terms(
        error, "control.separation", "2·(agent_radius + l + l·x²/2) = 2·(", ")"
    )
    assert value == pytest.approx(2 * (radius + ell + departure), rel=1e-5)
    # the terms are the scenario's, the departure l·x²/2 at v_max (sin x = v_max·dt/2l)
    assert radius == s.agent_radius and ell == s.unicycle.lookahead
    x = math.asin(s.speed_limit * s.dt / (2 * ell))
    assert departure == pytest.approx(ell * x * x / 2, rel=1e-5)
    assert departure == pytest.approx(arc_departure(s.speed_limit, ell, s.dt), rel=1e-5)
    assert value == pytest.approx(2 * s.body_reach, rel=1e-6)
    assert "2·agent_radius + l" not in said  # the old text, half of what it showed


def test_a_unicycles_guard_is_its_printed_reach_once() -> None:
    error = _refusal(_robotarium(safety_margin=0.12, sensing_radius=0.8, trigger_radius=0.6))
    radius, ell, departure, value = _terms(
        error, "control.safety_margin", "is less than agent_radius + l + l·x²/2 = ", ""
    )
    assert value == pytest.approx(radius + ell + departure, rel=1e-5)
    assert value == pytest.approx(load_scenario("robotarium").body_reach, rel=1e-6)


def test_a_point_robots_separation_is_twice_its_radius() -> None:
    data = yaml.safe_load(load_scenario("default").source)
    data["control"]["separation"] = 0.05
    said = str(_refusal(yaml.safe_dump(data)))
    found = re.search(f"less than 2·agent_radius = {NUMBER} m:", said)
    assert found, said
    assert float(found.group(1)) == pytest.approx(2 * load_scenario("default").agent_radius)
