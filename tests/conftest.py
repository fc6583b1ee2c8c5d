"""Fixtures for multi-process tests: a real Zenoh router on a free loopback port, client
sessions with multicast scouting off, and helpers that wait on the bus, never on the clock."""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zenoh

from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.links import subscribe
from shoal.bus.messages import Event
from shoal.bus.runtime import Inbox
from shoal.bus.zconfig import zenoh_config
from shoal.tools.procs.launch import free_port
from shoal.tools.procs.procfs import PPID, START_TIME, STATE, stat_fields
from shoal.tools.procs.swarm import Child, Swarm
from shoal.world.loader import load_scenario

PYTHON = [sys.executable, "-m", "shoal.tools"]
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def router() -> Iterator[str]:
    """The endpoint of a fresh router process on 127.0.0.1."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with Swarm() as swarm:
        child = swarm.spawn("router", "router", ["router", "--listen", endpoint], ready_pipe=True)
        swarm.wait_ready(child, 30.0)
        yield endpoint


@contextlib.contextmanager
def client(endpoint: str) -> Iterator[zenoh.Session]:
    with zenoh.open(zenoh_config(mode="client", connect=[endpoint])) as session:
        yield session


class Watcher:
    """Follows a run's tick records and summary (and, with ``events``, its events) from a
    test's own session."""

    def __init__(self, session: zenoh.Session, run: str, *, events: bool = False) -> None:
        self.keys = Keys(run)
        self.inbox = Inbox()
        kinds = [self.keys.tick, self.keys.summary] + ([self.keys.event] if events else [])
        self._held = [subscribe(session, key, self.inbox) for key in kinds]
        self.events: list[Event] = []
        self.last_tick = -1
        self.summary: dict[str, Any] | None = None

    def until(self, done: Callable[[], bool], what: str, timeout: float = 120.0) -> None:
        deadline = time.monotonic() + timeout
        while not done():
            arrival = self.inbox.get(timeout=max(deadline - time.monotonic(), 0.0))
            if arrival is None:
                raise AssertionError(f"{what}: not seen within {timeout} s")
            if arrival.key == self.keys.event:
                self.events.append(codec.decode_event(arrival.payload))
            elif arrival.key == self.keys.tick:
                self.last_tick = codec.decode_tick(arrival.payload).tick
            elif arrival.key == self.keys.summary:
                self.summary = codec.decode_document("summary", arrival.payload)

    def until_tick(self, tick: int, timeout: float = 120.0) -> None:
        """Until tick ``tick`` is recorded, or the run is over."""
        done = lambda: self.last_tick >= tick or self.summary is not None  # noqa: E731
        self.until(done, f"tick {tick}", timeout)

    def until_summary(self, timeout: float = 120.0) -> dict[str, Any]:
        self.until(lambda: self.summary is not None, "the summary", timeout)
        assert self.summary is not None
        return self.summary

    def event(self, agent: int, word: str) -> Event | None:
        found = [e for e in self.events if e.agent == agent and word in e.text]
        return found[0] if found else None

    def until_event(self, agent: int, word: str, timeout: float = 120.0) -> Event:
        self.until(lambda: self.event(agent, word) is not None, f"{word!r} of agent {agent}",
                   timeout)  # fmt: skip
        found = self.event(agent, word)
        assert found is not None
        return found


