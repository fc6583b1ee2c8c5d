"""Multi-process integration: real OS processes, a real Zenoh router, loopback only.

Readiness comes from liveliness tokens and the run's own tick records; nothing sleeps.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import time
from pathlib import Path

import msgpack
import pytest
from conftest import (
    PYTHON,
    Watcher,
    client,
    cpu_hogs,
    descendants,
    json_of,
    processes_mentioning,
    run_cli,
    shoal_run,
    shortened,
    start_run,
    still_running_after,
    stop,
    unique,
)
from mcap.reader import make_reader
from physics_cases import mixed_robotarium
from test_readme import RUN_HERE as README_RUNS  # checked there, from the README's own commands

from shoal.bus import codec
from shoal.bus.messages import AgentState, Sensing
from shoal.bus.runtime import EXIT_GRACE_S
from shoal.tools.commands.report import json_safe
from shoal.tools.log.reader import iter_channel, read_trajectory
from shoal.tools.procs.reaper import WAIT_S as REAPER_WAIT_S
from shoal.tools.procs.swarm import Swarm
from shoal.tools.simulator import simulate
from shoal.world.loader import builtin_names, load_scenario, parse_scenario
from shoal.world.metrics import summarize

pytestmark = pytest.mark.integration


def reference(scenario: str | Path) -> tuple[object, object]:
    scn = load_scenario(scenario)
    traj = simulate(scn)
    return scn, traj


@pytest.mark.parametrize("name", [n for n in builtin_names() if n not in README_RUNS])
def test_lockstep_run_equals_the_reference_simulator_bit_for_bit(name: str, tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    proc = run_cli(["run", name, "--json", "--no-foxglove", "--out", str(out)])
    assert proc.returncode == 0
    got = json_of(proc)
    scn = load_scenario(name)
    ref = simulate(scn)
    assert read_trajectory(out, dt=scn.dt).equals(ref)
    expected = json_safe(summarize(scn, ref).as_dict())
    assert {k: got[k] for k in expected} == expected
    assert got["clock"] == "lockstep" and got["wall_s"] > 0


def test_a_mixed_formation_runs_distributed_equal_to_the_reference(tmp_path: Path) -> None:
    """GRITSbots with two holonomic followers among them (``kinematics: single`` per agent):
    the distributed lockstep run equals the reference bit for bit, headings included."""
    text = mixed_robotarium(10.0)
    path = tmp_path / "mixed.yaml"
    path.write_text(text)
    out = tmp_path / "run.mcap"
    proc = run_cli(["run", str(path), "--json", "--no-foxglove", "--out", str(out)])
    assert proc.returncode == 0, proc.stderr
    scn = parse_scenario(text)
    assert scn.lookaheads is not None and scn.lookaheads.tolist() == [0.05, 0, 0.05, 0.05, 0]
    got = read_trajectory(out, dt=scn.dt)
    assert got.headings is not None and got.equals(simulate(scn))


def test_sigkill_of_a_follower_mid_run_is_survived_and_logged(router: str, tmp_path: Path) -> None:
    scenario = shortened(tmp_path, "obstacles", duration=8.0)
    out = tmp_path / "run.mcap"
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), unique("killone"), out)
        watcher, logger, world, agents = r.watcher, r.logger, r.world, r.agents
        watcher.until_tick(200)
        os.kill(agents[2].popen.pid, signal.SIGKILL)  # follower 3
        agents[2].done = True
        summary = watcher.until_summary()
        assert world.popen.wait(timeout=30) == 0
        assert logger.popen.wait(timeout=30) == 0
        for a in agents:
            a.done = True
            a.popen.wait(timeout=30)
    assert summary["steps"] == 800
    assert [a.popen.returncode for a in agents if a is not agents[2]] == [0, 0, 0, 0]
    events = [codec.decode_event(d) for _t, d, _ns in iter_channel(out, "/world/event")]
    gone = [e for e in events if e.agent == 3 and "gone" in e.text]
    assert len(gone) == 1 and gone[0].tick >= 200 and gone[0].level == 3
    traj = read_trajectory(out, dt=0.01)
    after = traj.positions[gone[0].tick + 1 :, 2]
    assert (after == after[0]).all()  # held still from then on


@pytest.mark.parametrize("hogs", [0, 3], ids=["quiet", "beside-3-cpu-hogs"])
def test_two_runs_on_one_router_stay_isolated(router: str, tmp_path: Path, hogs: int) -> None:
    """Two lockstep runs share a router and stay exact; and with three processes spinning on
    the machine's two cores beside them (under load a run once lost live agents), they
    are slower, never different: every agent stays, every tick equals the reference."""
    scenario = shortened(tmp_path, "sinusoid", duration=4.0)
    outs = [tmp_path / "a.mcap", tmp_path / "b.mcap"]
    with cpu_hogs(hogs, seconds=240.0):
        procs = [shoal_run(scenario, router, o, "--json") for o in outs]
        try:
            results = [p.communicate(timeout=240) for p in procs]
        finally:
            for p in procs:
                stop(p)
    assert [p.returncode for p in procs] == [0, 0], results
    scn = load_scenario(scenario)
    ref = simulate(scn)
    for out in outs:
        assert read_trajectory(out, dt=scn.dt).equals(ref)
        with out.open("rb") as f:
            topics = {c.topic for c in make_reader(f).get_summary().channels.values()}  # type: ignore[union-attr]
        assert len({t.split("/")[1] for t in topics}) == 1  # only its own run's keys


def _listening(tree: dict[int, tuple[str, str]]) -> str | None:
    """The endpoint a router of ``tree`` was started to listen on, from its command line."""
    for pid in tree:
        try:
            args = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"router" in args and b"--listen" in args:
            return args[args.index(b"--listen") + 1].decode()
    return None


def test_sigkill_of_shoal_run_beside_cpu_hogs_takes_its_own_router_too(tmp_path: Path) -> None:
    """A SIGKILLed `shoal run` once left its router running on a loaded machine (> 60 s).
    Its router, like every child, gets SIGTERM when the supervisor dies and ends within its
    grace; here with three processes spinning on two cores from before the kill on."""
    run, tmp = unique("ownrouter"), tmp_path / "tmp"
    tmp.mkdir()
    proc = subprocess.Popen(
        [*PYTHON, "run", "sinusoid", "--run", run, "--out", str(tmp_path / "run.mcap")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "TMPDIR": str(tmp)},
    )
    try:
        deadline = time.monotonic() + 60.0
        while (endpoint := _listening(descendants(proc.pid))) is None:
            assert time.monotonic() < deadline and proc.poll() is None, "no router started"
            select.select([], [], [], 0.05)  # a condition polled with a deadline
        with client(endpoint) as session:
            Watcher(session, run).until_tick(50)  # the run is under way: readiness by its ticks
        tree = descendants(proc.pid)
        with cpu_hogs(3, seconds=60.0):
            proc.kill()
            proc.wait(timeout=10)
            left = still_running_after(tree, EXIT_GRACE_S + REAPER_WAIT_S)
    finally:
        stop(proc)
    assert left == {}
    assert list(tmp.iterdir()) == []


def test_sigterm_to_shoal_run_leaves_a_finished_mcap_and_no_processes(
    router: str, tmp_path: Path
) -> None:
    run, out = unique("termrun"), tmp_path / "run.mcap"
    proc = subprocess.Popen(
        [*PYTHON, "run", "obstacles", "--connect", router, "--run", run, "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        with client(router) as session:
            Watcher(session, run).until_tick(150)
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=30)
    finally:
        stop(proc)
    assert code != 0
    assert processes_mentioning(f"--run {run}") == []
    with out.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()  # only a finished file has a summary section
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count > 0
    assert len(read_trajectory(out, dt=0.01).velocities) >= 150


def test_garbage_on_the_runs_keys_crashes_nothing(router: str, tmp_path: Path) -> None:
    scenario = shortened(tmp_path, "sinusoid", duration=3.0)
    run, out = unique("junk"), tmp_path / "run.mcap"
    proc = shoal_run(scenario, router, out, "--json", run=run)
    garbage = [
        b"\xc1\xff not msgpack",
        msgpack.packb({"v": 1, "k": "state", "id": "two", "tick": None}),
        msgpack.packb({"v": 99, "k": "state"}),
        msgpack.packb({"v": 1, "k": "state", "id": 2, "tick": 5, "pos": [float("nan"), 0.0],
                       "omega": False, "bid": 1.0, "sigma": 1.0, "theta": 0.0}),
        msgpack.packb([1, 2, 3]),
        b"",
        # Well-formed but impossible: 3-D in a 2-D run, ticks far ahead (once crashed agents).
        codec.encode_state(AgentState(2, 250, (1.0, 2.0, 3.0), False, 1.0, 1.0, 0.0)),
        codec.encode_state(AgentState(2, 10**6, (1.0, 2.0), False, 1.0, 1.0, 0.0)),
        codec.encode_sensing(Sensing(10**6, (0.0, 0.0, 0.0), (), (), ())),
    ]  # fmt: skip
    try:
        with client(router) as session:
            watcher = Watcher(session, run)
            watcher.until_tick(20)
            keys = watcher.keys
            targets = [keys.state(2), keys.command(3), keys.sensing(1), keys.tick, keys.event,
                       keys.summary, keys.config(4), keys.scenario]  # fmt: skip
            for key in targets:
                for payload in garbage:
                    session.put(key, payload)
            stdout, stderr = proc.communicate(timeout=240)
    finally:
        stop(proc)
    assert proc.returncode == 0, stderr
    scn = load_scenario(scenario)
    assert read_trajectory(out, dt=scn.dt).equals(simulate(scn))
    assert json_of(subprocess.CompletedProcess([], 0, stdout, stderr))["collisions"] == 0


# sinusoid only: realtime swarms among obstacles keep their guards exactly in
# tests/integration/test_safety_swarm.py (and the 65-s obstacles run here cost CI a minute).
@pytest.mark.parametrize("name", ["sinusoid"])
def test_realtime_run_converges_without_collisions_and_reports_latency(
    name: str, tmp_path: Path
) -> None:
    # Speed 1 (100 ticks/s): at speed 2 eight processes on two loaded cores fell behind often
    # enough that late commands cost clearance (0.02 m once, load average 12). The first 10 s
    # of the route, not its 30: a realtime run takes its simulated time in wall time, and the
    # formation converges in about 1 s (the bound: 31 s), so the run's last 5 s are well after
    # convergence; its final error and its latency are those of a formation in motion either way.
    scenario = shortened(tmp_path, name, duration=10.0)
    proc = run_cli(["run", str(scenario), "--clock", "realtime", "--speed", "1", "--json",
                    "--no-foxglove", "--out", str(tmp_path / "run.mcap")])  # fmt: skip
    assert proc.returncode == 0
    got = json_of(proc)
    assert got["clock"] == "realtime"
    assert got["collisions"] == 0
    assert got["convergence_time"] is not None
    assert got["convergence_time"] <= got["convergence_bound"]
    assert got["final_formation_error"] <= 3 * got["tolerance"]
    assert 0 < got["latency_p50_ms"] <= got["latency_p99_ms"]
    assert isinstance(got["missed_deadlines"], int) and got["missed_deadlines"] >= 0
    # The world kept (roughly) to its wall clock: 1 simulated second per second.
    assert got["ticks_per_s"] > 0.5 / got["dt"]


def test_sigkill_of_shoal_run_leaves_no_orphans(router: str, tmp_path: Path) -> None:
    """Children die with their supervisor (PR_SET_PDEATHSIG), even when it cannot clean up;
    agents forked by the fork server die with it, and it with ``shoal run``; the run's folder
    (children's logs; the keys in secured mode) goes too, removed by the reaper once they are
    gone (tools/procs/reaper.py; it used to be left behind)."""
    run = unique("orphans")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    proc = subprocess.Popen(
        [*PYTHON, "run", "sinusoid", "--connect", router, "--run", run,
         "--out", str(tmp_path / "run.mcap")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "TMPDIR": str(tmp)},
    )  # fmt: skip
    try:
        with client(router) as session:
            Watcher(session, run).until_tick(50)
        # world, logger, the fork server, 5 agents and the folder's reaper
        tree = descendants(proc.pid)
        names = sorted(name for name, _started in tree.values())
        assert [n for n in names if n.startswith("agent ")] == [f"agent {i}" for i in range(1, 6)]
        assert len(tree) == 9, names
        assert [p.name[:10] for p in tmp.iterdir()] == ["shoal-run-"]
        proc.kill()
        proc.wait(timeout=10)
        left = still_running_after(tree, 15.0 + REAPER_WAIT_S)
    finally:
        stop(proc)
    assert left == {}
    assert list(tmp.iterdir()) == []  # the reaper is gone, and it took the folder with it
