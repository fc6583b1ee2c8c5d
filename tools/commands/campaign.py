"""``shoal campaign``: the safety campaign over random obstacle fields (docs/campaign.md)."""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import click

from shoal.bus.runtime import exit_on_signals
from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.campaign.cluster import ClusterError, run_on_dask
from shoal.tools.campaign.fields import (
    BREACHES,
    FieldError,
    FieldOptions,
    breaches,
    load_field,
    make_field,
)
from shoal.tools.campaign.hard import HARD_MODES, hard_field
from shoal.tools.campaign.people import (
    MODELS,
    PeopleOptions,
    PeopleOutcome,
    PeopleTask,
    people_report,
    render_people,
    run_people_task,
)
from shoal.tools.campaign.report import render, report
from shoal.tools.campaign.runner import (
    Outcome,
    measure,
    run_campaign,
    run_task,
    saved_stem,
    tasks,
)
from shoal.tools.campaign.runner import save_failures as write_failures
from shoal.tools.campaign.swarms import (
    Faults,
    Swarming,
    render_swarms,
    run_swarms,
    swarm_report,
)
from shoal.tools.commands.options import check_layer, check_plant, layer_option, load_for_cli
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.extras import require
from shoal.tools.procs.children import PLANT_OPTIONS, WorldSpec, click_options
from shoal.tools.procs.swarm import SUPERVISOR_GRACE_S, ChildFailed
from shoal.tools.progress import progress_bar
from shoal.tools.simulator import reference
from shoal.world.dynamics import PRESETS, Drive
from shoal.world.errors import ScenarioError
from shoal.world.metrics import summarize
from shoal.world.plant import KINEMATICS
from shoal.world.scenario import Scenario

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class Workers:
    """Where the fields run: ``jobs`` local processes, or the Dask cluster at ``dask``."""

    jobs: int
    dask: str | None = None

    def run(
        self, todo: Sequence[T], done: Callable[[R], None], work: Callable[[T], R]
    ) -> tuple[list[R], int]:
        """The outcomes in task order, and how many workers ran them."""
        if self.dask is None:
            return run_campaign(todo, self.jobs, done, work), self.jobs
        try:
            return run_on_dask(todo, self.dask, done, work)
        except ClusterError as exc:
            raise click.ClickException(str(exc)) from None


def _count(text: str) -> tuple[int, int]:
    low, _, high = text.partition("-")
    try:
        bounds = (int(low), int(high or low))
    except ValueError:
        raise click.BadParameter(f"expected N or LOW-HIGH, got {text!r}") from None
    if not 0 <= bounds[0] <= bounds[1]:
        raise click.BadParameter(f"expected 0 ≤ LOW ≤ HIGH, got {text!r}")
    return bounds


