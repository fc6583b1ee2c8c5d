"""``shoal plot``: the figures show the run's own numbers, and the command writes PNG and SVG."""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D

from shoal.tools.campaign.fields import FieldOptions, make_field
from shoal.tools.campaign.shapes import new_scenario
from shoal.tools.cli import main
from shoal.tools.plot.figures import (
    FIGURES,
    RunView,
    colour,
    consensus,
    distances,
    formation_error,
    omega_timeline,
    trajectories,
)
from shoal.tools.simulator import simulate
from shoal.world.errors import BetaWarning
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.metrics import Sweep, clearances


@functools.cache
def view_of(name: str) -> RunView:
    scenario = load_scenario(name)
    return RunView(scenario=scenario, traj=simulate(scenario), label=name)


def data_lines(ax: object) -> list[Line2D]:
    """Lines that carry data (not the axhline/axvline markers, whose data are 2 points)."""
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]  # type: ignore[attr-defined]


def test_distances_show_the_closest_approach_the_metrics_measure() -> None:
    """The lines are tick samples; the titles give the least over whole steps, the summary's
    figures, which no sample is below."""
    view = view_of("default")
    summary = view.summary()
    top, bottom = distances(view).axes
    plotted = min(float(np.min(ln.get_ydata())) for ln in data_lines(top))
    assert plotted >= summary.min_interagent_distance
    assert f"(min {summary.min_interagent_distance:.3f} m)" in top.get_title()
    clear = min(float(np.min(ln.get_ydata())) for ln in data_lines(bottom))
    assert clear == float(clearances(view.scenario, view.traj).min())
    assert summary.min_clearance is not None and clear >= summary.min_clearance
    assert f"(min {summary.min_clearance:.3f} m)" in bottom.get_title()
    # one line per graph edge plus the closest non-neighbours: every pair is covered
    assert len(data_lines(top)) == len(view.scenario.edges) + 1


def test_a_collision_shows_below_zero_against_lines_at_their_true_values() -> None:
    """A run that collides (field 0 of the campaign, Algorithm 2 alone): the clearance axis is
    not clipped at 0, and the lines are the agent radius (collision) and the guard ρ."""
    field = make_field(load_scenario("obstacles"), 0, options=FieldOptions(safety="paper"))
    view = RunView(scenario=field, traj=simulate(field), label="collides")
    worst = float(clearances(field, view.traj).min())
    assert worst < 0  # the agent went into the obstacle
    _top, bottom = distances(view).axes
    assert bottom.get_ylim()[0] <= worst
    lines = {
        str(ln.get_label()): float(ln.get_ydata()[0])
        for ln in bottom.get_lines()
        if len(ln.get_xdata()) == 2
    }
    assert lines[f"collision (radius {field.agent_radius:g} m)"] == field.agent_radius
    rho = field.control.safety_margin
    assert lines[f"guard ρ = {rho:g} m"] == rho and rho != field.agent_radius


def test_no_follower_wears_the_leaders_colour_however_many_there_are() -> None:
    leader = to_rgba(colour(0))
    followers = [to_rgba(colour(k)) for k in range(1, 60)]
    assert leader not in followers
    assert len(set(followers[:18])) == 18  # the first 18 followers are told apart


def test_formation_error_marks_the_theorem1_bound_and_the_measured_convergence() -> None:
    view = view_of("default")
    summary = view.summary()
    (ax,) = formation_error(view).axes
    vertical = {
        ln.get_label(): ln.get_xdata()[0] for ln in ax.get_lines() if len(ln.get_xdata()) == 2
    }
    bound = next(x for label, x in vertical.items() if label.startswith("Theorem 1"))
    converged = next(x for label, x in vertical.items() if label.startswith("converged"))
    assert bound == summary.convergence_bound and summary.convergence_bound < 20.0
    assert converged == summary.convergence_time
    assert len(data_lines(ax)) == view.scenario.n - 1  # one per follower


def test_a_leader_faster_than_beta_has_no_bound_line_and_still_plots() -> None:
    """β ≤ the leader's speed: Theorem 1 gives no bound (inf), a warning and a normal run."""
    with pytest.warns(BetaWarning):
        scenario = parse_scenario(
            load_scenario("sinusoid").source.replace("beta: 2.0", "beta: 1.1")
        )
    view = RunView(scenario=scenario, traj=simulate(scenario), label="fast")
    assert view.summary().convergence_bound == float("inf")
    (ax,) = formation_error(view).axes
    labels = [str(ln.get_label()) for ln in ax.get_lines()]
    assert not any(label.startswith("Theorem 1") for label in labels), labels


