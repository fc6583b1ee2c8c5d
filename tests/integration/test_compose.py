"""`shoal compose` and tools/deploy/compose.py without Docker: the generated file's structure, that
its environment variables are options the commands really read, and that docker/compose.yaml is
exactly the generator's output for `default` (so it never goes stale)."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import click
import pytest
import yaml
from click.testing import CliRunner
from conftest import run_cli, unique

from shoal.tools.cli import main
from shoal.tools.deploy.compose import (
    ENDPOINT,
    SCENARIO_PATH,
    compose_dict,
    compose_yaml,
    run_id_for,
)
from shoal.tools.procs.launch import free_port
from shoal.tools.procs.swarm import Swarm
from shoal.world.loader import builtin_names, load_scenario

REPO = Path(__file__).resolve().parents[2]
SHIPPED = REPO / "docker" / "compose.yaml"
_VARIABLE = re.compile(r"\$\{(\w+):-([^}]*)\}")


def test_docker_compose_yaml_is_the_output_of_shoal_compose_default(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    expected = compose_yaml(
        load_scenario("default"), builtin=True, label="default", build_context=".."
    )
    assert SHIPPED.read_text() == expected, (
        "regenerate: shoal compose default -o docker/compose.yaml"
    )
    monkeypatch.chdir(REPO / "docker")  # the build context is written relative to the output
    result = CliRunner().invoke(main, ["compose", "default"])
    assert result.exit_code == 0, result.output
    assert result.output == expected


@pytest.mark.parametrize("name", builtin_names())
def test_one_service_per_process_with_explicit_tcp_endpoints(name: str) -> None:
    scn = load_scenario(name)
    spec = yaml.safe_load(compose_yaml(scn, builtin=True, label=name))
    services = spec["services"]
    agents = [f"agent-{i}" for i in range(1, scn.n + 1)]
    assert list(services) == ["router", "logger", "world", *agents]
    for service in services.values():
        assert service["init"] is True  # docker stop's SIGTERM reaches the process
        assert service["image"] == "${SHOAL_IMAGE:-shoal}"
        assert "network_mode" not in service and "ports" not in service
        env = service["environment"]
        assert not any("MULTICAST" in key for key in env)
        assert env["ZENOH_CONFIG"] == "${SHOAL_ZENOH_CONFIG:-}"
    for client in ["logger", "world", *agents]:
        assert services[client]["depends_on"] == {"router": {"condition": "service_healthy"}}
        command = services[client]["command"][0].upper()
        assert services[client]["environment"][f"SHOAL_{command}_CONNECT"] == ENDPOINT
    assert [services[a]["command"] for a in agents] == [
        ["agent", "--id", str(i)] for i in range(1, scn.n + 1)
    ]
    assert services["world"]["command"] == ["world", name]
    assert "build" not in services["router"]


def interpolated(value: str) -> str:
    """What compose makes of ``${VAR:-default}`` when VAR is unset."""
    return _VARIABLE.sub(lambda m: m.group(2), value)


def parsed(service: dict[str, Any], monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """The options the service's command gets from its command line and environment, as click
    resolves them (auto_envvar_prefix SHOAL): a misspelt variable would simply be ignored."""
    for key, value in service["environment"].items():
        monkeypatch.setenv(key, interpolated(value))
    name, *args = service["command"]
    with click.Context(main, info_name="shoal", auto_envvar_prefix="SHOAL") as parent:
        command = main.get_command(parent, name)
        assert command is not None
        with command.make_context(name, list(args), parent=parent) as ctx:
            return dict(ctx.params)


def test_every_variable_is_an_option_its_command_reads(monkeypatch: pytest.MonkeyPatch) -> None:
    services = yaml.safe_load(SHIPPED.read_text())["services"]
    router = parsed(services["router"], monkeypatch)
    assert router["listen"] == ("tcp/0.0.0.0:7447",)
    assert router["exit_after_run"] == "default"  # ends with the run: `up` returns
    logger = parsed(services["logger"], monkeypatch)
    assert logger["run_id"] == "default" and logger["connect"] == (ENDPOINT,)
    assert logger["out"] == Path("/runs/default.mcap")
    assert services["logger"]["volumes"][-1] == "${SHOAL_RUNS_DIR:-./runs}:/runs"
    world = parsed(services["world"], monkeypatch)
    assert world["scenario"] == "default" and world["expect"] == ("logger",)
    assert world["run_id"] == "default" and world["connect"] == (ENDPOINT,)
    agent = parsed(services["agent-3"], monkeypatch)
    assert agent["agent_id"] == 3 and agent["run_id"] == "default"
    assert agent["connect"] == (ENDPOINT,)


def test_a_scenario_file_travels_inside_the_compose_file(tmp_path: Path) -> None:
    text = load_scenario("sinusoid").source.replace("name: sinusoid", "name: my wedge")
    text += "# costs $5 and ${HOME}\n"  # compose would interpolate a bare $
    path = tmp_path / "mine.yaml"
    path.write_text(text)
    out = tmp_path / "out" / "compose.yaml"
    out.parent.mkdir()
    result = CliRunner().invoke(main, ["compose", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    spec = yaml.safe_load(out.read_text())
    assert spec["name"] == "shoal-my-wedge"
    assert spec["configs"]["scenario"]["content"].replace("$$", "$") == text
    world = spec["services"]["world"]
    assert world["command"] == ["world", SCENARIO_PATH]
    assert world["configs"] == [{"source": "scenario", "target": SCENARIO_PATH}]
    assert world["environment"]["SHOAL_WORLD_RUN_ID"] == "${SHOAL_RUN:-my-wedge}"
    context = spec["services"]["router"]["build"]["context"]
    assert (out.parent / context).resolve() == REPO  # relative to the compose file


def test_no_build_leaves_the_image_to_the_user() -> None:
    result = CliRunner().invoke(main, ["compose", "passage", "--no-build"])
    assert result.exit_code == 0, result.output
    spec = yaml.safe_load(result.stdout)
    assert "build" not in spec["services"]["router"]
    assert "the image ${SHOAL_IMAGE:-shoal} must exist first" in result.stderr
    assert "docker build -f docker/Dockerfile -t shoal ." in result.stderr
    assert len(spec["services"]) == 3 + load_scenario("passage").n


def test_unknown_scenario_is_a_clear_error() -> None:
    result = CliRunner().invoke(main, ["compose", "nowhere"])
    assert result.exit_code == 1
    assert "no file 'nowhere' and no built-in" in result.output


@pytest.mark.parametrize(
    ("name", "run"), [("default", "default"), ("my wedge.v2", "my-wedge-v2"), ("", "run")]
)
def test_run_id_for_keeps_only_what_a_run_id_may_hold(name: str, run: str) -> None:
    assert run_id_for(name) == run


def test_compose_dict_is_pure_data() -> None:
    """Plain dicts, lists, strings, ints and bools: anything can serialise it (JSON too)."""
    spec = compose_dict(load_scenario("default"), builtin=True, build_context="..")
    assert yaml.safe_load(yaml.safe_dump(spec)) == yaml.safe_load(SHIPPED.read_text())
    assert os.path.basename(spec["services"]["router"]["build"]["dockerfile"]) == "Dockerfile"


@pytest.mark.integration
def test_the_router_ends_with_its_run_so_compose_up_returns(tmp_path: Path) -> None:
    """What `docker compose up` relies on, without Docker: `shoal router --exit-after-run RUN`
    exits 0 by itself once the run's world and every other process of the run have left."""
    short = tmp_path / "short.yaml"
    short.write_text(load_scenario("sinusoid").source.replace("duration: 30.0", "duration: 1.0"))
    endpoint, run = f"tcp/127.0.0.1:{free_port()}", unique("compose")
    with Swarm() as swarm:
        router = swarm.spawn(
            "router", "router", ["router", "--listen", endpoint, "--exit-after-run", run],
            ready_pipe=True,
        )  # fmt: skip
        swarm.wait_ready(router, 30)
        out = tmp_path / "run.mcap"
        proc = run_cli(["run", str(short), "--connect", endpoint, "--run", run, "--out", str(out)])
        assert proc.returncode == 0
        router.done = True
        assert router.popen.wait(timeout=30) == 0


def test_an_install_without_a_checkout_writes_the_shipped_file_given_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """From an installed wheel (no checkout beside the packages) `--build-context CHECKOUT`
    writes docker/compose.yaml as shipped; a folder that is not a checkout is refused."""
    import shoal.tools.commands.compose as command

    monkeypatch.setattr(command, "_CHECKOUT", tmp_path / "site-packages")
    monkeypatch.chdir(REPO / "docker")  # where the shipped file is: its context is ".."
    bare = CliRunner().invoke(main, ["compose", "default"])
    assert "build:" not in bare.stdout and "--build-context CHECKOUT" in bare.stderr
    given = CliRunner().invoke(main, ["compose", "default", "--build-context", str(REPO)])
    assert given.exit_code == 0, given.output
    assert given.stdout == SHIPPED.read_text(encoding="utf-8")
    wrong = CliRunner().invoke(main, ["compose", "default", "--build-context", str(tmp_path)])
    assert wrong.exit_code == 2 and "has no docker/Dockerfile" in wrong.output
