"""``shoal run``: a whole run as separate OS processes over Zenoh."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from shoal.bus.errors import WireError
from shoal.bus.runtime import exit_on_signals, warn
from shoal.bus.secure import Material
from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.certs import CertError
from shoal.tools.commands.options import (
    check_layer,
    check_plant,
    live_options,
    live_view,
    load_for_cli,
    out_file,
)
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.extras import require
from shoal.tools.foxglove.export import ExportResult, export_beside, sibling
from shoal.tools.log.salvage import is_finished
from shoal.tools.procs.children import (
    PLANT_OPTIONS,
    ROBOT_OPTIONS,
    AgentSpec,
    WorldSpec,
    check_run_id,
    click_options,
)
from shoal.tools.procs.launch import RunPlan, RunResult, fresh_run_id, launch
from shoal.tools.procs.swarm import SUPERVISOR_GRACE_S, ChildFailed
from shoal.tools.ros2.config import RosConfig, ros_config
from shoal.world.scenario import Scenario


def injected_drops(reports: Mapping[int, Mapping[str, Any]]) -> dict[str, int]:
    """The fault injection's totals over the agents' reports (bus/report.py)."""
    return {
        "dropped": sum(r.get("injected_drops") or 0 for r in reports.values()),
        "offered": sum(r.get("states_heard") or 0 for r in reports.values()),
        "agents": len(reports),
    }


def _where_the_log_is(out: Path) -> str:
    """For a run that did not finish: where its log is and what to do with it."""
    if not out.exists():
        return ""
    if is_finished(out):
        return f"\nthe log of the run so far: {out}"
    return (
        f"\nthe log of the run so far: {out}, unfinished; "
        f"`shoal recover {out} -o FIXED.mcap` keeps every complete chunk"
    )


@click.command()
@click.argument("scenario", default="default")
@click.option(
    "--clock",
    type=click.Choice([c.value for c in Clock]),
    help="lockstep: the world advances once every live agent's command for the tick is in "
    "(exact, deterministic); realtime: the world integrates at a fixed wall-clock rate with "
    "each agent's latest command. [default: lockstep; realtime with --robots ros2]",
)
@click.option(
    "--mode",
    type=click.Choice([c.value for c in Clock]),
    hidden=True,
    help="The old spelling of --clock, kept for scripts; warns.",
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.01, max=100.0),
    default=1.0,
    help="realtime: simulated seconds per wall-clock second.",
)
@out_file("MCAP file to record the run in [default: runs/<scenario>-<run id>.mcap].")
@click.option(
    "--connect", "-e", help="Use the Zenoh router at this endpoint instead of starting one."
)
@click.option(
    "--run", "run_id", callback=check_run_id, help="Run id [default: a fresh random one]."
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--start-timeout", default=60.0, help="Seconds for every process to come up.")
@click.option(
    "--foxglove/--no-foxglove",
    default=True,
    help="Write Foxglove views beside the log, <log>.foxglove.mcap (docs/foxglove.md).",
)
@click.option(
    "--force", is_flag=True, help="Overwrite the log (and its views) if they exist already."
)
@live_options("while it runs")
@click.option(
    "--live-wait",
    is_flag=True,
    help="With --live: start the run only once a viewer has subscribed to one of its topics.",
)
@click_options(AgentSpec, only=("drop_rate", "drop_seed", "delay_ms", "jitter_ms"))
@click_options(WorldSpec, only=("safety_layer", "layer_epoch", *PLANT_OPTIONS, *ROBOT_OPTIONS))
@click.option(
    "--secure",
    is_flag=True,
    help="Secured mode: TLS with mutual authentication, a password per process and the "
    "router's access rules, with fresh certificates for this run (docs/security.md).",
)
@click.option(
    "--secure-dir",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="Secured mode with the material in DIR (`shoal certs DIR`), e.g. for a router "
    "started by hand with --secure DIR; the run id defaults to the one DIR was made for.",
)
def run(**params: Any) -> None:
    """Run SCENARIO with one OS process per agent, a world, a logger (and a router).

    Prints the same summary as `shoal simulate`; the lockstep trajectory equals the reference
    simulator's bit for bit, and the whole run is recorded in an MCAP file.
    """
    exit_on_signals(grace=SUPERVISOR_GRACE_S)
    if params["mode"] is not None:
        warn("run: --mode is now --clock (the word the summary, the docs and the world use)")
        params["clock"] = params["mode"]
    params["clock"] = _clock(params["clock"], params["robots"])
    _validate(params)
    config = RunConfig(
        plan=_plan(params), as_json=params["as_json"], foxglove=params["foxglove"],
        live=params["live"], live_port=params["live_port"], live_wait=params["live_wait"],
    )  # fmt: skip
    _check_out(config)
    summarize(config, run_swarm(config))


@dataclass(frozen=True)
class RunConfig:
    """A ``shoal run``: what to launch (every fact resolved once) and how to show it."""

    plan: RunPlan
    as_json: bool = False  # one JSON object instead of text
    foxglove: bool = True  # the Foxglove views beside the log
    live: bool = False  # serve the views while it runs …
    live_port: int = 0  # … on this port …
    live_wait: bool = False  # … and start once a viewer has subscribed


def _clock(given: str | None, robots: str | None) -> str:
    """The run's clock: as given, else realtime for ROS 2 robots (they move on the wall
    clock: nothing else can drive them) and lockstep for everything else. An explicit
    lockstep with robots stays given, for `_validate` to refuse by name."""
    if given is not None:
        return given
    return Clock.REALTIME.value if robots == "ros2" else Clock.LOCKSTEP.value


def _validate(params: Mapping[str, Any]) -> None:
    """Refuse what cannot run, before anything starts (the options as click parsed them)."""
    clock, speed, robots = params["clock"], params["speed"], params["robots"]
    if params["live_wait"] and not params["live"]:
        raise click.UsageError("--live-wait waits for a viewer of --live: give --live too")
    if params["drop_rate"] > 0 and clock != Clock.REALTIME:
        raise click.BadParameter(
            "needs --clock realtime: a lockstep run waits for every state, so a dropped one "
            "would stall it forever",
            param_hint="--drop-rate",
        )
    if params["jitter_ms"] > params["delay_ms"]:
        raise click.BadParameter(
            f"{params['jitter_ms']:g} ms is more than --delay-ms {params['delay_ms']:g}: a "
            "message cannot go out before it is sent",
            param_hint="--jitter-ms",
        )
    if robots == "ros2" and clock != Clock.REALTIME:
        raise click.BadParameter(
            f"robots move on the wall clock: --clock {clock} cannot drive them (leave --clock "
            "out, or give --clock realtime)",
            param_hint="--robots",
        )
    if robots == "ros2" and speed != 1.0:
        raise click.BadParameter(
            f"robots move on the wall clock: --speed {speed:g} would need them faster or "
            "slower than they are (leave --speed at 1)",
            param_hint="--robots",
        )
    if robots == "ros2":
        require("ros2", "--robots ros2")  # here, not in the world once the swarm is up
    if speed != 1.0 and clock != Clock.REALTIME:
        raise click.BadParameter(
            "needs --clock realtime: a lockstep run goes as fast as its processes can, and "
            "its result does not depend on time",
            param_hint="--speed",
        )


def _plan(params: Mapping[str, Any]) -> RunPlan:
    """The run: its scenario parsed and its ROS 2 robots resolved, once, here; the secured
    mode's material checked; the run id and the log's path decided."""
    scn = load_for_cli(params["scenario"])
    check_plant(scn, params["plant"], params["dynamics"], params["robots"])
    if params["safety_layer"] is not None:
        check_layer(scn, SafetyLayer(params["safety_layer"]), params["dynamics"])
    secure, secure_dir, run_id = params["secure"], params["secure_dir"], params["run_id"]
    if secure and params["connect"] and secure_dir is None:
        raise click.BadParameter(
            "a router started elsewhere enforces the rules it was given: pass --secure-dir "
            "with the directory it was started with",
            param_hint="--secure",
        )
    if secure_dir is not None:
        run_id = _check_material(secure_dir, run_id, scn.n)
    run_id = run_id or fresh_run_id()
    layer = params["safety_layer"]
    return RunPlan(
        scenario=scn,
        out=params["out"] or Path("runs") / f"{scn.name}-{run_id}.mcap",
        run_id=run_id,
        clock=Clock(params["clock"]),
        speed=params["speed"],
        safety_layer=None if layer is None else SafetyLayer(layer),
        layer_epoch=params["layer_epoch"],
        connect=params["connect"],
        start_timeout=params["start_timeout"],
        progress=not params["as_json"],
        drop_rate=params["drop_rate"],
        drop_seed=params["drop_seed"],
        delay_ms=params["delay_ms"],
        jitter_ms=params["jitter_ms"],
        secure=secure or secure_dir is not None,
        secure_dir=secure_dir,
        force=params["force"],
        ros=_robots(scn, params),
        plant=params["plant"],
        dynamics=params["dynamics"],
    )


def _robots(scn: Scenario, params: Mapping[str, Any]) -> RosConfig | None:
    """With ``--robots ros2``, the robots the world drives and its guard stops, resolved from
    the ``--ros-*`` options, the scenario's ``robots:`` section and the defaults."""
    if params["robots"] != "ros2":
        return None
    return ros_config(
        scn, connect=params["ros_connect"], domain=params["ros_domain"],
        distro=params["ros_distro"], prefix=params["ros_prefix"], pose=params["ros_pose"],
        pose_timeout=params["pose_timeout"],
    )  # fmt: skip


