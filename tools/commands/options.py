"""Options shared by the commands (the process commands, run, replay, and the files they write)."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from shoal.bus.runtime import warn
from shoal.bus.types import SafetyLayer
from shoal.tools.extras import require
from shoal.world.assumptions import unlimited
from shoal.world.errors import ScenarioError, ScenarioWarning
from shoal.world.layers import make_layer
from shoal.world.loader import load_scenario
from shoal.world.plant import KINEMATICS
from shoal.world.reach_layer import reach_inputs
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
    cost = unlimited(scenario)
    if cost is not None:
        click.echo(f"warning: {cost}", err=True)
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


# The layers the reference simulator runs (``shoal simulate``, ``shoal campaign``): in lockstep
# the referee changes nothing; the reach layer certifies each step from what a robot can reach.
REFERENCE_LAYERS = (SafetyLayer.REFEREE, SafetyLayer.REACH)


class LayerRefused(click.UsageError):
    """A ``--safety-layer`` that cannot run a scenario; the layer's own reason in the message
    (world/layers.py ``make_layer``: unicycles, ``safety: paper``)."""

    def __init__(self, layer: SafetyLayer, scenario: str, reason: str) -> None:
        super().__init__(f"--safety-layer {layer} cannot run {scenario}: {reason}")
        self.layer, self.scenario, self.reason = layer, scenario, reason


def layer_option(what: str) -> Callable[[F], F]:
    """--safety-layer referee|reach: the layer ``what`` (e.g. "the run") goes through, as a
    :class:`SafetyLayer` (its parameter is ``layer``)."""
    return click.option(
        "--safety-layer", "layer", type=click.Choice([str(x) for x in REFERENCE_LAYERS]),
        default=str(SafetyLayer.REFEREE), show_default=True,
        callback=lambda _ctx, _param, value: SafetyLayer(value),
        help=f"What stands between a command and the robot's motion in {what}. referee: every "
        "command filtered again with every robot's true position (in lockstep it changes "
        "nothing); reach: the referee for robots with mass, each step certified from what the "
        "robot can reach given its dynamics: section (latency, braking, loop lag; "
        "docs/safety.md). Not for unicycles nor safety: paper.",
    )  # fmt: skip


def check_layer(scenario: Scenario, layer: SafetyLayer, dynamics: str | None) -> None:
    """Refuse a ``--safety-layer`` that cannot run ``scenario`` (robots ``dynamics``, as
    ``--dynamics`` names them), before anything starts: :class:`LayerRefused` with the layer's
    own reason. Call it after :func:`check_plant`, which vets ``dynamics``."""
    if layer == SafetyLayer.REFEREE:
        return
    s = scenario
    bounds, largest = reach_inputs(s, dynamics)
    try:  # the very factory the run calls: its refusal, said before the run
        make_layer(layer, s.params(), s.n, s.dt, s.limits, bounds=bounds, largest_obstacle=largest)
    except ValueError as exc:
        raise LayerRefused(layer, s.name, str(exc)) from None


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
