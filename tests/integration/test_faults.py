"""Faults survived (processes killed, messages lost), with real processes over a real Zenoh router.

A follower SIGKILLed in realtime (lockstep: tests/integration/test_run_swarm.py), a follower
restarted after it died (taken back in realtime, refused in lockstep), the leader killed (every
agent held still, the run ends with an error naming it), the world killed (agents stop and exit
0), and neighbour messages dropped at 0, 5 and 20 % (the formation still converges). The logger
killed is tests/integration/test_salvage.py; a network partition is tests/integration/test_netns.py.

Readiness and progress come from the run's own events, tick records and liveliness tokens;
nothing sleeps. Realtime runs share a 2-core machine with other work, so every bound on a
realtime figure is a multiple of what an unloaded run gives, with the margin said where it is
asserted; figures are printed (``pytest -s``) for docs/wire.md.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import (
    Watcher,
    client,
    descendants,
    json_of,
    processes_mentioning,
    shoal_run,
    shortened,
    start_run,
    stop,
    unique,
)

from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.links import subscribe, watch_presence
from shoal.bus.messages import Event
from shoal.bus.runtime import Inbox
from shoal.geometry.path import peak_speed
from shoal.tools.bench.drops import measure
from shoal.tools.log.reader import iter_channel, read_ticks, read_trajectory
from shoal.tools.procs.swarm import Swarm
from shoal.world.loader import load_scenario
from shoal.world.metrics import formation_errors
from shoal.world.theory import convergence_bound, formation_error

pytestmark = pytest.mark.integration

DT = 0.01  # s, every built-in's step


def logged_events(out: Path) -> list[Event]:
    return [codec.decode_event(d) for _t, d, _ns in iter_channel(out, "/world/event")]


def follower_errors(scenario: Path, out: Path) -> Any:
    """(T, n-1) formation error of every follower at every tick, from the log."""
    scn = load_scenario(scenario)
    return formation_errors(scn, read_trajectory(out, dt=scn.dt))


# -- a follower killed (realtime; the lockstep case is tests/integration/test_run_swarm.py) ------


def test_realtime_sigkill_of_a_follower_is_survived_and_logged(router: str, tmp_path: Path) -> None:
    scenario, out = shortened(tmp_path, "sinusoid", 6.0), tmp_path / "run.mcap"
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), unique("rtkill"), out,
                      clock="realtime")  # fmt: skip
        bus = Watcher(session, r.watcher.keys.run, events=True)
        bus.until_tick(200)
        os.kill(r.agents[2].popen.pid, signal.SIGKILL)  # follower 3
        r.agents[2].done = True
        killed_after = bus.last_tick
        summary = bus.until_summary()
        assert r.world.popen.wait(timeout=30) == 0
        assert r.logger.popen.wait(timeout=30) == 0
        others = [a for a in r.agents if a is not r.agents[2]]
        codes = [a.popen.wait(timeout=30) for a in others]
        for a in r.agents:
            a.done = True
    assert codes == [0, 0, 0, 0]
    assert summary["steps"] == 600 and summary["aborted"] is None
    gone = [e for e in logged_events(out) if e.agent == 3 and "gone" in e.text]
    assert len(gone) == 1 and gone[0].level == 3 and gone[0].tick >= killed_after
    positions = read_trajectory(out, dt=DT).positions[gone[0].tick + 1 :, 2]
    assert (positions == positions[0]).all()  # held still from the tick it was noticed
    # The rest go on: followers 2, 4 and 5 (5 now follows 4 alone) keep their slots. Over the
    # last 2 s their median error is ≤ 3 × tolerance (unloaded realtime runs give ≈ 1 ×).
    errors = follower_errors(scenario, out)[-200:][:, [0, 2, 3]].max(axis=1)
    assert float(np.median(errors)) <= 3 * summary["tolerance"]
    print(f"\nrealtime kill of agent 3 after tick {killed_after}: gone at tick {gone[0].tick}")


# -- a follower restarted ----------------------------------------------------------------------


def test_restarted_follower_is_taken_back_and_returns_to_its_slot_in_realtime(
    router: str, tmp_path: Path
) -> None:
    """Agent 4 is killed at tick 300 of a 20 s realtime run and started again as soon as the
    world has logged it gone. The new process fetches its configuration, the world takes it
    back when its token appears, and it returns to its slot within the Theorem-1 bound computed
    from the formation error at the tick its first command is applied."""
    scenario, out = shortened(tmp_path, "sinusoid", 20.0), tmp_path / "run.mcap"
    run = unique("rejoin")
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), run, out, clock="realtime")
        bus = Watcher(session, run, events=True)
        bus.until_tick(300)
        os.kill(r.agents[3].popen.pid, signal.SIGKILL)
        r.agents[3].done = True
        bus.until_event(4, "gone")
        restarted = time.monotonic()
        again = swarm.spawn("agent 4 again", "agent",
                            ["agent", "--id", "4", "--run", run, "--connect", router])  # fmt: skip
        bus.until_event(4, "back at tick", timeout=60)
        back_wall = time.monotonic() - restarted
        summary = bus.until_summary()
        assert r.world.popen.wait(timeout=30) == 0
        assert r.logger.popen.wait(timeout=30) == 0
        codes = [a.popen.wait(timeout=30) for a in [*r.agents[:3], r.agents[4], again]]
        for c in swarm.children:
            c.done = True
    assert codes == [0, 0, 0, 0, 0]
    assert summary["steps"] == 2000 and summary["collisions"] == 0

    events = logged_events(out)
    gone = next(e for e in events if e.agent == 4 and "gone" in e.text)
    back = next(e for e in events if e.agent == 4 and "back at tick" in e.text)
    assert gone.level == 3 and back.level == 2 and gone.tick < back.tick
    scn = load_scenario(scenario)
    traj = read_trajectory(out, dt=scn.dt)
    held = traj.positions[gone.tick + 1 : back.tick + 1, 3]
    assert (held == held[0]).all()  # held still while it was away
    moving = np.flatnonzero(np.any(traj.velocities[back.tick :, 3] != 0.0, axis=1))
    assert moving.size > 0, "the world never applied a command of the restarted agent"
    first = back.tick + int(moving[0])  # the tick its first command was applied
    mine = formation_errors(scn, traj)[:, 2]  # agent 4 is the third follower
    below = np.flatnonzero(mine[first:] <= scn.tolerance)
    assert below.size > 0, "agent 4 never got back within tolerance of its slot"
    # Theorem 1 holds for the law running, not for agents the world holds still: on a loaded
    # machine a late command is stale and the world stops that follower (in CI once, 2.91 s
    # against a 1.95 s bound). So the bound runs from the last tick a follower was held (an
    # exactly zero velocity) before agent 4 got back. The leader may stop at its path's end.
    reached = first + int(below[0])
    followers = [i - 1 for i in range(1, scn.n + 1) if not scn.agent_config(i).is_leader]
    stopped = traj.velocities[first:reached][:, followers] == 0.0
    held = np.flatnonzero(np.all(stopped, axis=2).any(axis=1))
    start = first if held.size == 0 else first + int(held[-1]) + 1
    z = formation_error(traj.positions[start], scn.offsets)
    bound = convergence_bound(scn.adjacency, z, directed=scn.directed, beta=scn.control.beta,
                              f_max=peak_speed(scn.path))  # fmt: skip
    took = (reached - start) * scn.dt
    load = {k: summary[k] for k in ("missed_deadlines", "stale_holds", "latency_p99_ms")}
    assert took <= bound, f"from tick {start} (error {mine[start]:.2f} m); {load}"
    # And it stays there: median error over the last 2 s ≤ 3 × tolerance (≈ 1 × unloaded).
    assert float(np.median(mine[-200:])) <= 3 * scn.tolerance
    print(
        f"\nrejoin: gone at tick {gone.tick}, back at tick {back.tick} ({back_wall:.2f} s after "
        f"the restart), first command applied at tick {first}, followers held at {held.size} "
        "ticks after it, "
        f"error {mine[start]:.2f} m at tick {start} → ≤ {scn.tolerance} m in {took:.2f} s "
        f"(Theorem-1 bound from there {bound:.2f} s)"
    )


def test_restarted_follower_is_refused_in_lockstep(router: str, tmp_path: Path) -> None:
    """Lockstep cannot take an agent back (its neighbours stopped waiting for it): the world
    answers the configuration query with an error and logs the refusal; the restarted process
    exits 1 with the reason; the run goes on without it."""
    scenario, out = shortened(tmp_path, "sinusoid", 20.0), tmp_path / "run.mcap"
    run = unique("refuse")
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), run, out)
        bus = Watcher(session, run, events=True)
        bus.until_tick(50)
        os.kill(r.agents[3].popen.pid, signal.SIGKILL)
        r.agents[3].done = True
        bus.until_event(4, "gone")
        replies = list(session.get(bus.keys.config(4), timeout=10.0))
        assert len(replies) == 1 and replies[0].err is not None
        assert "lockstep" in replies[0].err.payload.to_bytes().decode()
        again = swarm.spawn("agent 4 again", "agent",
                            ["agent", "--id", "4", "--run", run, "--connect", router])  # fmt: skip
        again.done = True
        code = again.popen.wait(timeout=60)
        told = again.tail()
        bus.until_summary()
        assert r.world.popen.wait(timeout=30) == 0
        assert [a.popen.wait(timeout=30) for a in r.agents if a is not r.agents[3]] == [0] * 4
        for c in swarm.children:
            c.done = True
    assert code == 1 and "refuses it" in told and "lockstep" in told
    events = logged_events(out)
    gone = next(e for e in events if e.agent == 4 and "gone" in e.text)
    refused = [e for e in events if e.agent == 4 and "refused" in e.text]
    assert len(refused) >= 2  # the test's own query and the restarted process's
    held = read_trajectory(out, dt=DT).positions[gone.tick + 1 :, 3]
    assert (held == held[0]).all()


# -- the leader killed -------------------------------------------------------------------------


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_leader_killed_stops_everyone_and_ends_the_run(
    clock: str, router: str, tmp_path: Path
) -> None:
    scenario, out = shortened(tmp_path, "sinusoid", 10.0), tmp_path / "run.mcap"
    run = unique("leader")
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), run, out, clock=clock)
        bus = Watcher(session, run, events=True)
        bus.until_tick(150)
        os.kill(r.agents[0].popen.pid, signal.SIGKILL)
        r.agents[0].done = True
        killed_after = bus.last_tick
        summary = bus.until_summary()
        world_code = r.world.popen.wait(timeout=30)
        logger_code = r.logger.popen.wait(timeout=30)
        codes = [a.popen.wait(timeout=30) for a in r.agents[1:]]
        told = r.world.tail()
        for c in swarm.children:
            c.done = True
    assert world_code == 1 and "the leader (agent 1) is gone" in told
    assert logger_code == 0 and codes == [0, 0, 0, 0]
    assert "leader (agent 1)" in summary["aborted"]
    errors = [e for e in logged_events(out) if e.level == 4]
    assert errors[0].agent == 1 and errors[0].tick >= killed_after
    ticks = read_ticks(out)
    assert ticks[-1].tick == errors[0].tick == summary["steps"] - 1  # the run ends right there
    assert all(v == 0.0 for vel in ticks[-1].velocities for v in vel)  # everyone held still
    if clock == "realtime":  # ticks/s counts the ticks run, which cannot outpace the clock
        assert 0 < summary["ticks_per_s"] <= 1.01 / load_scenario("sinusoid").dt
    print(f"\n{clock}: leader killed after tick {killed_after}, run ended at tick {ticks[-1].tick}")


def test_shoal_run_exits_1_naming_the_leader_when_it_dies(router: str, tmp_path: Path) -> None:
    run, out = unique("leaderrun"), tmp_path / "run.mcap"
    scenario = shortened(tmp_path, "sinusoid", 20.0)
    proc = shoal_run(scenario, router, out, "--json", "--no-foxglove", run=run)
    try:
        with client(router) as session:
            Watcher(session, run).until_tick(100)
        (leader,) = [p for p, (name, _) in descendants(proc.pid).items() if name == "agent 1"]
        os.kill(leader, signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        stop(proc)
    assert proc.returncode == 1
    assert "the run ended early: the leader (agent 1) is gone at tick" in stderr
    got = json_of(subprocess.CompletedProcess([], 1, stdout, stderr))
    assert got["steps"] < 2000 and "leader" in got["aborted"]
    deadline = time.monotonic() + 15
    while processes_mentioning(f"--run {run}") and time.monotonic() < deadline:
        os.sched_yield()  # waiting on a condition with a deadline, not on the clock
    assert processes_mentioning(f"--run {run}") == []


@pytest.mark.parametrize("how", ["logger killed", "ctrl-c"])
def test_a_run_that_does_not_finish_says_where_its_log_is(
    how: str, router: str, tmp_path: Path
) -> None:
    """A killed logger or a Ctrl-C: shoal run names the log, and for an unfinished one says
    how to recover it; no dangling "code -9:" with nothing after it."""
    run, out = unique("where"), tmp_path / "run.mcap"
    scenario = shortened(tmp_path, "sinusoid", 20.0)
    proc = shoal_run(scenario, router, out, "--no-foxglove", run=run)
    try:
        with client(router) as session:
            Watcher(session, run).until_tick(100)
        if how == "ctrl-c":
            proc.send_signal(signal.SIGINT)
        else:
            (logger,) = [
                p
                for p in descendants(proc.pid)
                if b"\0shoal.tools\0logger\0" in Path(f"/proc/{p}/cmdline").read_bytes()
            ]
            os.kill(logger, signal.SIGKILL)
        _, stderr = proc.communicate(timeout=60)
    finally:
        stop(proc)
    assert proc.returncode != 0
    assert f"the log of the run so far: {out}" in stderr, stderr
    if how == "logger killed":
        assert f"shoal recover {out} -o FIXED.mcap" in stderr and "-9:" not in stderr, stderr
    else:
        assert "shoal run: interrupted" in stderr, stderr


# -- the world killed --------------------------------------------------------------------------


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_world_killed_agents_stop_commanding_and_exit_0(
    clock: str, router: str, tmp_path: Path
) -> None:
    """After a SIGKILL of the world every agent exits 0 within 10 s (measured: well under 1 s
    unloaded; the kernel closes the world's socket, so no lease is involved), and no agent
    commands a tick the world never sensed: it only ever answers sensings."""
    scenario, out = shortened(tmp_path, "sinusoid", 20.0), tmp_path / "run.mcap"
    run = unique("worldkill")
    keys = Keys(run)
    inbox = Inbox()
    with Swarm() as swarm, client(router) as session:
        held = [
            subscribe(session, f"{keys.root}/agent/*/cmd", inbox),
            subscribe(session, f"{keys.root}/agent/*/sensing", inbox),
            watch_presence(session, keys.alive_world, inbox),
        ]
        r = start_run(swarm, session, router, str(scenario), run, out, clock=clock)
        bus = Watcher(session, run, events=True)
        bus.until_tick(150)
        os.kill(r.world.popen.pid, signal.SIGKILL)
        killed = time.monotonic()
        r.world.done = True
        waited = []
        for a in r.agents:
            a.done = True
            code = a.popen.wait(timeout=30)
            waited.append((code, time.monotonic() - killed))
        r.logger.done = True
        logger_code = r.logger.popen.wait(timeout=30)
        sensed, commanded = -1, -1
        while (arrival := inbox.get(timeout=1.0)) is not None:  # until the bus is quiet
            if arrival.key.endswith("/sensing"):
                sensed = max(sensed, codec.decode_sensing(arrival.payload).tick)
            elif arrival.key.endswith("/cmd"):
                commanded = max(commanded, codec.decode_report(arrival.payload)[1].tick)
        del held
    assert [code for code, _ in waited] == [0] * 5
    assert max(s for _, s in waited) <= 10.0
    assert logger_code == 0 and len(read_ticks(out)) >= 150
    assert 150 <= commanded <= sensed
    slowest = max(s for _, s in waited)
    print(f"\n{clock}: agents exited 0 within {slowest:.2f} s of the world's SIGKILL; "
          f"last tick sensed {sensed}, commanded {commanded}")  # fmt: skip


# -- lost messages -----------------------------------------------------------------------------


@pytest.mark.parametrize("rate", [0.0, 0.05, 0.2])
def test_formation_converges_with_lost_neighbour_messages(rate: float, tmp_path: Path) -> None:
    """Realtime sinusoid (10 s, speed 1) with a fraction of every agent's incoming neighbour
    states thrown away. Bound: the median steady-state error (t ≥ 5 s) ≤ 3 × tolerance = 0.6 m;
    measured 0.18–0.20 m at every rate on this machine under load (a formation that had not
    converged would be metres off: the followers start up to 2 m from their slots and the
    leader moves at up to 1.3 m/s)."""
    scenario = shortened(tmp_path, "sinusoid", 10.0)
    row = measure(str(scenario), rate, speed=1.0, settle=5.0, seed=0, workdir=tmp_path)
    tolerance = load_scenario(scenario).tolerance
    print(f"\ndrop rate {rate}: {row.as_dict()}")
    assert row.collisions == 0
    assert row.median <= 3 * tolerance
    expected = 12 * 1000  # 6 undirected edges, a state each way per tick, 1000 ticks
    assert row.offered >= 0.9 * expected
    sd = (rate * (1 - rate) / row.offered) ** 0.5
    assert abs(row.injected / row.offered - rate) <= 5 * sd  # seeded, counted, at the rate asked
    assert row.age_max is not None