@click.command()
@click.option(
    "--base",
    help="Scenario the fields are drawn around.  [default: obstacles; with --people: crossing]",
)
@click.option(
    "--fields",
    "count",
    default=100,
    type=click.IntRange(min=1),
    help="Fields to run: inside the assumptions (--kind hard: hard fields, half in 2-D, half "
    "in 3-D).  [default: 100]",
)
@click.option(
    "--outside/--no-outside",
    default=False,
    help="Also run --outside-fields fields for each assumption broken on purpose.",
)
@click.option(
    "--outside-fields", default=20, show_default=True, help="With --outside: fields per broken "
    "assumption.",
)  # fmt: skip
@click.option("--seed", default=0, help="Seed of the first field; field k has seed SEED+k.")
@click.option("--jobs", default=os.cpu_count() or 1, help="Worker processes.")
@click.option(
    "--dask",
    metavar="ADDRESS",
    help="Instead of --jobs: run the fields on the Dask cluster whose scheduler is at ADDRESS "
    "(e.g. tcp://10.0.0.1:8786; every worker needs this shoal; pip install 'shoal[cluster]').",
)
@click.option("--length", default=FieldOptions.length, help="Metres of the leader's path.")
@click.option("--obstacles", default="2-5", help="Obstacles per field: N or LOW-HIGH.")
@click.option("--spacing", default=0.0, help="Least free distance between obstacles, m.")
@click.option("--sigma-max", type=float, help="Override σ_max (1: no contraction).")
@click.option(
    "--kinematics",
    type=click.Choice(["single", "unicycle"]),
    help="Make every agent a single integrator or a unicycle (a base of single integrators "
    "gets unicycles with l = (ρ − agent_radius)/2, |v| ≤ 1.5·max(β·√dim, the field's speed "
    "limit); headings drawn per field; a field whose speed limit is l/dt or more runs k ticks "
    "for each of its base's, so that it is not; with --kind hard every field is drawn in 2-D) "
    "[default: the base's].",
)
@click.option(
    "--speed-limit", type=click.FloatRange(min=0.0, min_open=True), metavar="M_S",
    help="Every field's control.speed_limit, m/s: the robots' own cap [default: the base's, "
    "or the largest the lockstep theorem admits]. The far test of each robot's own safety layer "
    "believes it (docs/safety.md, Without a referee).",
)  # fmt: skip
@click.option(
    "--position-error", type=click.FloatRange(min=0.0), metavar="M",
    help="Every field's position_error, m: each robot's estimate off by up to this "
    "(docs/safety.md, Position error) [default: the base's].",
)  # fmt: skip
@click.option(
    "--boundary-layer", default=0.0, show_default=True, type=click.FloatRange(min=0.0),
    metavar="K", help="Run every field with the optional boundary layer φ = K·β·dt, sat(e/φ) in "
    "place of the paper's sign(e) (0: the paper's law; docs/campaign.md, Arrival).",
)  # fmt: skip
@click.option(
    "--safety",
    type=click.Choice(["filter", "paper", "both"]),
    default="filter",
    show_default=True,
    help="Run the fields with the safety filter, with Algorithm 2 alone (the paper), or both "
    "side by side (sets named SET/paper).",
)
@click.option(
    "--swarm",
    type=click.IntRange(min=1),
    help="Instead: run the first N inside fields as distributed swarms (real processes); "
    "with --people, each with its crowd.",
)
@click.option(
    "--swarm-clock",
    type=click.Choice(["lockstep", "realtime"]),
    default="realtime",
    show_default=True,
    help="--swarm: the clock (lockstep runs must also equal the reference bit for bit).",
)
@click.option(
    "--swarm-faults",
    metavar="DELAY_MS,JITTER_MS,DROP_RATE",
    default="0,0,0",
    show_default=True,
    help="--swarm, realtime: every agent's outgoing messages held back DELAY_MS ± JITTER_MS "
    "and DROP_RATE of the states it hears thrown away (shoal run's --delay-ms, --jitter-ms, "
    "--drop-rate).",
)
@click.option(
    "--swarm-safety-layer",
    type=click.Choice([str(r) for r in SafetyLayer]),
    default=None,
    help="--swarm: onboard, each robot's own layer (its radio has --swarm-faults too); referee, "
    "the world filters every command again with the true positions; none, applied as sent. "
    "Without the referee, what it would have changed is counted (docs/safety.md). "
    "[default: onboard in realtime, referee in lockstep]",
)
@click.option(
    "--save-failures",
    type=click.Path(file_okay=False, path_type=Path),
    help="Write every field that collided to this directory as scenario YAML.",
)
@click.option(
    "--save-lagging",
    type=click.Path(file_okay=False, path_type=Path),
    help="Write every safe field that stalled, did not settle or left its leader short of "
    "its goal to this directory as scenario YAML.",
)
@click.option(
    "--rerun",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Run one saved field (even one the loader refuses) and print its summary.",
)
@click.option(
    "--people",
    type=click.IntRange(min=1),
    help="Instead: inside fields with N people crossing the formation's path (docs/people.md).",
)
@click.option(
    "--people-speed", default=1.0, show_default=True, type=click.FloatRange(min=0.05),
    help="--people: their preferred walking speed, m/s.",
)  # fmt: skip
@click.option(
    "--people-model", type=click.Choice(MODELS), default="reactive", show_default=True,
    help="--people: social-force walkers who give way to the robots, or blind straight walkers.",
)  # fmt: skip
@click.option(
    "--agent-speed", default=PeopleOptions.agent_speed, show_default=True,
    type=click.FloatRange(min=0.05), help="--people: the robots' speed limit, m/s.",
)  # fmt: skip
@click.option(
    "--kind",
    type=click.Choice(["around", "hard"]),
    default="around",
    show_default=True,
    help="around: fields around BASE, inside the assumptions (and, with --outside, outside "
    "them); hard: the adversarial generator's admissible fields, half of --fields in 2-D and "
    "half in 3-D (docs/campaign.md, Hard fields).",
)
@click_options(WorldSpec, only=PLANT_OPTIONS)
@click.option(
    "--latency-ms", type=click.FloatRange(min=0.0, max=10_000.0), metavar="MS",
    help="--plant mujoco: every robot's actuation latency, ms, from a command to its motors "
    "acting on it [default: the preset's]. Written into each field's dynamics: section.",
)  # fmt: skip
@layer_option("every field's reference run (not --swarm: --swarm-safety-layer; not --people)")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
def campaign(**params: Any) -> None:
    """Run many random obstacle fields through the reference simulator, in parallel.

    --fields N runs N fields inside the paper's assumptions (every load-time check passes);
    --outside adds --outside-fields fields for each assumption broken on purpose
    (docs/campaign.md). Reports collisions, clearance
    and convergence per set, and the filter's activity and stalls. Exit status 1 if any inside
    field collides: that falsifies the guarantee (with --safety paper, the paper's
    Corollary 1). Outside collisions are data. 2 if a field could not be drawn.

    --plant mujoco runs every field on robots with mass (docs/campaign.md, Robots with mass):
    the engine judges collisions and margins, and each saved field carries its robots.
    --safety-layer reach runs every field through the reach layer and reports its brakes,
    slowed ticks and largest margin beside the time to goal.
    """
    if params["rerun"] is not None:
        if params["latency_ms"] is not None:
            raise click.BadParameter(
                "not with --rerun: the saved field's dynamics: section sets it",
                param_hint="--latency-ms",
            )
        _rerun(
            params["rerun"], params["as_json"], params["plant"], params["dynamics"], params["layer"]
        )
        return
    config = _config(params)
    _check_robots(config, params)
    if params["swarm"] is not None:
        if params["dask"] is not None:
            raise click.UsageError("--swarm runs real processes on this machine: not with --dask")
        _swarms(config, params["swarm"], _swarming(params, config.crowd))
        return
    if params["dask"] is not None:
        require("cluster", "--dask")  # before a field is drawn
    where = Workers(max(1, params["jobs"]), params["dask"])
    if config.crowd is not None:
        _people(config, config.crowd, where)
    else:
        _reference(config, where)


