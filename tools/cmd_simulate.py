"""``shoal simulate``: the in-process reference simulator."""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path
from typing import Any

import click

from shoal.tools.report import render_summary
from shoal.tools.simulator import simulate as run_reference
from shoal.world.errors import ScenarioError, ScenarioWarning
from shoal.world.loader import load_scenario
from shoal.world.metrics import summarize
from shoal.world.scenario import Scenario


def load_for_cli(name_or_path: str) -> Scenario:
    """Load a scenario, turning its errors into messages a person can act on."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ScenarioWarning)
        try:
            scenario = load_scenario(name_or_path)
        except ScenarioError as exc:
            raise click.ClickException(f"scenario {name_or_path}: {exc}") from None
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    return scenario


def json_safe(summary: dict[str, Any]) -> dict[str, Any]:
    """inf is not JSON: an unbounded figure becomes null."""
    return {k: (None if isinstance(v, float) and math.isinf(v) else v) for k, v in summary.items()}


@click.command()
@click.argument("scenario", default="default")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option(
    "--out",
    type=click.Path(dir_okay=False, writable=True, path_type=Path),
    help="Save the trajectories to this .npz file.",
)
def simulate(scenario: str, as_json: bool, out: Path | None) -> None:
    """Run SCENARIO (a built-in name or a YAML file) in one process, exactly.

    Every agent's controller and the world's kinematics are called in lockstep, the same
    functions the distributed run calls. Built-ins: see `shoal scenarios`.
    """
    scn = load_for_cli(scenario)
    show_bar = not as_json and sys.stderr.isatty()
    with click.progressbar(
        length=scn.steps, label=f"simulating {scn.name}", file=sys.stderr, hidden=not show_bar
    ) as bar:
        traj = run_reference(scn, progress=lambda _k: bar.update(1))
    summary = json_safe(summarize(scn, traj).as_dict())
    if out is not None:
        traj.save(out)
    if as_json:
        click.echo(json.dumps(summary))
    else:
        click.echo(render_summary(summary))
        if out is not None:
            click.echo(f"trajectories written to {out}")
