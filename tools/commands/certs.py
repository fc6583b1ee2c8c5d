"""``shoal certs``: make the secured mode's material for one run (docs/security.md)."""

from __future__ import annotations

from pathlib import Path

import click

from shoal.bus.acl import agent_name
from shoal.tools.certs import DEFAULT_HOSTS, CertError, make_material
from shoal.tools.procs.children import check_run_id


@click.command()
@click.argument("directory", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--run", "run_id", required=True, callback=check_run_id, help="The run the rules are for."
)
@click.option(
    "--agents", type=click.IntRange(min=1), required=True, help="Agents 1..N get an identity."
)
@click.option(
    "--host",
    "hosts",
    multiple=True,
    help="A DNS name or IP address clients use to reach the router (repeatable) "
    f"[default: {', '.join(DEFAULT_HOSTS)}].",
)
@click.option("--days", type=click.IntRange(min=1), default=365, help="Certificate lifetime.")
def certs(directory: Path, run_id: str, agents: int, hosts: tuple[str, ...], days: int) -> None:
    """Make DIRECTORY: a local CA, a certificate, key and password for the router, the world,
    the logger, the monitor and each agent, and the router's access rules for run RUN.

    Re-running keeps the CA and existing identities and rewrites the rules (a new run id, more
    agents). Give each host only ca.pem and its own folder.
    """
    try:
        m = make_material(
            directory, run=run_id, agents=agents, hosts=hosts or DEFAULT_HOSTS, days=days
        )
    except CertError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"secured mode material for run {run_id} in {m.root}")
    click.echo(f"  router:   shoal router --secure {m.root} --listen tls/127.0.0.1:7447")
    click.echo(f"  clients:  --secure {m.root} --connect tls/127.0.0.1:7447")
    click.echo(f"  identities: world, logger, monitor, {agent_name(1)} … {agent_name(agents)}")