@dataclass(frozen=True)
class Campaign:
    """One ``shoal campaign``: fields ``seed``… around ``base``, drawn as ``fields`` says, and
    what becomes of them."""

    base: Scenario
    seed: int
    count: int  # fields inside the assumptions (hard fields, with ``hard``)
    fields: FieldOptions
    as_json: bool = False
    crowd: PeopleOptions | None = None  # fields with people crossing (docs/people.md)
    hard: bool = False  # the adversarial generator's fields
    outside: int | None = None  # fields per assumption broken on purpose; None: none
    modes: tuple[str, ...] = ("filter",)  # the safety each field runs with
    save_failures: Path | None = None
    save_lagging: Path | None = None


def _config(params: Mapping[str, Any]) -> Campaign:
    """The campaign the options ask for, checked."""
    latency = params["latency_ms"]
    fields = FieldOptions(
        length=params["length"], count=_count(params["obstacles"]), spacing=params["spacing"],
        sigma_max=params["sigma_max"], boundary_layer=params["boundary_layer"],
        kinematics=params["kinematics"], speed_limit=params["speed_limit"],
        position_error=params["position_error"], plant=params["plant"],
        dynamics=params["dynamics"], latency=None if latency is None else latency / 1000,
        layer=params["layer"],
    )  # fmt: skip
    people, safety = params["people"], params["safety"]
    scn = load_for_cli(params["base"] or ("crossing" if people is not None else "obstacles"))
    crowd = None
    if people is not None and safety != "filter":
        raise click.UsageError("--people needs the safety filter (docs/people.md)")
    if people is not None:
        crowd = PeopleOptions(
            count=people, speed=params["people_speed"], model=params["people_model"],
            agent_speed=params["agent_speed"],
        )  # fmt: skip
    hard = params["kind"] == "hard"
    if hard and (params["swarm"] is not None or people is not None or safety != "filter"):
        raise click.UsageError(
            "--kind hard draws fields for the reference simulator with the safety filter: "
            "not with --swarm, --people or --safety paper/both"
        )
    return Campaign(
        base=scn, seed=params["seed"], count=params["count"], fields=fields,
        as_json=params["as_json"], crowd=crowd, hard=hard,
        outside=params["outside_fields"] if params["outside"] else None,
        modes=("filter", "paper") if safety == "both" else (safety,),
        save_failures=params["save_failures"], save_lagging=params["save_lagging"],
    )  # fmt: skip