def _check_out(config: RunConfig) -> None:
    """Refuse a log (or its views) that exists without --force, or a folder that cannot be
    written: said now, not after the swarm is up (the logger creates the file)."""
    out = config.plan.out
    taken = [p for p in (out, sibling(out) if config.foxglove else None) if p and p.exists()]
    if taken and not config.plan.force:
        raise click.ClickException(
            f"{taken[0]} exists; pass --force to overwrite it, or --out another file"
        )
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        writable = os.access(out.parent, os.W_OK)
    except OSError:
        writable = False
    if not writable:
        raise click.ClickException(f"{out}: cannot be written (its folder is not writable)")


def run_swarm(config: RunConfig) -> RunResult:
    """Launch the run (with its live view, if asked) and follow it to its end; a failed or
    interrupted run says where its log is."""
    plan = config.plan
    try:
        with (
            live_view(plan.scenario, plan.run_id, config.live_port)
            if config.live
            else contextlib.nullcontext()
        ) as sink:
            if sink is not None and config.live_wait:
                warn("run: waiting for a viewer to subscribe (Ctrl-C to stop)")
                sink.wait_for_viewer()
            return launch(plan, sink)
    except (ChildFailed, CertError) as exc:
        why = str(exc).rstrip(": \n")  # a killed child has no last words: no dangling colon
        raise click.ClickException(f"{why}{_where_the_log_is(plan.out)}") from None
    except SystemExit as exc:  # Ctrl-C or SIGTERM: the swarm has been stopped in order
        if plan.out.exists():
            later = f"; no Foxglove views yet: `shoal export {plan.out}`" if config.foxglove else ""
            warn(f"shoal run: interrupted{_where_the_log_is(plan.out)}{later}")
        raise SystemExit(exc.code) from None


