"""``shoal compose``: write the docker compose file of a scenario (see tools/deploy/compose.py)."""

from __future__ import annotations

import os
from pathlib import Path

import click

from shoal.tools.commands.options import load_for_cli
from shoal.tools.deploy.compose import compose_yaml
from shoal.world.loader import builtin_names

# The checkout this command runs from, if it is one (an editable install): the image is built
# from it. An installed wheel has no docker/Dockerfile beside its packages.
_CHECKOUT = Path(__file__).resolve().parents[2]


@click.command()
@click.argument("scenario", default="default")
@click.option(
    "--out",
    "-o",
    type=click.Path(dir_okay=False, writable=True, path_type=Path),
    help="Write the compose file here instead of to stdout.",
)
@click.option(
    "--no-build",
    is_flag=True,
    help="Leave out the build section: the image ($SHOAL_IMAGE, else shoal) must exist.",
)
@click.option(
    "--build-context",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="The shoal checkout to build the image from (its docker/Dockerfile)  [default: the "
    "checkout shoal runs from, if it runs from one; an installed wheel has none].",
)
def compose(scenario: str, out: Path | None, no_build: bool, build_context: Path | None) -> None:
    """Write the docker compose file that runs SCENARIO (a built-in name or a YAML file):
    a router, the world, the logger and one service per agent.

    A built-in is run by name; a file's text is embedded in the compose file, so the file is
    all that travels. When shoal runs from a checkout, the router's service builds the image
    from it (docker/Dockerfile), with the path written relative to the compose file.
    docker/compose.yaml is `shoal compose default -o docker/compose.yaml`.
    """
    scn = load_for_cli(scenario)
    builtin = scenario in builtin_names() and not Path(scenario).exists()
    checkout = _CHECKOUT if build_context is None else build_context.resolve()
    if build_context is not None and not (checkout / "docker" / "Dockerfile").is_file():
        raise click.BadParameter(
            f"{build_context} has no docker/Dockerfile: give a shoal checkout",
            param_hint="--build-context",
        )
    context = None
    if not no_build and (checkout / "docker" / "Dockerfile").is_file():
        here = (out.parent if out else Path()).resolve()
        context = Path(os.path.relpath(checkout, here)).as_posix()
    text = compose_yaml(scn, builtin=builtin, label=scenario, build_context=context)
    if out is None:
        click.echo(text, nl=False)
    else:
        out.write_text(text, encoding="utf-8")
        click.echo(
            f"wrote {out} ({scn.n} agents); run it with: docker compose -f {out} up", err=True
        )
    if context is None:  # said on stdout's side too: a file piped away still gets the hint
        click.echo(
            "no build section: the image ${SHOAL_IMAGE:-shoal} must exist first; build it "
            "from a shoal checkout with `docker build -f docker/Dockerfile -t shoal .` (or run "
            "`shoal compose --build-context CHECKOUT`, whose compose file builds it)",
            err=True,
        )
