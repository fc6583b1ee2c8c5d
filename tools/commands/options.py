"""Options shared by the commands (the process commands, run, replay, and the files they write)."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from shoal.bus.runtime import warn
from shoal.tools.extras import require
from shoal.world.errors import ScenarioError, ScenarioWarning
from shoal.world.loader import load_scenario
from shoal.world.plant import KINEMATICS
from shoal.world.scenario import Scenario

if TYPE_CHECKING:  # not at run time: it needs the Foxglove SDK, which is optional
    from shoal.tools.foxglove.live import LiveView

F = TypeVar("F", bound=Callable[..., Any])
LIVE_PORT = 8765  # Foxglove's default for a WebSocket connection


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


def check_plant(
    scenario: Scenario, plant: str, dynamics: str | None, robots: str = "simulated"
) -> None:
    """Refuse a ``--plant`` / ``--dynamics`` choice that cannot run ``scenario``, before anything
    starts: MuJoCo not installed, a preset that fits none of its agents, ``--dynamics`` without
    robots with mass, or a physics plant and real robots at once."""
    if plant == KINEMATICS:
        if dynamics is not None:
            raise click.BadParameter(
                "is for robots with mass: add --plant mujoco", param_hint="--dynamics"
            )
        return
    if robots != "simulated":
        raise click.BadParameter(
            f"moves simulated robots; --robots {robots} drives real ones: choose one",
            param_hint="--plant",
        )
    require("physics", f"--plant {plant}")
    try:
        scenario.robot_dynamics(dynamics)
    except ScenarioError as exc:
        raise click.ClickException(f"scenario {scenario.name}: {exc}") from None


def out_file(help: str, *, required: bool = False) -> Callable[[F], F]:
    """-o/--out: the file a command writes (its folder need not exist yet)."""
    return click.option(
        "--out", "-o", type=click.Path(dir_okay=False, path_type=Path), required=required,
        help=help,
    )  # fmt: skip


def live_options(when: str) -> Callable[[F], F]:
    """--live, --live-port: serve the run's Foxglove views ``when`` (e.g. "while it runs") on
    a Foxglove WebSocket server."""

    def add(func: F) -> F:
        func = click.option(
            "--live-port",
            type=click.IntRange(0, 65535),
            default=LIVE_PORT,
            show_default=True,
            help="Port of the --live server (0: any free port; the URL is printed).",
        )(func)
        return click.option(
            "--live",
            is_flag=True,
            help=f"Serve the run's views to Foxglove {when}, on a Foxglove WebSocket server "
            "on 127.0.0.1 (needs `pip install 'shoal[live]'`; docs/foxglove.md).",
        )(func)

    return add


@contextlib.contextmanager
def live_view(
    scenario: Scenario, run_id: str, port: int, *, source: str = "live"
) -> Iterator[LiveView]:
    """The live view's server (tools/foxglove/live.py), up (its URL said on stderr) until the
    block ends; a missing SDK or a taken port is a one-line error."""
    require("live", "--live")
    from shoal.tools.foxglove.live import LiveError, LiveView

    with contextlib.ExitStack() as stack:
        try:
            view = stack.enter_context(LiveView(scenario, run_id, port=port, source=source))
        except LiveError as exc:
            raise click.ClickException(f"--live: {exc}") from None
        warn(f"live view: {view.url}  (in Foxglove: Open connection → Foxglove WebSocket)")
        if view.app_url:
            warn(f"           or open {view.app_url}")
        yield view