def test_consensus_panel_shows_every_agent_reaching_the_maximum_bid() -> None:
    view = view_of("passage")
    _top, bottom = consensus(view).axes
    rounds = data_lines(bottom) or bottom.get_lines()
    assert len(rounds) == view.scenario.n
    top_bid = float(view.traj.bid.max())
    assert top_bid == pytest.approx(4.0)
    # Proposition 1: after L_G rounds every agent holds the largest bid
    finals = [float(ln.get_ydata()[view.scenario.rounds]) for ln in rounds]
    assert finals == [top_bid] * view.scenario.n
    starts = [float(ln.get_ydata()[0]) for ln in rounds]
    assert starts.count(top_bid) < view.scenario.n  # it did take rounds to spread


def test_omega_timeline_has_one_bar_per_evasion_episode() -> None:
    view = view_of("default")
    (ax,) = omega_timeline(view).axes
    bars = [c for c in ax.collections if isinstance(c, PolyCollection)]
    episodes = sum(len(c.get_paths()) for c in bars)
    assert episodes == view.summary().omega_episodes
    assert episodes >= 2  # both obstacles of the route are evaded


def test_plot_command_writes_every_figure_as_png_and_svg(tmp_path: Path) -> None:
    text = load_scenario("sinusoid").source.replace("duration: 30.0", "duration: 0.5")
    assert "duration: 0.5" in text
    scenario_file = tmp_path / "short.yaml"
    scenario_file.write_text(text)
    log = tmp_path / "run.mcap"
    ran = CliRunner().invoke(
        main, ["run", str(scenario_file), "--json", "--no-foxglove", "--out", str(log)]
    )
    assert ran.exit_code == 0, ran.output
    out = tmp_path / "figs"
    drawn = CliRunner().invoke(main, ["plot", str(log), "--out", str(out)])
    assert drawn.exit_code == 0, drawn.output
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(f"run-{f}.{ext}" for f in FIGURES for ext in ("png", "svg"))  # log's
    for path in out.iterdir():
        if path.suffix == ".png":
            assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        else:
            assert ET.parse(path).getroot().tag.endswith("svg")
    # Nothing is replaced without --force: not the log, not the figures, not the views.
    logged = log.read_bytes()
    again = CliRunner().invoke(
        main, ["run", str(scenario_file), "--no-foxglove", "--out", str(log)]
    )
    assert again.exit_code == 1 and f"{log} exists; pass --force" in again.output
    assert log.read_bytes() == logged
    redrawn = CliRunner().invoke(main, ["plot", str(log), "--out", str(out)])
    assert redrawn.exit_code == 1 and "exists; pass --force" in redrawn.output
    forced = CliRunner().invoke(main, ["plot", str(log), "--out", str(out), "--force"])
    assert forced.exit_code == 0, forced.output
    views = CliRunner().invoke(main, ["export", str(log)])
    assert views.exit_code == 0, views.output
    twice = CliRunner().invoke(main, ["export", str(log)])
    assert twice.exit_code == 1 and "run.foxglove.mcap exists; pass --force" in twice.output
    assert CliRunner().invoke(main, ["export", str(log), "--force"]).exit_code == 0
    # An output that cannot be written: one clear error each, no traceback.
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    for command in (
        ["export", str(log), "-o", str(blocker / "views.mcap")],
        ["plot", str(log), "--out", str(blocker / "figs")],
        ["recover", str(log), "-o", str(blocker / "fixed.mcap")],
        ["run", str(scenario_file), "--out", str(blocker / "run.mcap")],
    ):
        failed = CliRunner().invoke(main, command)
        assert failed.exit_code == 1 and "cannot be written" in failed.output, failed.output


def test_plot_refuses_a_file_without_a_run(tmp_path: Path) -> None:
    empty = tmp_path / "empty.mcap"
    from mcap.writer import Writer

    with empty.open("wb") as f:
        writer = Writer(f)
        writer.start()
        writer.finish()  # type: ignore[no-untyped-call]
    result = CliRunner().invoke(main, ["plot", str(empty), "--out", str(tmp_path / "x")])
    assert result.exit_code == 1
    assert "no scenario recorded" in result.output


def test_plot_names_an_unknown_figure_and_refuses_a_file_that_is_not_mcap() -> None:
    bogus = CliRunner().invoke(main, ["plot", __file__, "--figure", "nope"])
    assert bogus.exit_code == 1 and "unknown figure(s) ['nope']" in bogus.output
    garbage = CliRunner().invoke(main, ["plot", __file__])
    assert garbage.exit_code == 1 and "not an MCAP file" in garbage.output


