"""``shoal simulate``: the in-process reference simulator."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from shoal.bus.types import SafetyLayer
from shoal.tools.commands.options import check_layer, check_plant, layer_option, load_for_cli
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.procs.children import PLANT_OPTIONS, WorldSpec, click_options
from shoal.tools.simulator import reference
from shoal.world.metrics import summarize
from shoal.world.plant import PlantError


@click.command()
@click.argument("scenario", default="default")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option(
    "--out",
    type=click.Path(dir_okay=False, writable=True, path_type=Path),
    help="Save the trajectories to this .npz file (.npz is added to a name without it).",
)
@click.option("--force", is_flag=True, help="Overwrite the --out file if it exists.")
@click_options(WorldSpec, only=PLANT_OPTIONS)
@layer_option("the run")
def simulate(
    scenario: str,
    as_json: bool,
    out: Path | None,
    force: bool,
    plant: str,
    dynamics: str | None,
    layer: SafetyLayer,
) -> None:
    """Run SCENARIO (a built-in name or a YAML file) in one process, exactly.

    Every agent's controller and the world's kinematics are called in lockstep, the same
    functions the distributed run calls. Built-ins: see `shoal scenarios`. With
    --safety-layer reach the summary adds the reach layer's counts (docs/wire.md).
    """
    scn = load_for_cli(scenario)
    check_plant(scn, plant, dynamics)
    check_layer(scn, layer, dynamics)
    if out is not None:
        out = out if out.suffix == ".npz" else out.with_name(out.name + ".npz")
        if out.exists() and not force:
            raise click.ClickException(f"{out} exists; pass --force to overwrite it")
        if not out.parent.is_dir():
            raise click.ClickException(f"{out.parent} is not a folder: cannot write {out.name}")
    show_bar = not as_json and sys.stderr.isatty()
    with click.progressbar(
        length=scn.steps, label=f"simulating {scn.name}", file=sys.stderr, hidden=not show_bar
    ) as bar:
        try:
            traj, judged = reference(
                scn, progress=lambda _k: bar.update(1), plant=plant, dynamics=dynamics,
                layer=layer,
            )  # fmt: skip
        except PlantError as exc:
            raise click.ClickException(f"{scn.name}: {exc}") from None
    summary = json_safe({**summarize(scn, traj).as_dict(), **judged})
    if out is not None:
        traj.save(out)
    if as_json:
        click.echo(json.dumps(summary))
    else:
        click.echo(render_summary(summary))
        if out is not None:
            click.echo(f"trajectories written to {out}")
