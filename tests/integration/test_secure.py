"""The secured mode's three refusals, with real processes and a real router (docs/security.md):

(a) an outsider without valid credentials cannot open a session with the router;
(b) a process with a valid certificate and password that is not part of the run cannot get a
    message to the run's processes;
(c) an agent cannot publish under another agent's keys (or the world's);

and a secured lockstep run that still equals the reference simulator bit for bit.

How "never arrives" is shown without sleeping: every forged message is followed by a *sentinel*
that takes an allowed path, and the forged ones are checked absent once the sentinel is in. Why
that is enough is argued in each test's docstring; it rests on three facts: Zenoh delivers the
messages of one session over its one link reliably and in order within a priority (every put
here uses the same priority, DATA, and BLOCK so that none is dropped under congestion); the
router's reader handles one link's messages in order and routes each (hands it to the outgoing
links, or drops it) before the next; and a query the router refuses is still answered by the
router itself (checked by hand: with the router stopped by SIGSTOP, such a get waits out its
whole timeout, so the answer is not the client's own), so a get's end is a round trip through
the router. Also checked by hand, with the router's trace log
(RUST_LOG=zenoh::net::routing::interceptor=trace): the forged puts do leave the client and are
refused at the router ("is unauthorized to Put (ingress)"); no client-side filter is involved.
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
from typing import Any

import pytest
import zenoh
from conftest import PYTHON, Watcher, json_of, unique

from shoal.bus import codec
from shoal.bus.acl import LOGGER, MONITOR, WORLD, agent_name
from shoal.bus.keys import Keys
from shoal.bus.messages import AgentState, Command, Event, Sensing
from shoal.bus.report import reports_in
from shoal.bus.secure import Identity, Material
from shoal.bus.zconfig import zenoh_config
from shoal.tools.certs import issue, make_material
from shoal.tools.log.reader import iter_channel, read_documents, read_trajectory
from shoal.tools.procs.launch import free_port
from shoal.tools.procs.swarm import Child, Swarm
from shoal.tools.simulator import simulate
from shoal.tools.verify import verify
from shoal.world.loader import load_scenario

pytestmark = pytest.mark.integration

AGENTS = 5  # sinusoid
BLOCK, DATA = zenoh.CongestionControl.BLOCK, zenoh.Priority.DATA
BARRIER_TIMEOUT = 60.0


@dataclass
class Pki:
    m: Material
    run: str
    foreign: Material  # a complete set from another CA: right names, wrong signer


@dataclass
class SecuredRouter:
    endpoint: str
    pki: Pki


@pytest.fixture
def pki(tmp_path: Path) -> Pki:
    run = unique("secure")
    m = make_material(tmp_path / "pki", run=run, agents=AGENTS)
    issue(m, "intruder")  # CA-signed, with a password, in no rule
    m = make_material(m.root, run=run, agents=AGENTS)  # adds it to the users' dictionary
    foreign = make_material(tmp_path / "foreign", run=run, agents=1)
    return Pki(m, run, foreign)


@pytest.fixture
def router(pki: Pki) -> Iterator[SecuredRouter]:
    endpoint = f"tls/127.0.0.1:{free_port()}"
    with Swarm() as swarm:
        args = ["router", "--listen", endpoint, "--secure", str(pki.m.root)]
        swarm.wait_ready(swarm.spawn("router", "router", args, ready_pipe=True), 30.0)
        yield SecuredRouter(endpoint, pki)


def open_as(r: SecuredRouter, name: str, **overrides: Any) -> zenoh.Session:
    """A client session as identity ``name`` of the run, with config entries overridden
    (a key is written with dots for slashes, as keyword arguments cannot hold a slash)."""
    conf = zenoh_config(mode="client", connect=[r.endpoint], secure=Identity(r.pki.m, name))
    for key, value in overrides.items():
        conf.insert_json5(key.replace(".", "/"), json.dumps(value))
    return zenoh.open(conf)


def barrier(session: zenoh.Session, keys: Keys) -> None:
    """Return once the router has handled everything ``session`` sent before: a get (which
    the router answers even when it refuses it) behind them on the same link and priority."""
    began = time.monotonic()
    list(session.get(keys.config(1), timeout=BARRIER_TIMEOUT, priority=DATA))
    assert time.monotonic() - began < BARRIER_TIMEOUT / 2, "the get was not answered"


# -- (a) ----------------------------------------------------------------------------------------


def outsider(
    r: SecuredRouter, endpoint: str, retry_ms: int = 2000, **settings: Any
) -> zenoh.Config:
    """A client configuration made by hand, with only ``settings`` for credentials. It keeps
    retrying for ``retry_ms``, so a refusal is a refusal and not one missed attempt."""
    conf = zenoh.Config()
    for key, value in {
        "mode": "client",
        "connect/endpoints": [endpoint],
        "connect/timeout_ms": retry_ms,
        "scouting/multicast/enabled": False,
        "transport/link/tls/root_ca_certificate": str(r.pki.m.ca),
        **settings,
    }.items():
        conf.insert_json5(key, json.dumps(value))
    return conf


def test_outsiders_without_valid_credentials_cannot_connect(router: SecuredRouter) -> None:
    """Each outsider lacks one thing; the router refuses the session (it never opens, so it
    can neither publish nor receive). The control, with everything right, opens."""
    m, foreign, tls = router.pki.m, router.pki.foreign, "transport/link/tls"
    password = m.password(WORLD).read_text().strip()
    login = {"transport/auth/usrpwd/user": WORLD, "transport/auth/usrpwd/password": password}
    cert = {
        f"{tls}/enable_mtls": True,
        f"{tls}/connect_certificate": str(m.cert(WORLD)),
        f"{tls}/connect_private_key": str(m.key(WORLD)),
    }
    foreign_cert = {
        **cert,
        f"{tls}/connect_certificate": str(foreign.cert(WORLD)),
        f"{tls}/connect_private_key": str(foreign.key(WORLD)),
    }
    wrong = {**login, "transport/auth/usrpwd/password": "guess"}
    tcp = router.endpoint.replace("tls/", "tcp/")
    cases = {
        "no client certificate": outsider(router, router.endpoint, **login),
        "certificate from another CA": outsider(router, router.endpoint, **foreign_cert, **login),
        "wrong password": outsider(router, router.endpoint, **cert, **wrong),
        "no password": outsider(router, router.endpoint, **cert),
        "plain tcp": outsider(router, tcp, **login),
    }
    for what, conf in cases.items():
        with pytest.raises(zenoh.ZError), zenoh.open(conf):
            pytest.fail(f"{what}: the session opened")
    with zenoh.open(outsider(router, router.endpoint, 30_000, **cert, **login)) as session:
        assert session.info.routers_zid(), "the control did not reach the router"


# -- a live secured run -------------------------------------------------------------------------


@dataclass
class LiveRun:
    keys: Keys
    watcher: Watcher
    out: Path
    children: list[Child]
    token: Any  # the monitor's liveliness token, kept alive for the run


def start_secured_run(
    swarm: Swarm, monitor: zenoh.Session, r: SecuredRouter, scenario: Path, out: Path
) -> LiveRun:
    """Logger, world and every agent as processes with their own identities; the test's own
    session is the monitor (it holds the "monitor" token the world waits for)."""
    common = ["--run", r.pki.run, "--connect", r.endpoint, "--secure", str(r.pki.m.root)]
    watcher = Watcher(monitor, r.pki.run)
    token = monitor.liveliness().declare_token(watcher.keys.alive_process(MONITOR))
    logger = swarm.spawn(LOGGER, "logger", ["logger", "--out", str(out), *common], ready_pipe=True)
    expect = ["--expect", "logger", "--expect", "monitor"]
    children = [logger, swarm.spawn(WORLD, "world", ["world", str(scenario), *common, *expect])]
    children += [
        swarm.spawn(agent_name(i), "agent", ["agent", "--id", str(i), *common])
        for i in range(1, AGENTS + 1)
    ]
    swarm.wait_ready(logger, 60)
    return LiveRun(watcher.keys, watcher, out, children, token)


def finish(run: LiveRun) -> dict[str, Any]:
    summary = run.watcher.until_summary(timeout=240)
    for child in run.children:
        child.done = True
        assert child.popen.wait(timeout=60) == 0, child.tail()
    return summary


def short(tmp_path: Path, seconds: float = 4.0) -> Path:
    text = load_scenario("sinusoid").source
    lines = [f"duration: {seconds}" if s.startswith("duration:") else s for s in text.splitlines()]
    path = tmp_path / "sinusoid-short.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def forgeries(keys: Keys, tick: int) -> list[tuple[str, bytes]]:
    """Messages that would each do harm if accepted, all distinct bytes: commands and states
    for agent 2 a few ticks ahead (the first valid command for a tick wins, and a state for the
    awaited tick is used), a sensing that teleports agent 3, a summary that would end the
    logger and the monitor, and garbage on a command key (the world would count it)."""
    far = (1e3, -1e3)
    out = [
        (keys.command(2), codec.encode_report(
            AgentState(2, t, far, False, 1.0, 1.0, 0.0), Command(2, t, (50.0, 50.0))))
        for t in range(tick + 3, tick + 13)
    ]  # fmt: skip
    out += [
        (keys.state(2), codec.encode_state(AgentState(2, t, far, True, 9.0, 1.0, 0.0)))
        for t in range(tick + 1, tick + 6)
    ]
    out += [
        (keys.sensing(3), codec.encode_sensing(Sensing(tick + 2, far, (), (), ()))),
        (keys.summary, codec.encode_document("summary", {"scenario": "forged", "steps": 1})),
        (keys.event, codec.encode_event(Event(tick, 4, 2, "forged: agent 2 lost"))),
        (keys.command(2), f"garbage {uuid.uuid4()}".encode()),
    ]
    return out


def assert_log_has_sentinels_and_no_forgery(
    out: Path, forged: list[tuple[str, bytes]], sentinels: list[bytes]
) -> None:
    seen = [data for _topic, data, _ns in iter_channel(out, "")]
    leaked = [key for key, data in forged if data in seen]
    assert leaked == [], f"forged messages reached the logger on {leaked}"
    assert all(s in seen for s in sentinels), "a sentinel is missing from the log"


def assert_untouched(out: Path, summary: dict[str, Any], sentinels: int, steps: int) -> None:
    """The world counted exactly the sentinels as bad commands (each forged command would have
    counted too, or changed the trajectory), and the run equals the reference bit for bit."""
    assert summary["dropped_messages"] == sentinels
    assert read_documents(out)["summary"]["scenario"] == "sinusoid"
    scn = load_scenario("sinusoid")
    traj = read_trajectory(out, dt=scn.dt)
    assert len(traj.velocities) == steps
    verdict = verify(out)
    assert verdict.ok and verdict.recorded == steps, verdict


# -- (b) ----------------------------------------------------------------------------------------


def test_an_authenticated_stranger_cannot_publish_into_the_run(
    router: SecuredRouter, tmp_path: Path
) -> None:
    """Two strangers with sessions the router accepts: "intruder" (a CA-signed certificate and a
    valid password, for a name in no rule) and a mix (agent 2's certificate with agent 1's
    username and password, which matches no subject: a subject needs both). Each sends every
    forgery, then a get as a barrier. Only then does agent 1's identity send a sentinel, a
    garbage command on agent 1's own key, which the logger records and the world counts.

    Ordering: each stranger's forgeries precede its get on its link, at the same priority, so
    the router had routed or dropped them all before it answered the get; anything it routed
    was queued then on the outgoing links to the world, the agents and the logger. The sentinel
    left after the answer, so the router routed it later, and on each outgoing link (same
    priority) it queues behind anything forged. Hence: the sentinel in the log and in the
    world's count, and no forgery in either, means no forgery was ever delivered.
    """
    scenario, out = short(tmp_path), tmp_path / "run.mcap"
    steps = load_scenario(scenario).steps
    m = router.pki.m
    with Swarm() as swarm, open_as(router, MONITOR) as monitor:
        run = start_secured_run(swarm, monitor, router, scenario, out)
        run.watcher.until_tick(20)
        forged = forgeries(run.keys, run.watcher.last_tick)
        mixed = {
            "transport.link.tls.connect_certificate": str(m.cert(agent_name(2)).resolve()),
            "transport.link.tls.connect_private_key": str(m.key(agent_name(2)).resolve()),
        }
        sentinel = f"sentinel {uuid.uuid4()}".encode()
        with (
            open_as(router, "intruder") as intruder,
            open_as(router, agent_name(1), **mixed) as mix,
            open_as(router, agent_name(1)) as sender,
        ):
            for stranger in (intruder, mix):
                for key, payload in forged:
                    stranger.put(key, payload, congestion_control=BLOCK, priority=DATA)
                barrier(stranger, run.keys)
            sender.put(run.keys.command(1), sentinel, congestion_control=BLOCK, priority=DATA)
            summary = finish(run)
    assert_log_has_sentinels_and_no_forgery(out, forged, [sentinel])
    assert_untouched(out, summary, sentinels=1, steps=steps)


# -- (c) ----------------------------------------------------------------------------------------


def test_an_agent_cannot_publish_under_another_agents_keys(
    router: SecuredRouter, tmp_path: Path
) -> None:
    """A second session with agent 1's identity (a compromised agent 1) sends every forgery
    (agent 2's command and state, agent 3's sensing, the world's summary and event), then, on
    the same session, a sentinel on its own command key, which is allowed: the logger records
    it and the world counts it as a bad command.

    Ordering: one session, one link, one priority: the router reads the forgeries before the
    sentinel and routes (or drops) each before reading the next, so on every outgoing link
    anything forged would be queued ahead of the sentinel. The sentinel arrived and none of
    the forgeries did.
    """
    scenario, out = short(tmp_path), tmp_path / "run.mcap"
    steps = load_scenario(scenario).steps
    with Swarm() as swarm, open_as(router, MONITOR) as monitor:
        run = start_secured_run(swarm, monitor, router, scenario, out)
        run.watcher.until_tick(20)
        forged = forgeries(run.keys, run.watcher.last_tick)
        sentinel = f"sentinel {uuid.uuid4()}".encode()
        with open_as(router, agent_name(1)) as rogue:
            for key, payload in forged:
                rogue.put(key, payload, congestion_control=BLOCK, priority=DATA)
            rogue.put(run.keys.command(1), sentinel, congestion_control=BLOCK, priority=DATA)
            summary = finish(run)
    assert_log_has_sentinels_and_no_forgery(out, forged, [sentinel])
    assert_untouched(out, summary, sentinels=1, steps=steps)


# -- the run still works ------------------------------------------------------------------------


def test_shoal_run_secure_is_exact_and_leaves_no_material(tmp_path: Path) -> None:
    """``shoal run --secure`` out of the box: fresh certificates, a TLS router with the run's
    rules, every process as its own identity; the log verifies bit for bit, and the private
    keys went with the run's temporary folder."""
    scenario, out, tmp = short(tmp_path, 3.0), tmp_path / "run.mcap", tmp_path / "tmp"
    tmp.mkdir()
    proc = subprocess.run(
        [*PYTHON, "run", str(scenario), "--secure", "--json", "--no-foxglove", "--out", str(out)],
        capture_output=True, text=True, timeout=300, env={**os.environ, "TMPDIR": str(tmp)},
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    got = json_of(proc)
    assert got["secure"] is True and got["collisions"] == 0
    scn = load_scenario(scenario)
    # Every agent answered the world's report query through the run's ACL (bus/report.py).
    reports = reports_in(got)
    assert sorted(reports) == list(range(1, scn.n + 1))
    assert all(r["last_tick"] == scn.steps - 1 and r["peak_rss_kb"] > 0 for r in reports.values())
    assert read_trajectory(out, dt=scn.dt).equals(simulate(scn))
    verdict = verify(out)
    assert verdict.ok and verdict.recorded == scn.steps
    assert list(tmp.iterdir()) == [], "the run folder with the keys was left behind"