def _check_robots(c: Campaign, params: Mapping[str, Any]) -> None:
    """Refuse a --plant, --dynamics, --latency-ms or --safety-layer that cannot run the
    campaign's fields, before any runs: physics options without robots with mass, a physics
    plant or the reach layer for swarms or people, MuJoCo not installed, a preset that fits
    none of the fields' agents, a layer that refuses them (checked on the first field, drawn
    without its robots: every field's agents are of one kind)."""
    plant, robots = c.fields.plant, c.fields
    if robots.layer != SafetyLayer.REFEREE and (params["swarm"] is not None or c.crowd is not None):
        raise click.UsageError(
            f"--safety-layer {robots.layer} is the reference runs' layer: not with --swarm "
            "(--swarm-safety-layer) or --people"
        )
    _check_layer(c)
    if plant == KINEMATICS and params["latency_ms"] is not None:
        raise click.BadParameter(
            "is for robots with mass: add --plant mujoco", param_hint="--latency-ms"
        )
    if plant != KINEMATICS and (params["swarm"] is not None or c.crowd is not None):
        raise click.UsageError(
            f"--plant {plant} runs the fields through the reference simulator: not with "
            "--swarm or --people"
        )
    if plant == KINEMATICS:
        check_plant(c.base, plant, robots.dynamics)  # --dynamics without --plant mujoco
        return
    # The campaign reports a field it cannot draw; then the base's agents are checked.
    sample = _sample(c, robots) or c.base
    if robots.dynamics is not None:
        _fits(sample, robots.dynamics)
    check_plant(sample, plant, robots.dynamics)


def _check_layer(c: Campaign) -> None:
    """The fields' --safety-layer accepts them: checked on the first field of each safety
    mode (the reach layer refuses unicycles and safety: paper)."""
    opts = c.fields
    if opts.layer == SafetyLayer.REFEREE:
        return
    for safety in c.modes:
        sample = _sample(c, dataclasses.replace(opts, safety=safety))
        if sample is not None:  # else the campaign reports the field it cannot draw
            check_layer(sample, opts.layer, None)


def _sample(c: Campaign, opts: FieldOptions) -> Scenario | None:
    """The campaign's first field as ``opts`` draw it, without robots with mass (every field's
    agents are of one kind); None when it cannot be drawn."""
    bare = dataclasses.replace(opts, plant=KINEMATICS, dynamics=None, latency=None)
    try:
        if c.hard:
            return hard_field(c.seed, 2, unicycles=bare.kinematics == "unicycle")
        return make_field(c.base, c.seed, "inside", bare)
    except FieldError:
        return None


def _fits(sample: Scenario, name: str) -> None:
    """``--dynamics name`` drives some agent of ``sample`` (a field of the campaign)."""
    drive = PRESETS[name].drive
    wheeled = drive == Drive.DIFFERENTIAL
    if any(a.single != wheeled for a in sample.agents):
        return
    kind = "single integrators" if wheeled else "unicycles"
    fits = ", ".join(p for p, d in PRESETS.items() if d.drive != drive)
    hint = " (--kinematics unicycle makes them unicycles)" if wheeled else ""
    raise click.BadParameter(
        f"{name} is a {drive} drive, but the fields' agents are {kind}{hint}: choose one of {fits}",
        param_hint="--dynamics",
    )