def test_trajectories_mark_every_collision_where_it_began() -> None:
    """Field 0 of the campaign with Algorithm 2 alone collides: each onset is an ×, at the
    colliding agent's position at that moment, and the title counts them."""
    field = make_field(load_scenario("obstacles"), 0, options=FieldOptions(safety="paper"))
    view = RunView(scenario=field, traj=simulate(field), label="collides")
    (ax,) = trajectories(view).axes
    (marks,) = [ln for ln in ax.get_lines() if ln.get_label() == "collision (where it began)"]
    swept = Sweep.of(field, view.traj)
    clear = swept.clearance < field.agent_radius - swept.slack  # over whole steps, as summarized
    onsets = [
        (k, i)
        for i in range(field.n)
        for k in range(clear.shape[0])
        if clear[k, i].any() and (k == 0 or not clear[k - 1, i].any())
    ]
    assert onsets  # it does collide
    spots = {
        (float(x), float(y)) for x, y in zip(marks.get_xdata(), marks.get_ydata(), strict=True)
    }
    assert spots == {tuple(float(c) for c in view.traj.positions[k, i, :2]) for k, i in onsets}
    assert f"{len(onsets)} collision" in ax.get_title()
    safe = view_of("obstacles")
    (clean,) = trajectories(safe).axes
    assert not [ln for ln in clean.get_lines() if ln.get_label() == "collision (where it began)"]


def test_a_big_formation_names_followers_on_the_plot_not_in_the_legend() -> None:
    text = new_scenario(shape="grid", agents=14, length=3.0)
    scenario = parse_scenario(text)
    view = RunView(scenario=scenario, traj=simulate(scenario), label="grid")
    (ax,) = trajectories(view).axes
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "agent 1 (leader)" in labels and "agent 2" not in labels
    assert len(labels) <= 8
    ends = {t.get_text() for t in ax.texts}
    assert ends == {str(i) for i in range(2, 15)}  # every follower's id, at its path's end


def test_a_3d_run_shows_its_height_in_two_more_projections() -> None:
    scenario = parse_scenario(new_scenario(shape="grid", agents=8, dim=3, length=3.0))
    assert float(np.ptp(scenario.offsets[:, 2])) > 0  # the grid's second layer flies higher
    view = RunView(scenario=scenario, traj=simulate(scenario), label="3-D")
    axes = trajectories(view).axes
    assert [(a.get_xlabel(), a.get_ylabel()) for a in axes] == [
        ("x (m)", "y (m)"), ("x (m)", "z (m)"), ("y (m)", "z (m)"),
    ]  # fmt: skip
    heights = np.concatenate([ln.get_ydata() for ln in data_lines(axes[1])])
    assert float(heights.max()) == pytest.approx(float(view.traj.positions[:, :, 2].max()))


def test_moving_obstacles_are_drawn_with_their_trails_and_contacts_they_made_are_marked() -> None:
    """crossing: each person's trail is the path the run recorded; a field where blind walkers
    run into the leader marks those contacts as theirs (not as collisions)."""
    view = view_of("crossing")
    (ax,) = trajectories(view).axes
    movers = view.traj.movers
    assert movers is not None
    trails = [ln for ln in data_lines(ax) if ln.get_color() == "purple"]
    assert len(trails) == movers.shape[1]
    for q, ln in enumerate(trails):
        assert np.array_equal(ln.get_xdata(), movers[:, q, 0])
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(t.startswith("moving obstacle") for t in legend)

    from shoal.tools.campaign.people import PeopleOptions, add_people
    from shoal.world.contacts import contacts

    field = add_people(
        load_scenario("obstacles"), 4, FieldOptions(), PeopleOptions(speed=1.75, model="blind")
    )
    run = RunView(scenario=field, traj=simulate(field), label="pinned")
    theirs = [c for c in contacts(field, run.traj) if not c.agent_at_fault]
    assert theirs  # blind walkers at 1.75 m/s corner the leader in this field
    (ax,) = trajectories(run).axes
    (marks,) = [ln for ln in ax.get_lines() if ln.get_label() == "walked into by a moving obstacle"]
    assert len(marks.get_xdata()) == len(theirs)
    assert "collision" not in ax.get_title()


def test_the_legend_lists_only_what_the_figure_draws() -> None:
    """crossing has people and no standing obstacle, and nobody evades: no obstacle entries."""
    legend = {
        name: {t.get_text() for t in trajectories(view_of(name)).axes[0].get_legend().get_texts()}
        for name in ("crossing", "obstacles")
    }
    drawn_only_with_obstacles = {"obstacle", "obstacle + trigger radius", "evading (Ω = 1)"}
    assert not legend["crossing"] & drawn_only_with_obstacles
    assert any(label.startswith("moving obstacle") for label in legend["crossing"])
    assert drawn_only_with_obstacles <= legend["obstacles"]
