"""The docker compose file of a scenario: a router, the world, the logger and one service per agent.

Compose gives scaled replicas no index, so every agent is its own service (``agent-<id>``) and
the file is generated per scenario rather than written by hand. Everything here is pure: a
scenario in, a dict or its YAML text out (``shoal compose`` writes it; docker/compose.yaml is
its output for ``default``, and a test keeps the two equal).

Design (docs/docker.md):

- explicit TCP endpoints (``tcp/router:7447`` on the compose network), multicast off;
- configuration by environment variables, which click reads (``SHOAL_<COMMAND>_<OPTION>``);
  what a user may change is a compose variable with a default (``${SHOAL_RUN:-default}``),
  and a mounted folder of Zenoh configs selected with ``SHOAL_ZENOH_CONFIG``;
- ``init: true``: a signal-forwarding PID 1, so ``docker compose down`` reaches the processes'
  SIGTERM handlers and the logger finishes its file;
- the router exits 0 once the run is over (``--exit-after-run``), so ``docker compose up``
  returns when the run ends with every container exited 0.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from shoal.tools.procs.children import AgentSpec, ChildSpec, LoggerSpec, RouterSpec, WorldSpec
from shoal.world.scenario import Scenario

PORT = 7447
ENDPOINT = f"tcp/router:{PORT}"
ZENOH_DIR = "/etc/shoal/zenoh"  # where ./zenoh is mounted in every container
SCENARIO_PATH = "/etc/shoal/scenario.yaml"  # where a scenario file is put in the world container
DEFAULT_BASE = "python:3.11-slim"

# The router is healthy once it accepts TCP connections: the clients then connect at their first
# attempt, even with a mounted Zenoh config (which turns shoal's connect retries off).
_HEALTH = f'import socket; socket.create_connection(("127.0.0.1", {PORT}), 1)'


def run_id_for(name: str) -> str:
    """The default run id: the scenario's name, cut to what a run id may hold."""
    return re.sub(r"[^A-Za-z0-9_-]", "-", name)[:64] or "run"


def compose_dict(
    scenario: Scenario, *, builtin: bool, build_context: str | None = None
) -> dict[str, Any]:
    """The compose file for ``scenario`` as a dict.

    builtin: the image has the scenario by name; otherwise its YAML text is embedded as a
    compose config and mounted into the world's container. build_context: the shoal checkout
    relative to the compose file, to build the image from (None: the image must exist).
    """
    run = f"${{SHOAL_RUN:-{run_id_for(scenario.name)}}}"
    client: dict[str, Any] = {"run_id": run, "connect": (ENDPOINT,)}

    router = _service(RouterSpec(listen=(f"tcp/0.0.0.0:{PORT}",), exit_after_run=run))
    del router["depends_on"]
    if build_context is not None:
        router["build"] = {
            "context": build_context,
            "dockerfile": "docker/Dockerfile",
            "args": {"BASE_IMAGE": f"${{SHOAL_BASE_IMAGE:-{DEFAULT_BASE}}}"},
        }
    router["healthcheck"] = {
        "test": ["CMD", "python3", "-c", _HEALTH],
        "interval": "1s",
        "timeout": "2s",
        "retries": 30,
    }

    logger = _service(LoggerSpec(out=Path(f"/runs/{run}.mcap"), **client))
    logger["volumes"].append("${SHOAL_RUNS_DIR:-./runs}:/runs")
    logger["user"] = "${SHOAL_USER:-0:0}"  # who owns the log on the host

    where = scenario.name if builtin else SCENARIO_PATH
    world = _service(WorldSpec(scenario=where, expect=("logger",), **client))
    agents = {
        f"agent-{i}": _service(AgentSpec(agent_id=i, **client)) for i in range(1, scenario.n + 1)
    }
    spec: dict[str, Any] = {
        "name": f"shoal-{run_id_for(scenario.name).lower()}",
        "services": {"router": router, "logger": logger, "world": world, **agents},
    }
    if not builtin:
        world["configs"] = [{"source": "scenario", "target": SCENARIO_PATH}]
        # Compose interpolates $ in every value, config contents included: escape it.
        spec["configs"] = {"scenario": {"content": scenario.source.replace("$", "$$")}}
    return spec


def _service(spec: ChildSpec) -> dict[str, Any]:
    """One shoal process: the image's entrypoint is ``shoal``; options travel as click's
    environment variables (SHOAL_<COMMAND>_<OPTION>), the Zenoh config as Zenoh's own."""
    return {
        "image": "${SHOAL_IMAGE:-shoal}",
        "init": True,
        "command": [spec.command, *spec.identity()],
        "environment": {
            **spec.environment(),
            "ZENOH_CONFIG": "${SHOAL_ZENOH_CONFIG:-}",
            "ZENOH_CONFIG_OVERRIDE": "${SHOAL_ZENOH_CONFIG_OVERRIDE:-}",
        },
        "volumes": [f"${{SHOAL_ZENOH_DIR:-./zenoh}}:{ZENOH_DIR}:ro"],
        "depends_on": {"router": {"condition": "service_healthy"}},
    }


def compose_yaml(
    scenario: Scenario, *, builtin: bool, label: str, build_context: str | None = None
) -> str:
    """The compose file's text; ``label`` is the scenario as given to ``shoal compose``."""
    spec = compose_dict(scenario, builtin=builtin, build_context=build_context)
    header = (
        f"# Generated by `shoal compose {label}`: regenerate it, do not edit it.\n"
        "# Run with `docker compose -f FILE up`; variables and mounts: docs/docker.md.\n"
    )
    body = yaml.dump(_styled(spec), Dumper=_Dumper, sort_keys=False, width=100, allow_unicode=True)
    return header + body


_ONE_LINE = {"command", "test"}  # lists written on one line: commands read like commands


def _styled(value: Any, key: str = "") -> Any:
    """``value`` with the lists under :data:`_ONE_LINE` keys marked for flow style."""
    if isinstance(value, dict):
        return {k: _styled(v, k) for k, v in value.items()}
    if isinstance(value, list):
        items = [_styled(v) for v in value]
        return _Flow(items) if key in _ONE_LINE else items
    return value


class _Flow(list[Any]):
    """A list the dumper writes on one line (``[agent, --id, '3']``)."""


class _Dumper(yaml.SafeDumper):
    """Block style with indented lists, no anchors, multi-line strings as literal blocks."""

    def ignore_aliases(self, data: Any) -> bool:
        return True

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        super().increase_indent(flow, False)


def _flow(dumper: yaml.SafeDumper, data: _Flow) -> yaml.Node:
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=True)


def _text(dumper: yaml.SafeDumper, data: str) -> yaml.Node:
    style = "|" if "\n" in data else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", data, style=style)


_Dumper.add_representer(_Flow, _flow)
_Dumper.add_representer(str, _text)