def _reference(c: Campaign, where: Workers) -> None:
    """The fields through the reference simulator; exit status 1 if an inside field collided
    (2 if one could not be drawn)."""
    todo = tasks(c.base, c.seed, c.count, c.outside or 0, c.fields, c.modes, hard=c.hard)
    if not c.as_json:  # said up front, before the first field runs
        click.echo(_up_front(c, len(todo), sum(HARD_MODES.get(t.mode) == 2 for t in todo)),
                   err=True)  # fmt: skip
    start = time.perf_counter()
    label = f"{len(todo)} hard fields" if c.hard else f"{len(todo)} fields around {c.base.name}"
    with progress_bar(len(todo), label) as bar:
        outcomes: list[Outcome]
        outcomes, jobs = where.run(todo, lambda _o: bar.update(1), run_task)
    rep = report(outcomes, time.perf_counter() - start, jobs)
    if c.fields.boundary_layer > 0:  # said with every figure: not the paper's law
        rep["boundary_layer"] = c.fields.boundary_layer
    if c.fields.kinematics is not None:
        rep["kinematics"] = c.fields.kinematics
    if c.fields.plant != KINEMATICS:  # said with every figure: robots with mass, which ones
        ran = {s["dynamics"] for s in rep["sets"].values() if "dynamics" in s}
        rep.update(plant=c.fields.plant, dynamics=", ".join(sorted(ran)),
                   latency=c.fields.latency)  # fmt: skip
    if c.fields.layer != SafetyLayer.REFEREE:
        rep["safety_layer"] = str(c.fields.layer)
    if c.save_failures is not None:
        _saved(rep["failures"], write_failures(outcomes, c.save_failures))
    if c.save_lagging is not None:
        lagging = write_failures(
            outcomes, c.save_lagging, which=lambda o: o.lagged and not o.collided
        )
        _saved(rep["lagging"], lagging)
    click.echo(json.dumps(_json_safe(rep)) if c.as_json else render(rep))
    inside = "inside/paper" if c.modes == ("paper",) else "inside"
    judged = ("hard/2d", "hard/3d") if c.hard else (inside,)
    _exit_status(rep, c.save_failures, judged, c.fields.plant)


def _up_front(c: Campaign, runs: int, in_2d: int) -> str:
    """How many runs the options make, and of what (``in_2d``: the hard fields in 2-D)."""
    if c.hard:
        return f"{runs} runs: {in_2d} hard fields in 2-D and {runs - in_2d} in 3-D"
    sets = f"{c.count} fields inside the assumptions"
    if c.outside is not None:
        sets += f" and {c.outside} for each of the {len(BREACHES)} broken ones"
    each = f", each {' and '.join(c.modes)}" if len(c.modes) > 1 else ""
    hint = "" if c.outside is not None else " (--outside: also fields that break one on purpose)"
    return f"{runs} runs: {sets}{each}{hint}"


def _saved(rows: list[dict[str, Any]], written: Iterable[Path]) -> None:
    """Each reported field's ``file``: where it was saved as scenario YAML (None: it was not)."""
    files = {p.stem: str(p) for p in written}
    for row in rows:
        row["file"] = files.get(saved_stem(row["name"], row["safety"]))


def _people(c: Campaign, crowd: PeopleOptions, where: Workers) -> None:
    """The people campaign; exit status 1 if any contact was an agent's fault."""
    todo = [PeopleTask(c.base.source, c.base.name, c.seed + k, c.fields, crowd)
            for k in range(c.count)]  # fmt: skip
    start = time.perf_counter()
    label = f"{c.count} fields with {crowd.count} {crowd.model} people at {crowd.speed:g} m/s"
    with progress_bar(c.count, label) as bar:
        outcomes: list[PeopleOutcome]
        outcomes, jobs = where.run(todo, lambda _o: bar.update(1), run_people_task)
    rep = people_report(outcomes, crowd, time.perf_counter() - start, jobs)
    if c.fields.kinematics is not None:
        rep["kinematics"] = c.fields.kinematics
    if c.save_failures is not None:  # every field with a contact or without success, as YAML
        c.save_failures.mkdir(parents=True, exist_ok=True)
        for o in outcomes:
            if o.source:
                (c.save_failures / f"{o.name}.yaml").write_text(o.source, encoding="utf-8")
    click.echo(json.dumps(_json_safe(rep)) if c.as_json else render_people(rep))
    if rep["agent_at_fault"]:
        click.echo(f"{rep['agent_at_fault']} contact(s) were an agent's fault", err=True)
        sys.exit(1)
    if rep["errors"]:
        sys.exit(2)


def _swarming(params: Mapping[str, Any], crowd: PeopleOptions | None) -> Swarming:
    """How each swarm runs: ``--swarm-clock``, ``--swarm-safety-layer``, ``--swarm-faults``."""
    clock, layer = params["swarm_clock"], params["swarm_safety_layer"]
    return Swarming(
        clock=Clock(clock), layer=None if layer is None else SafetyLayer(layer),
        faults=_faults(params["swarm_faults"], clock), people=crowd,
    )  # fmt: skip


