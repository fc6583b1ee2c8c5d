"""Options shared by the process commands (router, world, agent, logger, run)."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from shoal.bus.errors import WireError
from shoal.bus.keys import Keys
from shoal.world.errors import ScenarioError, ScenarioWarning
from shoal.world.loader import load_scenario
from shoal.world.scenario import Scenario

F = TypeVar("F", bound=Callable[..., Any])


def drop_options(func: F) -> F:
    """--drop-rate, --drop-seed: realtime fault injection (shoal agent, and shoal run for all)."""
    func = click.option(
        "--drop-seed", default=0, envvar="SHOAL_DROP_SEED", help="Seed of the injected drops."
    )(func)
    return click.option(
        "--drop-rate",
        type=click.FloatRange(min=0.0, max=1.0, max_open=True),
        default=0.0,
        envvar="SHOAL_DROP_RATE",
        help="Fault injection, realtime only: throw away this fraction of incoming neighbour "
        "states (seeded, counted; shoal run totals them in its summary, `injected_drops`).",
    )(func)


def bus_options(func: F) -> F:
    """--run, --connect, --zenoh-config, --multicast, --secure."""
    func = click.option(
        "--secure",
        type=click.Path(exists=True, file_okay=False, path_type=Path),
        help="Secured mode: TLS with this run's certificates, a password and the router's "
        "access rules, from DIR (made by `shoal certs DIR`; docs/security.md).",
    )(func)
    func = click.option(
        "--multicast", is_flag=True, help="Allow Zenoh multicast scouting (off by default)."
    )(func)
    func = click.option(
        "--zenoh-config",
        type=click.Path(exists=True, dir_okay=False, path_type=Path),
        help="A Zenoh JSON5 config file (ZENOH_CONFIG is honoured too).",
    )(func)
    func = click.option(
        "--connect",
        "-e",
        multiple=True,
        help="Zenoh endpoint of the router, e.g. tcp/127.0.0.1:7447 (repeatable).",
    )(func)
    func = click.option(
        "--run",
        "run_id",
        required=True,
        callback=check_run_id,
        help="The run id every key lives under.",
    )(func)
    return func


def check_run_id(_ctx: click.Context, _param: click.Parameter, value: str | None) -> str | None:
    """Refuse a run id that cannot be a Zenoh key chunk, before anything starts."""
    if value is not None:
        try:
            Keys(value)
        except WireError as exc:
            raise click.BadParameter(str(exc)) from None
    return value


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
