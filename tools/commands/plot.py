"""``shoal plot``: the paper's figures from a run's log alone."""

from __future__ import annotations

from pathlib import Path

import click

from shoal.tools.commands.logs import log_files, run_logs
from shoal.tools.plot.save import FIGURE_COUNT, PlotError
from shoal.tools.plot.save import plot as draw
from shoal.tools.progress import progress_bar


@click.command()
@log_files
@click.option(
    "--out",
    "-o",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("plots"),
    help="Folder for the figures (PNG and SVG).",
)
@click.option(
    "--figure",
    "only",
    multiple=True,
    help="Draw only this figure (repeatable): trajectories, distances, formation_error, "
    "consensus, omega, tracking.",
)
@click.option("--force", is_flag=True, help="Overwrite figures that exist already.")
def plot(files: tuple[Path, ...], out: Path, only: tuple[str, ...], force: bool) -> None:
    """Draw the paper's figures from the runs recorded in FILE... (a glob works; Foxglove
    views files are left out); with no FILE, from the last run in runs/.

    \b
    trajectories     paths, obstacles, formation snapshots (paper Fig. 1b, 2a, 3a)
    distances        distances between neighbours and to obstacles (Fig. 2b, 3b)
    formation_error  each follower's error against the Theorem 1 / Remark 3 bound
    consensus        σ over time and Algorithm 1's rounds
    omega            when each agent was evading (Ω = 1)
    tracking         commanded against achieved velocity (robots with mass lag: --plant mujoco)
    """
    logs = run_logs(files, command="plot")
    with progress_bar(len(logs) * (len(only) or FIGURE_COUNT), "plotting") as bar:
        for file in logs:
            try:
                written = draw(
                    file, out, only=only, progress=lambda _name: bar.update(1), overwrite=force
                )
            except PlotError as exc:
                raise click.ClickException(str(exc)) from None
            except OSError as exc:
                raise click.ClickException(f"{out}: cannot be written ({exc.strerror})") from None
            for path in written:
                click.echo(str(path))