def _faults(text: str, clock: str) -> Faults:
    """``--swarm-faults`` DELAY_MS,JITTER_MS,DROP_RATE, checked."""
    parts = text.split(",")
    try:
        delay, jitter, drop = (float(p) for p in parts)
    except ValueError:
        raise click.BadParameter(
            f"{text!r}: give three numbers, DELAY_MS,JITTER_MS,DROP_RATE",
            param_hint="--swarm-faults",
        ) from None
    if not (0 <= jitter <= delay <= 10_000 and 0 <= drop < 1):
        raise click.BadParameter(
            f"{text!r}: need 0 ≤ JITTER_MS ≤ DELAY_MS ≤ 10000 and 0 ≤ DROP_RATE < 1",
            param_hint="--swarm-faults",
        )
    if drop > 0 and clock != "realtime":
        raise click.BadParameter(
            "a dropped state would stall a lockstep run forever: DROP_RATE needs realtime",
            param_hint="--swarm-faults",
        )
    return Faults(delay_ms=delay, jitter_ms=jitter, drop_rate=drop)


def _swarms(c: Campaign, count: int, how: Swarming) -> None:
    """The first ``count`` inside fields as real swarms; exit status 1 if one collided, came
    below a margin, or (lockstep) differed from the reference."""
    exit_on_signals(grace=SUPERVISOR_GRACE_S)
    with progress_bar(count, f"{count} swarms ({how.clock}) around {c.base.name}") as bar:
        try:
            rows = run_swarms(c.base, c.seed, count, c.fields, how, done=lambda _r: bar.update(1))
        except ChildFailed as exc:
            raise click.ClickException(str(exc)) from None
    rep = swarm_report(rows, str(how.clock), how.layer)
    click.echo(json.dumps(_json_safe(rep)) if c.as_json else render_swarms(rep))
    if rep["collided"] or rep["below_guard"] or rep["below_separation"] or rep["inexact"]:
        sys.exit(1)  # (an agent-at-fault contact counts among the collisions)


def _exit_status(
    rep: dict[str, Any], saved: Path | None, judged: Sequence[str], plant: str = KINEMATICS
) -> None:
    inside = [f for f in rep["failures"] if f["set"] in judged]
    if inside:
        names = ", ".join(f["name"] for f in inside[:10]) + (" …" if len(inside) > 10 else "")
        where = f"saved in {saved}" if saved else "rerun with --save-failures DIR to keep them"
        why = (
            "which the guarantee rules out"
            if plant == KINEMATICS
            else f"on robots with mass ({plant}; the filter's theorem is for robots that move "
            "as commanded)"
        )
        click.echo(f"{len(inside)} inside field(s) collided, {why}: {names} ({where})", err=True)
        sys.exit(1)
    if rep["errors"]:
        click.echo(f"{len(rep['errors'])} field(s) could not be drawn", err=True)
        sys.exit(2)


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_json_safe(v) for v in value]
    if isinstance(value, float) and (value != value or value in (float("inf"), float("-inf"))):
        return None
    return value


def _rerun(path: Path, as_json: bool, plant: str, dynamics: str | None, layer: SafetyLayer) -> None:
    """Run one saved field; also those the loader refuses because they break an assumption.
    On ``plant`` mujoco the engine's judgement replaces the ticks', as in ``shoal simulate``;
    through ``layer``."""
    try:
        field = load_field(path.read_text(encoding="utf-8"))
    except ScenarioError as exc:
        raise click.ClickException(f"{path}: {exc}") from None
    check_plant(field, plant, dynamics)
    check_layer(field, layer, dynamics)
    traj, judged = reference(field, plant=plant, dynamics=dynamics, layer=layer)
    result = summarize(field, traj)
    outcome = measure(field, traj, result)
    summary = json_safe({**result.as_dict(), **judged})
    summary.update(breaks=sorted(breaches(field)))
    by_kind = "plant" not in judged  # the engine does not split its collisions by kind
    if by_kind:
        summary.update(
            obstacle_collisions=outcome.obstacle_collisions,
            agent_collisions=outcome.agent_collisions,
        )
    if as_json:
        click.echo(json.dumps(summary))
        return
    click.echo(render_summary(summary))
    if by_kind:
        click.echo(
            f"{'collisions by kind':<24}  {outcome.obstacle_collisions} agent–obstacle, "
            f"{outcome.agent_collisions} agent–agent"
        )
    click.echo(f"{'breaks':<24}  {', '.join(summary['breaks']) or 'nothing checked at load'}")