def run_cli(args: list[str], timeout: float = 300.0) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run([*PYTHON, *args], capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        print(proc.stdout, proc.stderr, sep="\n")
    return proc


def json_of(proc: subprocess.CompletedProcess[str]) -> dict[str, Any]:
    return dict(json.loads(proc.stdout))


def processes_mentioning(text: str) -> list[int]:
    """Pids of live processes whose command line contains ``text`` (no psutil needed)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        with contextlib.suppress(OSError):
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            state = (entry / "stat").read_text().split()[2]
            if text in cmdline and state != "Z":
                found.append(int(entry.name))
    return found


def descendants(root: int) -> dict[int, tuple[str, str]]:
    """Every live process below ``root``: pid → (its name, its start time). The start time
    tells a process from a later one that reuses its pid."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        fields = stat_fields(int(entry.name)) if entry.name.isdigit() else None
        if fields is not None and fields[STATE] != "Z":
            parents[int(entry.name)] = int(fields[PPID])
    tree: set[int] = set()
    grew = True
    while grew:
        below = {p for p, pp in parents.items() if (pp == root or pp in tree) and p not in tree}
        tree |= below
        grew = bool(below)
    found = {}
    for pid in tree:
        with contextlib.suppress(OSError):
            name = Path(f"/proc/{pid}/comm").read_text().strip()
            if (fields := stat_fields(pid)) is not None:
                found[pid] = (name, fields[START_TIME])
    return found


def still_running(snapshot: dict[int, tuple[str, str]]) -> dict[int, str]:
    """Those of a :func:`descendants` snapshot that still run (same pid, same start time)."""
    left = {}
    for pid, (name, started) in snapshot.items():
        fields = stat_fields(pid)
        if fields is not None and fields[STATE] != "Z" and fields[START_TIME] == started:
            left[pid] = name
    return left


def still_running_after(snapshot: dict[int, tuple[str, str]], within: float) -> dict[int, str]:
    """Those of a :func:`descendants` snapshot still running once they have all ended or
    ``within`` s have passed, each with its state and what it waits in, to say why."""
    deadline = time.monotonic() + within
    while still_running(snapshot) and time.monotonic() < deadline:
        select.select([], [], [], 0.01)  # a condition polled with a deadline; leaves the CPU
    return {pid: f"{name} {_why(pid)}" for pid, name in still_running(snapshot).items()}


def _why(pid: int) -> str:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
        wchan = Path(f"/proc/{pid}/wchan").read_text()
    except OSError:
        return "(gone)"
    state = next((line for line in status.splitlines() if line.startswith("State:")), "")
    return f"{state.split(maxsplit=1)[-1]}, waiting in {wchan or '?'}"


def stop(proc: subprocess.Popen[Any], timeout: float = 20.0) -> int:
    """SIGTERM, wait, then SIGKILL: a test never leaves a process behind."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            return proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
    return proc.wait()


@dataclass
class Run:
    """A run's processes started one by one, so a test can kill any of them; the test's own
    session holds the "monitor" token the world waits for."""

    logger: Child
    world: Child
    agents: list[Child]
    watcher: Watcher
    token: Any


def start_run(
    swarm: Swarm,
    session: zenoh.Session,
    router: str,
    scenario: str,
    run: str,
    out: Path,
    *,
    clock: str = "lockstep",
) -> Run:
    common = ["--run", run, "--connect", router]
    watcher = Watcher(session, run)
    token = session.liveliness().declare_token(watcher.keys.alive_process("monitor"))
    logger = swarm.spawn(
        "logger", "logger", ["logger", "--out", str(out), *common], ready_pipe=True
    )
    expect = ["--expect", "logger", "--expect", "monitor"]
    world = swarm.spawn("world", "world", ["world", scenario, *common, *expect, "--clock", clock])
    agents = [
        swarm.spawn(f"agent {i}", "agent", ["agent", "--id", str(i), *common])
        for i in range(1, load_scenario(scenario).n + 1)
    ]
    swarm.wait_ready(logger, 30)
    return Run(logger, world, agents, watcher, token)


def unique(name: str) -> str:
    """A run id no other test (or concurrent test session) on this machine uses."""
    return f"{name}-{uuid.uuid4().hex[:8]}"


def shoal_run(
    scenario: Path | str, router: str, out: Path, *extra: str, run: str | None = None
) -> subprocess.Popen[str]:
    """``shoal run SCENARIO`` as a user starts it, on ``router``, logging to ``out``, with its
    stdout and stderr to read (``communicate``); ``run``: its run id (default: a fresh one)."""
    ident = ["--run", run] if run is not None else []
    return subprocess.Popen(
        [*PYTHON, "run", str(scenario), "--connect", router, *ident, "--out", str(out), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def shortened(tmp_path: Path, name: str = "sinusoid", duration: float = 4.0) -> Path:
    """A built-in scenario cut to ``duration`` seconds, as a file."""
    lines = [
        f"duration: {duration}" if line.startswith("duration:") else line
        for line in load_scenario(name).source.splitlines()
    ]
    path = tmp_path / f"{name}-{duration:g}s.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


@contextlib.contextmanager
def cpu_hogs(count: int, seconds: float) -> Iterator[None]:
    """``count`` processes spinning on the CPU for at most ``seconds`` (each ends itself then),
    stopped when the block ends: a busy machine, bounded in time, for tests that a busy machine
    slows a run down and never changes its result."""
    spin = f"import time\nend = time.monotonic() + {seconds}\nwhile time.monotonic() < end: pass"
    hogs = [subprocess.Popen([sys.executable, "-c", spin]) for _ in range(count)]
    try:
        yield
    finally:
        for h in hogs:
            h.kill()
            h.wait()


@dataclass
class Build:
    """``pip install`` of this checkout into ``target``, running in its own process group."""

    proc: subprocess.Popen[bytes]
    target: Path
    log: Path


@pytest.fixture(scope="session", autouse=True)
def _install_in_background(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Build | None]:
    """Starts the build behind :func:`installed` when the session begins, if a collected test
    uses it: mypyc's type check and one C compiler on one core take a minute and a half, which
    the session's first tests (one core each: unit and property tests) leave to it. At the
    lowest priority (nice 19), so the realtime runs it may overlap get the CPU first: the
    build only takes what they leave, and a test that needs it waits for the rest."""
    if not any("installed" in getattr(i, "fixturenames", ()) for i in request.session.items):
        yield None
        return
    target = tmp_path_factory.mktemp("site")
    log = target.parent / "pip-install.log"
    with log.open("wb") as sink:
        proc = subprocess.Popen(
            ["nice", "-n", "19", sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
             "--no-build-isolation", "--target", str(target), str(ROOT)],
            cwd=tmp_path_factory.mktemp("build"), stdout=sink, stderr=subprocess.STDOUT,
            env={**os.environ, "SHOAL_MYPYC_OPT": "0"},  # the same bits, a quicker compile
            start_new_session=True,  # its compilers too are stopped with it below
        )  # fmt: skip
    try:
        yield Build(proc, target, log)
    finally:
        if proc.poll() is None:  # the session ended (or was interrupted) before a test needed it
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


@pytest.fixture(scope="session")
def installed(_install_in_background: Build | None) -> Path:
    """A non-editable install of this checkout, as a user's ``pip install .`` builds it (its
    per-tick modules compiled where a C compiler is: setup.py); no dependencies: this venv has
    them. Shared by tests/integration/test_install.py and tests/tools/test_compiled.py; built
    from the session's start on (:func:`_install_in_background`)."""
    build = _install_in_background
    assert build is not None  # started for every session that collected a test using this
    try:
        code = build.proc.wait(timeout=600)
    except subprocess.TimeoutExpired:
        os.killpg(build.proc.pid, signal.SIGKILL)
        raise
    if code != 0:
        raise RuntimeError(f"pip install exited {code}:\n{build.log.read_text()[-4000:]}")
    return build.target


