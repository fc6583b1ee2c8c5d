"""``shoal run``: a whole run as separate OS processes over Zenoh."""

from __future__ import annotations

import json
import uuid
from pathlib import Path

import click

from bus.runtime import exit_on_signals
from tools.cmd_export import export_beside
from tools.cmd_simulate import json_safe, load_for_cli
from tools.launch import RunPlan, launch
from tools.options import check_run_id
from tools.report import render_summary
from tools.swarm import ChildFailed
from world.loader import builtin_names


@click.command()
@click.argument("scenario", default="default")
@click.option(
    "--mode",
    type=click.Choice(["lockstep", "realtime"]),
    default="lockstep",
    help="lockstep: the world advances once every live agent's command for the tick is in "
    "(exact, deterministic); realtime: the world integrates at a fixed wall-clock rate with "
    "each agent's latest command.",
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.01, max=100.0),
    default=1.0,
    help="realtime: simulated seconds per wall-clock second.",
)
@click.option(
    "--out",
    "-o",
    type=click.Path(dir_okay=False, path_type=Path),
    help="MCAP file to record the run in [default: runs/<scenario>-<run id>.mcap].",
)
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
def run(
    scenario: str,
    mode: str,
    speed: float,
    out: Path | None,
    connect: str | None,
    run_id: str | None,
    as_json: bool,
    start_timeout: float,
    foxglove: bool,
) -> None:
    """Run SCENARIO with one OS process per agent, a world, a logger (and a router).

    Prints the same summary as `shoal simulate`; the lockstep trajectory equals the reference
    simulator's bit for bit, and the whole run is recorded in an MCAP file.
    """
    exit_on_signals()
    scn = load_for_cli(scenario)
    run_id = run_id or uuid.uuid4().hex[:8]
    plan = RunPlan(
        scenario=scenario if scenario in builtin_names() else str(Path(scenario).resolve()),
        agents=scn.n,
        steps=scn.steps,
        out=out or Path("runs") / f"{scn.name}-{run_id}.mcap",
        run_id=run_id,
        clock=mode,
        speed=speed,
        connect=connect,
        start_timeout=start_timeout,
        progress=not as_json,
    )
    try:
        result = launch(plan)
    except ChildFailed as exc:
        raise click.ClickException(str(exc)) from None
    views = export_beside(plan.out, progress=not as_json) if foxglove else None
    summary = json_safe(result.summary)
    if as_json:
        extra = {
            "mode": mode,
            "wall_s": round(result.wall_s, 3),
            "startup_s": result.startup_s,
            "mcap": str(plan.out),
            "foxglove": str(views.out) if views else None,
        }
        click.echo(json.dumps({**summary, **extra}))
    else:
        click.echo(render_summary(summary))
        click.echo(
            f"{'processes':<24}  {scn.n + 3 - bool(connect)}, {result.wall_s:.1f} s wall, "
            f"all agents up in {result.startup_s:.1f} s"
        )
        click.echo(f"{'log':<24}  {plan.out}")
        if views:
            click.echo(f"{'foxglove views':<24}  {views.out}")
