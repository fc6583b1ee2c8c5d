"""``shoal export``: Foxglove views of a run, written beside its raw log (docs/foxglove.md)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from shoal.tools.commands.logs import one_log, the_log
from shoal.tools.foxglove.export import ExportError, ExportResult, sibling, with_progress
from shoal.tools.foxglove.views import ViewOptions
from shoal.tools.rosbag import writer as ros2_bag


def describe(result: ExportResult) -> str:
    return (
        f"{result.out}: {result.messages} messages from {result.ticks} tick records, "
        f"{result.bytes / 1e6:.1f} MB in {result.seconds:.1f} s"
    )


@click.command()
@one_log
@click.option(
    "-o",
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="The views file [default: beside FILE, its .mcap replaced by .foxglove.mcap].",
)
@click.option(
    "--scene-hz",
    type=click.FloatRange(min=0.1, max=1000.0),
    default=ViewOptions.scene_hz,
    help="Rate of the 3D scene and the agents' frames, per second of simulated time.",
)
@click.option(
    "--plot-hz",
    type=click.FloatRange(min=0.1, max=1000.0),
    default=ViewOptions.plot_hz,
    help="Rate of the scalar channels, per simulated second (every tick if above 1/dt).",
)
@click.option(
    "--ros2",
    "ros2",
    metavar="DIR",
    type=click.Path(path_type=Path),
    help="Write a ROS 2 bag (rosbag2 directory, MCAP) to this directory instead of the views "
    "(docs/ros2.md; needs pip install 'shoal[ros2]').",
)
@click.option("--force", is_flag=True, help="Overwrite the views file (or the --ros2 bag).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.pass_context
def export(
    ctx: click.Context,
    file: Path | None,
    out: Path | None,
    scene_hz: float,
    plot_hz: float,
    ros2: Path | None,
    force: bool,
    as_json: bool,
) -> None:
    """Write Foxglove views of the run logged in FILE (none: the last run in runs/): a 3D
    scene, agent frames, a log and plottable metrics, as Foxglove JSON channels in a new MCAP
    file (FILE is not changed).

    `shoal run` does this by itself at the end of a run; this is for older logs, or to choose
    other rates. Open the views file in Foxglove (docs/foxglove.md). With --ros2 DIR, write a
    ROS 2 bag of the run instead, for ros2 bag play and RViz (docs/ros2.md).
    """
    file = the_log(file, command="export")
    if ros2 is not None:
        views_only = [
            f"--{name.replace('_', '-')}"
            for name in ("out", "scene_hz", "plot_hz")
            if ctx.get_parameter_source(name) != click.core.ParameterSource.DEFAULT
        ]
        if views_only:
            raise click.UsageError(f"{', '.join(views_only)}: for the Foxglove views, not --ros2")
        export_ros2(file, ros2, force=force, as_json=as_json)
        return
    options = ViewOptions(scene_hz=scene_hz, plot_hz=plot_hz)
    target = out or sibling(file)
    if target.exists() and not force and target.resolve() != file.resolve():
        raise click.ClickException(f"{target} exists; pass --force to overwrite it")
    try:
        result = with_progress(file, out, options)
    except ExportError as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:
        raise click.ClickException(f"{target}: cannot be written ({exc.strerror})") from None
    if as_json:
        fields = ("messages", "ticks", "seconds", "bytes")
        click.echo(json.dumps({"out": str(result.out)} | {k: getattr(result, k) for k in fields}))
    else:
        click.echo(describe(result))


def export_ros2(file: Path, bag: Path, *, force: bool, as_json: bool) -> None:
    """``--ros2 DIR``: the run as a rosbag2 directory (tools/rosbag/writer.py)."""
    try:
        result = ros2_bag.with_progress(file, bag, force=force)
    except ros2_bag.Ros2Error as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:
        raise click.ClickException(f"{bag}: cannot be written ({exc.strerror})") from None
    if as_json:
        fields = ("messages", "ticks", "seconds", "bytes", "topics")
        click.echo(json.dumps({"out": str(result.out)} | {k: getattr(result, k) for k in fields}))
    else:
        click.echo(describe_bag(result))


def describe_bag(result: ros2_bag.BagResult) -> str:
    return (
        f"{result.out}: ROS 2 bag, {len(result.topics)} topics, {result.messages} messages from "
        f"{result.ticks} tick records, {result.bytes / 1e6:.1f} MB in {result.seconds:.1f} s"
    )
