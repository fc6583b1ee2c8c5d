"""What a run's processes hand each other once: an agent's end-of-run report (bus/report.py),
which the world folds into the summary, and the scenario the supervisor hands the world."""

from __future__ import annotations

from pathlib import Path

from shoal.agent.delivery import AgeStats, Dropper
from shoal.bus import codec
from shoal.bus.report import FIGURES, report_body, reports_in, summary_entries
from shoal.tools.commands.world import scenario_of
from shoal.tools.procs.children import WorldSpec
from shoal.tools.procs.launch import _hand_over
from shoal.world.loader import load_scenario


def test_a_report_round_trips_through_the_summary() -> None:
    body = report_body({"last_tick": 99, "bad_messages": 2, "peak_rss_kb": 40_000})
    assert set(body) == set(FIGURES) and body["age_p99"] is None
    wire = codec.decode_document("report", codec.encode_document("report", body))
    summary = {"collisions": 0, **summary_entries(3, wire), **summary_entries(1, wire)}
    got = reports_in(summary)
    assert list(got) == [1, 3]
    assert got[3] == body


def test_what_is_not_a_figure_is_left_out() -> None:
    entries = summary_entries(2, {"last_tick": 5, "bad_messages": "many", "peak_rss_kb": 1.5,
                                  "age_p50": True, "secret": 7})  # fmt: skip
    assert entries["agent_2.last_tick"] == 5
    assert "agent_2.bad_messages" not in entries and "agent_2.peak_rss_kb" not in entries
    assert "agent_2.age_p50" not in entries and "agent_2.secret" not in entries
    assert reports_in({"agent_x.last_tick": 1, "agent_2.nonsense": 1}) == {}


def test_an_agents_figures_are_its_own_counters() -> None:
    d, a = Dropper(0.5, 1, 2), AgeStats()
    for _ in range(200):
        d.drop()
    body = report_body({"states_heard": d.offered, "injected_drops": d.dropped,
                        "age_p99": a.quantile(0.99)})  # fmt: skip
    assert body["states_heard"] == 200 and 60 < (body["injected_drops"] or 0) < 140
    assert body["age_p99"] is None  # no state used yet


def test_the_world_is_handed_the_text_the_supervisor_parsed_under_the_same_name(
    tmp_path: Path,
) -> None:
    """The scenario was once parsed by `shoal run` and again, from its file, by the world
    (the file may change in between). The world now gets a copy of the parsed text and the
    name it was parsed under (`--name`) — even a name that is no file name."""
    for stem, text in (
        ("mine", load_scenario("sinusoid").source.replace("name: sinusoid\n", "")),
        ("my run (2)", load_scenario("passage").source.replace("name: passage\n", "")),
        ("named", load_scenario("obstacles").source),
    ):
        original = tmp_path / f"{stem}.yaml"
        original.write_text(text)
        parsed = load_scenario(original)
        folder = tmp_path / f"run-{len(list(tmp_path.iterdir()))}"
        folder.mkdir()
        handed = _hand_over(parsed, folder)
        original.write_text("changed: after it was parsed\n")  # the world never sees this
        again = scenario_of(WorldSpec(scenario=str(handed), name=parsed.name, run_id="r"))
        assert again.name == parsed.name and again.steps == parsed.steps
        assert again.agents == parsed.agents and again.obstacles == parsed.obstacles


def test_an_agent_reports_its_proportional_set_size_below_its_resident_size() -> None:
    """Memory per agent as PSS (shared pages counted once) beside RSS. This process
    shares its interpreter and libraries with nobody it forked, so PSS ≤ RSS, and both > 0."""
    import resource
    import sys

    from shoal.bus.report import pss_kb

    pss = pss_kb()
    if not sys.platform.startswith("linux"):
        assert pss is None
        return
    assert pss is not None and 0 < pss <= resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    body = report_body({"pss_kb": pss})
    assert reports_in(summary_entries(1, body))[1]["pss_kb"] == pss