def summarize(config: RunConfig, result: RunResult) -> None:
    """Write the Foxglove views, print the summary (text or JSON), and fail the command if
    the run ended early or lost an agent."""
    plan = config.plan
    views = export_beside(plan.out, progress=not config.as_json) if config.foxglove else None
    summary = json_safe(result.summary)
    drops = injected_drops(result.agent_reports) if plan.drop_rate > 0 else None
    if config.as_json:
        extra = {
            "injected_drops": drops,
            "clock": str(plan.clock),
            "wall_s": round(result.wall_s, 3),
            "startup_s": result.startup_s,
            "mcap": str(plan.out),
            "foxglove": str(views.out) if views else None,
            "secure": plan.secure,
        }
        click.echo(json.dumps({**summary, **extra}))
    else:
        click.echo(_text(plan, result, summary, drops, views))
    if summary.get("aborted"):
        raise click.ClickException(f"the run ended early: {summary['aborted']}")
    if result.lost:
        raise click.ClickException(
            f"agent process(es) died during the run: {', '.join(result.lost)} "
            "(the world held them still and finished without them)"
        )


def _text(
    plan: RunPlan,
    result: RunResult,
    summary: dict[str, Any],
    drops: Mapping[str, int] | None,
    views: ExportResult | None,
) -> str:
    """The run's summary as `shoal simulate` prints it, then the run's own lines."""
    lines = [
        render_summary(summary),
        f"{'processes':<24}  {result.processes}, {result.wall_s:.1f} s wall, "
        f"all agents up in {result.startup_s:.1f} s",
    ]
    if drops is not None:
        lines.append(
            f"{'injected drops':<24}  {drops['dropped']} of {drops['offered']} neighbour "
            f"states thrown away (--drop-rate {plan.drop_rate:g}, --drop-seed {plan.drop_seed})"
        )
    lines.append(f"{'log':<24}  {plan.out}")
    if plan.secure:
        lines.append(f"{'secured':<24}  TLS (mutual), passwords, router ACL for run {plan.run_id}")
    if views:
        lines.append(f"{'foxglove views':<24}  {views.out}")
    return "\n".join(lines)


def _check_material(secure_dir: Path, run_id: str | None, agents: int) -> str:
    """The run id the material in ``secure_dir`` was made for, if it fits this run: the
    router's rules name one run and agents 1..N, and anything else would be refused."""
    try:
        made_for, made_agents = Material(secure_dir).scope()
    except (WireError, KeyError, ValueError) as exc:
        raise click.BadParameter(f"{secure_dir}: {exc}", param_hint="--secure-dir") from None
    if run_id not in (None, made_for):
        raise click.BadParameter(
            f"{secure_dir} was made for run {made_for!r}, not {run_id!r}; re-run "
            f"`shoal certs {secure_dir} --run {run_id} --agents {agents}`",
            param_hint="--secure-dir",
        )
    if made_agents < agents:
        raise click.BadParameter(
            f"{secure_dir} has identities for {made_agents} agents; the scenario has {agents}",
            param_hint="--secure-dir",
        )
    return made_for