# The fast lane, `python -m pytest -m "not slow"`, for the loop of writing code; the README's
# `python -m pytest` (CI) runs every test, these included. Slow: every test of real OS processes
# (the integration, docker and netns markers), every test of the compiled install (the
# `installed` fixture: pip builds the per-tick modules with mypyc, minutes), and the tests below,
# each with why it is slow and, where it guards safety or exactness, what the fast lane keeps
# of that guarantee. A key is a test's node id without its parameters (every case), with them
# (that case), or a module (every test in it).
SLOW = {
    "tests/tools/test_campaign_reach.py::test_a_reach_campaigns_outcomes_carry_the_layers_counts":
        "a whole campaign on the physics plant; the module's other tests keep the option's checks",
    "tests/world/test_reach.py::test_latency_ignored_breaches":
        "twelve runs of three robots with mass; the fast lane keeps the property test and a mutant",
    "tests/world/test_reach.py::test_lag_ignored_breaches":
        "twelve runs of three robots with mass; the fast lane keeps the property test and a mutant",
    "tests/world/test_reach.py::test_pose_age_ignored_breaches":
        "twelve runs of three robots with mass; the fast lane keeps the property test and a mutant",
    "tests/agent/test_controller.py::test_a_follower_pressed_against_the_leader_at_its_goal_goes_round_it":
        "a whole run to the goal; the fast lane keeps the module's other evasion fixes",
    "tests/agent/test_controller.py::test_an_evasion_beside_a_slot_just_outside_the_guard_ends":
        "a whole run; the fast lane keeps the module's other evasion fixes",
    "tests/agent/test_controller.py::test_an_evasion_that_brought_its_follower_to_rest_is_reaimed_at_its_slot":
        "a long evasion simulated; the fast lane keeps the module's other evasion fixes",
    "tests/agent/test_delivery.py::test_injected_drops_are_reported_by_shoal_run":
        "`shoal run` in realtime: a router and a process per agent",
    "tests/agent/test_leader.py::test_a_leader_that_loses_sight_of_an_obstacle_round_a_cluster_does_not_turn_back":
        "a whole run round a cluster; the fast lane keeps the leader's other detours",
    "tests/geometry/test_safety.py::test_no_property_fails_on_two_thousand_crowded_cases":
        "2,000 cases; the fast lane keeps the filter's other property tests",
    "tests/geometry/test_safety_mutants.py::test_a_broken_filter_fails_the_checks[no margin]":
        "a mutant of the filter through the whole batch; the fast lane keeps the others",
    "tests/geometry/test_safety_mutants.py::test_a_broken_filter_fails_the_checks[no speed cap]":
        "as above",
    "tests/integration/test_api.py": "the API guide's examples run whole",
    "tests/integration/test_cpu.py": "processes spun and measured over windows of time",
    "tests/integration/test_forks.py": "a fork server and its children",
    "tests/integration/test_foxglove.py::test_filter_activity_is_the_logs_filtered_flags":
        "a run exported as Foxglove views",
    "tests/integration/test_fuzz.py::test_damaged_yaml_text_hypothesis":
        "the loader's fuzzing; the fast lane keeps test_mutated_builtins_hypothesis",
    "tests/integration/test_fuzz.py::test_damaged_yaml_text_seeded_random": "as above",
    "tests/integration/test_fuzz.py::test_each_decoder_on_hypothesis_bad_payloads":
        "the fuzzing's bulk; the fast lane keeps the hand-made edge cases, what fuzzing found and "
        "tests/bus/test_wire.py's random bytes",
    "tests/integration/test_fuzz.py::test_each_decoder_on_seeded_random_bad_payloads": "as above",
    "tests/integration/test_fuzz.py::test_mutated_builtins_seeded_random":
        "the loader's fuzzing; the fast lane keeps test_mutated_builtins_hypothesis",
    "tests/integration/test_fuzz.py::test_truncated_builtins_are_loaded_or_refused":
        "every truncation of every built-in; as above",
    "tests/integration/test_fuzz.py::test_valid_messages_round_trip_bit_for_bit":
        "hundreds of messages per kind; the fast lane keeps tests/bus/test_wire.py's round trips",
    "tests/integration/test_live.py": "a live Foxglove server on a port",
    "tests/tools/test_bench.py::test_the_filter_benchmark_times_real_calls_idle_and_active":
        "a benchmark",
    "tests/tools/test_campaign.py::test_a_campaign_with_the_boundary_layer_says_so_with_its_figures":
        "a whole campaign",
    "tests/tools/test_campaign.py::test_a_hard_campaign_runs_the_generators_fields_in_2d_and_3d":
        "a whole campaign; the fast lane keeps tests/tools/test_hard_fields.py",
    "tests/tools/test_campaign.py::test_a_small_campaign_is_safe_inside_and_its_failures_replay":
        "a whole campaign; the fast lane keeps "
        "test_inside_fields_with_several_obstacles_never_collide_with_the_filter",
    "tests/tools/test_campaign.py::test_hard_fields_as_unicycles_are_all_in_the_plane_and_none_collides":
        "a whole campaign; the fast lane keeps the unicycle safety tests of "
        "tests/world/test_unicycle.py",
    "tests/tools/test_campaign.py::test_kinematics_unicycle_turns_the_fields_into_unicycles_facing_anywhere":
        "a whole campaign",
    "tests/tools/test_campaign.py::test_the_campaign_says_up_front_how_many_runs_its_options_make":
        "three whole campaigns",
    "tests/tools/test_cli.py::test_fast_leader_warns_but_runs":
        "a whole simulation; the fast lane keeps test_simulate_out_saves_the_exact_trajectory",
    "tests/tools/test_cli.py::test_run_on_an_unreachable_router_says_so_and_starts_nothing":
        "waits out a Zenoh session's failure to connect",
    "tests/tools/test_cli.py::test_simulate_json_has_the_documented_keys":
        "a whole simulation; the fast lane keeps test_simulate_out_saves_the_exact_trajectory",
    "tests/tools/test_cli.py::test_simulate_out_names_the_file_it_writes_and_never_overwrites_unasked":
        "as above",
    "tests/tools/test_cli.py::test_simulate_prints_arrival_and_the_theorems_margins": "as above",
    "tests/tools/test_cli.py::test_summary_rows_that_could_look_like_faults_say_what_they_mean":
        "as above",
    "tests/tools/test_cluster.py": "a Dask cluster of worker processes",
    "tests/tools/test_hard_fields.py::test_a_sampled_sign_law_cycle_that_never_arrives_arrives_with_the_boundary_layer":
        "two whole runs of a hard field",
    "tests/tools/test_last_run.py": "runs recorded to read back",
    "tests/tools/test_people_campaign.py::test_one_field_is_judged_with_its_static_twin":
        "two whole runs; the fast lane keeps the crowds' reproducibility and "
        "tests/world/test_unicycle.py's give-way to a person",
    "tests/tools/test_people_campaign.py::test_the_cli_reports_contacts_by_fault_and_fails_on_an_agents_fault":
        "a whole campaign; as above",
    "tests/tools/test_people_campaign.py::test_the_cli_runs_unicycles_among_people_and_says_so":
        "a whole campaign; as above",
    "tests/tools/test_people_campaign.py::test_unicycles_among_people_tick_fast_enough_for_the_robots_speed":
        "two whole runs; as above",
    "tests/tools/test_plot.py": "matplotlib draws every figure",
    "tests/tools/test_portable.py":
        "a process per BLAS kernel; the fast lane keeps every built-in's stored digest "
        "(tests/world/test_scenarios_run.py)",
    "tests/world/test_convergence.py::test_converges_within_the_bound_from_random_starts":
        "200 random formations each; the fast lane keeps every built-in's bound "
        "(tests/world/test_scenarios_run.py)",
    "tests/world/test_onboard.py::test_each_broken_layer_lets_robots_meet[_AgeIgnored]":
        "a mutant of the onboard layers run to a meeting; the fast lane keeps one mutant",
    "tests/world/test_onboard.py::test_each_broken_layer_lets_robots_meet[_LeewayWithoutAge]":
        "as above",
    "tests/world/test_onboard.py::test_each_broken_layer_lets_robots_meet[_NoWait]": "as above",
    "tests/world/test_onboard.py::test_each_broken_layer_lets_robots_meet[_StaleCells]": "as above",
    "tests/world/test_safety_modes.py::test_the_filter_is_on_by_default_and_idle_on_the_builtins":
        "every built-in run twice; the fast lane keeps every built-in's stored digest in both "
        "modes (tests/world/test_scenarios_run.py)",
    "tests/world/test_unicycle.py::test_each_term_of_the_margin_is_there_for_a_reason":
        "a run per term left out of the margin",
    "tests/world/test_unicycle.py::test_the_robotarium_run_keeps_its_bodies_apart_and_off_the_obstacles":
        "a whole run; the fast lane keeps the unicycle filter's properties over a tick",
    "tests/world/test_unicycle.py::test_the_summary_says_how_often_the_point_is_held_to_its_cap":
        "a whole run",
    "tests/world/test_unicycle.py::test_unicycles_that_start_facing_away_turn_round_beside_obstacles_and_arrive":
        "whole runs to the goal",
}  # fmt: skip
SLOW_MARKERS = ("integration", "docker", "netns")


@pytest.hookimpl(tryfirst=True)  # before -m deselects
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    used: set[str] = set()
    for item in items:
        node, _, case = item.nodeid.partition("[")
        keys = (node.split("::")[0], node, item.nodeid if case else None)
        named = [key for key in keys if key in SLOW]
        used.update(named)
        installed = "installed" in getattr(item, "fixturenames", ())
        if named or installed or any(item.get_closest_marker(m) for m in SLOW_MARKERS):
            item.add_marker(pytest.mark.slow)
    # On a run of the whole suite, a key that names no test is a renamed or removed one.
    whole = not config.option.file_or_dir and not getattr(config.option, "lf", False)
    if whole and (stale := set(SLOW) - used):
        raise pytest.UsageError(f"tests/conftest.py SLOW names no test: {sorted(stale)}")
