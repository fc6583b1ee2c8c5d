"""`shoal scenarios new` (tools/campaign/shapes.py): formations of any size and shape whose
graph passes Assumptions 1 and 2, with obstacles inside every load-time check, written as YAML
the loader accepts and `shoal simulate` runs safely."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from shoal.tools.campaign.shapes import SHAPES, new_scenario, offsets
from shoal.tools.cli import main
from shoal.tools.simulator import simulate
from shoal.world.assumptions import check_graph
from shoal.world.loader import parse_scenario, scenario_from_dict
from shoal.world.metrics import summarize


@pytest.mark.parametrize(("shape", "dim"), list(itertools.product(SHAPES, (2, 3))))
@pytest.mark.parametrize("n", [2, 3, 7, 20])
def test_every_shape_keeps_its_spacing_and_its_graph_passes_a1_and_a2(
    shape: str, dim: int, n: int
) -> None:
    s = parse_scenario(new_scenario(shape=shape, agents=n, dim=dim, spacing=2.5))
    assert s.n == n and s.dim == dim and not s.obstacles
    assert np.array_equal(s.offsets[0], np.zeros(dim))  # the leader's slot
    gaps = [np.linalg.norm(a - b) for a, b in itertools.combinations(s.offsets, 2)]
    assert min(gaps) >= 2.5 - 1e-6
    check_graph(s)  # raises if an evading follower could cut anyone off
    if n >= 7:
        assert len(s.edges) < n * (n - 1) // 2  # nearest slots, not everyone with everyone


def test_a_removed_edge_that_cuts_someone_off_is_what_the_check_catches() -> None:
    """The graph check the maker relies on does fail on a chain (so the maker's graphs pass it
    because they are right, not because it passes everything)."""
    text = new_scenario(shape="column", agents=5)
    s = parse_scenario(text)
    chain = scenario_from_dict(
        {**_data(text), "graph": {"edges": [[1, 2], [2, 3], [3, 4], [4, 5]]}}
    )
    check_graph(s)
    with pytest.raises(Exception, match="Assumption 2"):
        check_graph(chain)


def _data(text: str) -> dict[str, object]:
    import yaml

    data = yaml.safe_load(text)
    assert isinstance(data, dict)
    return data


@pytest.mark.parametrize(("shape", "dim", "seed"), [("wedge", 2, 1), ("grid", 3, 2)])
def test_obstacles_are_drawn_inside_the_assumptions_and_the_run_is_safe(
    shape: str, dim: int, seed: int
) -> None:
    text = new_scenario(shape=shape, agents=6, dim=dim, obstacles=3, length=14.0, seed=seed)
    s = parse_scenario(text)  # every load-time check, obstacles included
    assert len(s.obstacles) == 3
    assert new_scenario(shape=shape, agents=6, dim=dim, obstacles=3, length=14.0, seed=seed) == text
    summary = summarize(s, simulate(s))
    assert summary.collisions == 0
    assert summary.leader_shortfall <= summary.tolerance


def test_the_cli_writes_a_file_that_runs_under_its_own_name(tmp_path: Path) -> None:
    out = tmp_path / "ring.yaml"
    made = CliRunner().invoke(
        main, ["scenarios", "new", "-n", "5", "--shape", "circle", "--length", "6", "-o", str(out)]
    )
    assert made.exit_code == 0, made.output
    assert out.read_text().startswith("# A circle of 5 agents")
    ran = CliRunner().invoke(main, ["simulate", str(out)])
    assert ran.exit_code == 0, ran.output
    assert "ring  (5 agents" in ran.output and "collisions                0" in ran.output
    again = CliRunner().invoke(main, ["scenarios", "new", "-n", "5", "-o", str(out)])
    assert again.exit_code == 1 and "exists; pass --force" in again.output
    printed = CliRunner().invoke(main, ["scenarios", "new", "-n", "3"])
    assert printed.exit_code == 0 and "name:" not in printed.output  # the file names it
    assert "passage" in CliRunner().invoke(main, ["scenarios"]).output  # the list, as before
    assert "max-consensus" in CliRunner().invoke(main, ["scenarios", "passage"]).output


@pytest.mark.parametrize(
    ("args", "code", "says"),
    [
        (["-n", "1"], 2, "x>=2"),
        (["-n", "4", "--shape", "blob"], 2, "'blob' is not one of"),
        (["-n", "4", "--spacing", "0"], 1, "spacing must be > 0"),
        (["-n", "4", "--obstacles", "40", "--length", "8"], 1, "could not place 40 obstacles"),
    ],
)
def test_impossible_options_are_one_clear_error(args: list[str], code: int, says: str) -> None:
    result = CliRunner().invoke(main, ["scenarios", "new", *args])
    assert result.exit_code == code and says in result.output, result.output


def test_offsets_of_an_unknown_shape_name_it() -> None:
    with pytest.raises(Exception, match="unknown shape 'blob'"):
        offsets("blob", 4, 1.0)
