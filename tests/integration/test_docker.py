"""The image and the compose files, for real: docker build, docker compose up / down.

Skipped when no Docker engine answers, unless SHOAL_REQUIRE_DOCKER=1 (CI sets it after
.ci/docker-setup has started one), in which case that is a failure. The image is built once per
session as shoal:test, from CI's base image local/bookworm:base when it exists (no registry
there), else from the Dockerfile's default. Every compose project has a unique name and is taken
down afterwards; the image stays tagged so the next session's build is a cache hit.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from shoal.tools.deploy.compose import compose_yaml
from shoal.tools.log.reader import read_documents, read_ticks, read_trajectory
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario

pytestmark = pytest.mark.docker

REPO = Path(__file__).resolve().parents[2]
IMAGE = "shoal:test"
CI_BASE = "local/bookworm:base"


def docker(
    *args: str, timeout: float = 60.0, cwd: Path | None = None, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["docker", *args], capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env
    )


def engine_answers() -> bool:
    try:
        return docker("info").returncode == 0 and docker("compose", "version").returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def image_id(ref: str) -> str | None:
    proc = docker("image", "inspect", "--format", "{{.Id}}", ref)
    return proc.stdout.strip() if proc.returncode == 0 else None


@pytest.fixture(scope="session")
def image() -> str:
    """shoal:test built from this checkout; a rebuild removes the image it replaces."""
    if not engine_answers():
        message = "no Docker engine answers (`docker info`), or no `docker compose`"
        if os.environ.get("SHOAL_REQUIRE_DOCKER") == "1":
            pytest.fail(f"SHOAL_REQUIRE_DOCKER=1 but {message}")
        pytest.skip(message)
    before = image_id(IMAGE)
    base = ["--build-arg", f"BASE_IMAGE={CI_BASE}"] if image_id(CI_BASE) else []
    build = docker(
        "build", "-q", "-f", "docker/Dockerfile", "-t", IMAGE, *base, ".",
        cwd=REPO, timeout=900,
    )  # fmt: skip
    assert build.returncode == 0, build.stderr[-3000:]
    if before and before != image_id(IMAGE):
        docker("rmi", before)  # the previous build, now untagged; fails harmlessly if in use
    return IMAGE


@dataclass
class Project:
    """One compose project: a compose file, a unique project name, the variables it reads."""

    file: Path
    runs: Path
    run: str
    name: str

    def compose(self, *args: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
        env = {
            **os.environ,
            "SHOAL_IMAGE": IMAGE,
            "SHOAL_RUN": self.run,
            "SHOAL_RUNS_DIR": str(self.runs),
            "SHOAL_USER": f"{os.getuid()}:{os.getgid()}",
            "SHOAL_ZENOH_CONFIG": "/etc/shoal/zenoh/example.json5",
            "SHOAL_ZENOH_DIR": str(REPO / "docker" / "zenoh"),
        }
        cmd = ["compose", "-f", str(self.file), "-p", self.name, *args]
        return docker(*cmd, timeout=timeout, env=env)

    @property
    def log(self) -> Path:
        return self.runs / f"{self.run}.mcap"

    def states(self) -> dict[str, tuple[str, int]]:
        """Each service's container state and exit code."""
        out = self.compose("ps", "--all", "--format", "json").stdout
        rows = [json.loads(line) for line in out.splitlines() if line.strip()]
        if len(rows) == 1 and isinstance(rows[0], list):  # older compose: one JSON array
            rows = rows[0]
        return {r["Service"]: (r["State"], int(r["ExitCode"])) for r in rows}


@pytest.fixture
def project(image: str, tmp_path: Path) -> Iterator[Project]:
    runs = tmp_path / "runs"
    runs.mkdir()
    tag = uuid.uuid4().hex[:8]
    p = Project(REPO / "docker" / "compose.yaml", runs, f"test-{tag}", f"shoal-test-{tag}")
    try:
        yield p
    finally:
        p.compose("down", "--volumes", "--remove-orphans", "--timeout", "5", timeout=120)


def finished(log: Path) -> bool:
    """Only a finished MCAP file has a summary section with statistics."""
    with log.open("rb") as f:
        summary = make_reader(f).get_summary()
    return summary is not None and summary.statistics is not None


def test_compose_up_runs_default_to_its_end_and_equals_the_reference(project: Project) -> None:
    up = project.compose("up", "--no-color", timeout=300)
    assert up.returncode == 0, up.stdout[-3000:] + up.stderr[-3000:]
    services = {"router", "world", "logger", *(f"agent-{i}" for i in range(1, 6))}
    assert project.states() == dict.fromkeys(services, ("exited", 0)), up.stdout[-3000:]
    assert finished(project.log)
    scn = load_scenario("default")
    assert read_trajectory(project.log, dt=scn.dt).equals(simulate(scn))
    assert read_documents(project.log)["summary"]["collisions"] == 0


def test_compose_down_mid_run_leaves_a_finished_mcap(project: Project, tmp_path: Path) -> None:
    # A generated file, for a scenario given as a file: its text travels inside the compose file.
    scenario = tmp_path / "crossing.yaml"
    scenario.write_text(load_scenario("obstacles").source)
    scn = load_scenario(scenario)
    project.file = tmp_path / "compose.yaml"
    project.file.write_text(compose_yaml(scn, builtin=False, label=str(scenario)))
    up = project.compose("up", "--detach", timeout=120)
    assert up.returncode == 0, up.stderr[-3000:]
    # Ready when the logger has flushed 100 kB: about 150 ticks at ~680 compressed bytes each.
    deadline = time.monotonic() + 120
    while not (project.log.exists() and project.log.stat().st_size > 100_000):
        assert time.monotonic() < deadline, project.compose("logs").stdout[-3000:]
        assert project.states()["world"][0] == "running", project.compose("logs").stdout[-3000:]
        time.sleep(0.2)  # a polling interval: the condition above is what synchronises
    down = project.compose("down", "--timeout", "20", timeout=120)
    assert down.returncode == 0, down.stderr[-3000:]
    assert finished(project.log)
    # The stop reaches the processes one by one: from the first tick the world held a stopped
    # agent still, the run departs from the reference. Up to there it equals it exactly.
    whole = [r for r in read_ticks(project.log) if all(r.alive)]
    assert [r.tick for r in whole] == list(range(len(whole)))
    ref = simulate(scn)
    assert 100 <= len(whole) < ref.ticks  # stopped mid-run, well after the start
    got = np.asarray([r.positions for r in whole])
    assert np.array_equal(got, ref.positions[: len(whole)])
