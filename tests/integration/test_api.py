"""The Python API, called as a user calls it: docs/api.md's example, run as it is written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import shoal
from shoal.world.errors import ScenarioError

DOC = Path(__file__).resolve().parents[2] / "docs" / "api.md"


def test_the_api_reaches_the_reference_and_its_figures() -> None:
    scenario = shoal.load("passage")
    traj = shoal.simulate("passage")
    assert traj.equals(shoal.simulate(scenario))
    summary = shoal.summarize(scenario, traj)
    assert (summary.collisions, summary.sigma) == (0, pytest.approx(4.0, abs=1e-5))


def test_a_bad_scenario_is_refused_with_its_name() -> None:
    with pytest.raises(ScenarioError, match="no-such-scenario"):
        shoal.load("no-such-scenario")


@pytest.mark.integration
def test_the_example_in_docs_api_md_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    assert len(blocks) == 1 and blocks[0].count('"default"') == 2
    short = tmp_path / "short.yaml"  # default up to its corner (20 s), not its 40 s
    short.write_text(shoal.load("default").source.replace("duration: 40.0", "duration: 20.0"))
    monkeypatch.chdir(tmp_path)
    exec(compile(blocks[0].replace('"default"', repr(str(short))), str(DOC), "exec"), {})
    out = capsys.readouterr().out
    assert "0 collisions" in out and "5 agent processes" in out
    assert (tmp_path / "runs" / "api-default.mcap").stat().st_size > 0
