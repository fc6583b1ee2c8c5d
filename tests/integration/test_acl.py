"""The secured mode without a network: the router's rules for a run (bus/acl.py), the Zenoh
settings each process gets (bus/secure.py, bus/zconfig.py), and the material on disk
(tools/certs.py). The same refusals with real processes are in
tests/integration/test_secure.py."""

from __future__ import annotations

import json
import shutil
import stat
from pathlib import Path
from typing import Any

import pytest
import zenoh
from click.testing import CliRunner

from shoal.bus.acl import LOGGER, MONITOR, ROUTER, WORLD, access_control, agent_name
from shoal.bus.errors import WireError
from shoal.bus.keys import Keys
from shoal.bus.secure import Identity, Material
from shoal.bus.zconfig import zenoh_config
from shoal.tools.certs import issue, make_material
from shoal.tools.cli import main

RUN, AGENTS = "r-1", 4
ACL = access_control(RUN, AGENTS)
NAMES = [WORLD, LOGGER, MONITOR, *(agent_name(i) for i in range(1, AGENTS + 1))]


def may(acl: dict[str, Any], name: str, message: str, flow: str, key: str) -> bool:
    """Zenoh's verdict for identity ``name`` (certificate and username alike), as the router
    computes it for these rules: default deny, and an allow rule applies when one of its key
    expressions includes ``key``."""
    subjects = {
        s["id"]
        for s in acl["subjects"]
        if name in s["cert_common_names"] and name in s["usernames"]
    }
    rule_ids = {r for p in acl["policies"] if set(p["subjects"]) & subjects for r in p["rules"]}
    return any(
        rule["permission"] == "allow"
        and message in rule["messages"]
        and flow in rule["flows"]
        and any(zenoh.KeyExpr(k).includes(key) for k in rule["key_exprs"])
        for rule in acl["rules"]
        if rule["id"] in rule_ids
    )


def run_keys(run: str) -> list[str]:
    k = Keys(run)
    per_agent = [f(i) for i in range(1, AGENTS + 2) for f in (k.state, k.command, k.sensing)]
    world = [k.tick, k.event, k.summary, k.scenario, k.config(1)]
    return [*per_agent, *world, f"{k.root}/agent/1/other", f"{k.root}/anything"]


def test_default_deny_and_one_subject_per_identity_needing_certificate_and_username() -> None:
    assert ACL["enabled"] is True and ACL["default_permission"] == "deny"
    assert sorted(s["id"] for s in ACL["subjects"]) == sorted(NAMES)
    for s in ACL["subjects"]:  # both lists in one subject: Zenoh requires both to match
        assert s["cert_common_names"] == [s["id"]] and s["usernames"] == [s["id"]]
        assert "interfaces" not in s
    ids = [r["id"] for r in ACL["rules"]]
    assert len(ids) == len(set(ids))
    assert {r for p in ACL["policies"] for r in p["rules"]} == set(ids)
    assert all(r["permission"] == "allow" for r in ACL["rules"])


@pytest.mark.parametrize("key", run_keys(RUN))
def test_who_may_publish_each_key(key: str) -> None:
    k = Keys(RUN)
    world_keys = {k.tick, k.event, k.summary, k.scenario, *(k.sensing(i) for i in range(1, 6))}
    for name in NAMES:
        if name == WORLD:
            expected = key in world_keys
        elif name.startswith("agent-"):
            i = int(name.removeprefix("agent-"))
            expected = key in (k.state(i), k.command(i))
        else:
            expected = False  # the logger and the monitor only listen
        assert may(ACL, name, "put", "ingress", key) is expected, (name, key)


def test_nobody_outside_the_run_gets_anything() -> None:
    for name in ["intruder", ROUTER, "agent-0", agent_name(AGENTS + 1), "agent-1 ", "World"]:
        for key in [*run_keys(RUN), Keys(RUN).alive_world, Keys(RUN).alive_agent(1)]:
            for message in ["put", "declare_subscriber", "query", "liveliness_token"]:
                for flow in ["ingress", "egress"]:
                    assert not may(ACL, name, message, flow, key), (name, message, flow, key)


def test_nothing_is_allowed_on_another_runs_keys() -> None:
    other = Keys("r-2")
    for name in NAMES:
        for key in [*run_keys("r-2"), other.alive_world, other.alive_agent(1), other.everything]:
            for message in ["put", "declare_subscriber", "liveliness_token", "query"]:
                assert not may(ACL, name, message, "ingress", key), (name, key)


def test_each_identity_declares_only_its_own_token() -> None:
    k = Keys(RUN)
    tokens = {WORLD: k.alive_world, LOGGER: k.alive_logger, MONITOR: k.alive_process(MONITOR)}
    tokens |= {agent_name(i): k.alive_agent(i) for i in range(1, AGENTS + 1)}
    for name in NAMES:
        for owner, token in tokens.items():
            assert may(ACL, name, "liveliness_token", "ingress", token) is (owner == name)


def test_what_each_process_needs_to_run_is_allowed() -> None:
    """The traffic of a lockstep run (docs/wire.md §1), seen from the router: without any of
    these the run would stall, so they pin the rules against being tightened too far."""
    k = Keys(RUN)
    needs = [
        (WORLD, "declare_subscriber", "ingress", k.commands),
        (WORLD, "put", "egress", k.command(3)),
        (WORLD, "declare_queryable", "ingress", k.configs),
        (WORLD, "query", "egress", k.config(2)),
        (WORLD, "reply", "ingress", k.config(2)),
        (WORLD, "declare_liveliness_subscriber", "ingress", k.alive_everyone),
        (WORLD, "liveliness_query", "ingress", k.alive_world),
        (WORLD, "liveliness_token", "egress", k.alive_agent(4)),
        (WORLD, "declare_subscriber", "egress", k.everything),  # it learns of the logger
        (agent_name(2), "declare_subscriber", "ingress", k.sensing(2)),
        (agent_name(2), "declare_subscriber", "ingress", k.state(3)),
        (agent_name(2), "put", "egress", k.state(1)),
        (agent_name(2), "query", "ingress", k.config(2)),
        (agent_name(2), "reply", "egress", k.config(2)),
        (agent_name(2), "declare_liveliness_subscriber", "ingress", k.alive_agents),
        (agent_name(2), "liveliness_token", "egress", k.alive_world),
        (LOGGER, "declare_subscriber", "ingress", k.everything),
        (LOGGER, "put", "egress", k.command(1)),
        (LOGGER, "liveliness_token", "egress", k.alive_world),
        (MONITOR, "put", "egress", k.summary),
        (MONITOR, "declare_subscriber", "ingress", k.event),  # shoal run --live --secure: the
        (MONITOR, "put", "egress", k.event),  # world's events on the live view's /shoal/log
        (MONITOR, "liveliness_token", "egress", k.alive_agent(1)),
    ]
    for name, message, flow, key in needs:
        assert may(ACL, name, message, flow, key), (name, message, flow, key)
    refused = [
        (agent_name(2), "query", "ingress", k.config(3)),  # another agent's configuration
        (agent_name(2), "declare_queryable", "ingress", k.configs),  # posing as the world
        (agent_name(2), "put", "egress", k.sensing(3)),  # another agent's sensing
        (MONITOR, "put", "egress", k.command(1)),
    ]
    for name, message, flow, key in refused:
        assert not may(ACL, name, message, flow, key), (name, message, flow, key)


def test_the_monitor_hears_the_worlds_records_events_and_summary_and_nothing_else() -> None:
    """The supervisor's session follows the run (ticks, summary) and feeds the live view (ticks,
    events); it hears no agent's traffic, sends nothing and serves nothing."""
    k = Keys(RUN)
    for key in run_keys(RUN):
        hears = key in (k.tick, k.event, k.summary)
        for flow, message in [("ingress", "declare_subscriber"), ("egress", "put")]:
            assert may(ACL, MONITOR, message, flow, key) is hears, (message, flow, key)
        for message in ["put", "query", "declare_queryable"]:
            assert not may(ACL, MONITOR, message, "ingress", key), (message, key)
    heard = [k.tick, k.event, k.summary]
    assert sum(may(ACL, MONITOR, "put", "egress", key) for key in run_keys(RUN)) == len(heard)


def test_zenoh_accepts_the_rules() -> None:
    conf = zenoh.Config()
    conf.insert_json5("access_control", json.dumps(ACL))
    assert json.loads(conf.get_json("access_control/default_permission")) == "deny"


def test_secured_settings_refuse_plain_endpoints_peers_and_multicast(tmp_path: Path) -> None:
    me = Identity(Material(tmp_path), WORLD)
    with pytest.raises(WireError, match="not tls"):
        zenoh_config(mode="client", connect=["tcp/127.0.0.1:7447"], secure=me)
    with pytest.raises(WireError, match="no peers, no multicast"):
        zenoh_config(mode="client", connect=["tls/127.0.0.1:7447"], multicast=True, secure=me)
    with pytest.raises(WireError, match="no peers"):
        zenoh_config(mode="peer", connect=["tls/127.0.0.1:7447"], secure=me)
    with pytest.raises(WireError, match=r"ca\.pem is missing"):
        zenoh_config(mode="client", connect=["tls/127.0.0.1:7447"], secure=me)


needs_openssl = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl")


@needs_openssl
def test_material_layout_permissions_and_settings(tmp_path: Path) -> None:
    m = make_material(tmp_path / "pki", run=RUN, agents=2)
    for name in [ROUTER, WORLD, LOGGER, MONITOR, "agent-1", "agent-2"]:
        assert m.cert(name).is_file()
        assert stat.S_IMODE(m.key(name).stat().st_mode) == 0o600
        assert stat.S_IMODE((m.root / name).stat().st_mode) == 0o700
    assert stat.S_IMODE(m.ca_key.stat().st_mode) == 0o600
    users = dict(line.split(":", 1) for line in m.users.read_text().splitlines())
    assert sorted(users) == sorted([WORLD, LOGGER, MONITOR, "agent-1", "agent-2"])
    assert users["agent-2"] == m.password("agent-2").read_text().strip()
    assert m.scope() == (RUN, 2)
    assert json.loads(m.acl.read_text()) == access_control(RUN, 2)

    client = zenoh_config(
        mode="client", connect=["tls/127.0.0.1:7447"], secure=Identity(m, "agent-2")
    )
    got = {k: json.loads(client.get_json(k)) for k in ["transport/link/protocols",
           "transport/link/tls/enable_mtls", "transport/auth/usrpwd/user"]}  # fmt: skip
    assert got == {
        "transport/link/protocols": ["tls"],
        "transport/link/tls/enable_mtls": True,
        "transport/auth/usrpwd/user": "agent-2",
    }
    router = zenoh_config(mode="router", listen=["tls/127.0.0.1:7447"], secure=Identity(m, ROUTER))
    assert json.loads(router.get_json("access_control/enabled")) is True

    # Re-running keeps the CA and the keys, adds identities, and retargets the rules.
    ca, key = m.ca.read_bytes(), m.key("agent-1").read_bytes()
    issue(m, "outsider")
    m = make_material(m.root, run="r-9", agents=3)
    assert m.ca.read_bytes() == ca and m.key("agent-1").read_bytes() == key
    assert m.scope() == ("r-9", 3) and "outsider:" in m.users.read_text()
    assert "agent-3" in m.users.read_text() and '"shoal/r-9/' in m.acl.read_text()


@needs_openssl
def test_certs_and_run_refuse_material_made_for_another_run(tmp_path: Path) -> None:
    pki = tmp_path / "pki"
    made = CliRunner().invoke(main, ["certs", str(pki), "--run", "r-1", "--agents", "5"])
    assert made.exit_code == 0, made.output
    assert Material(pki).scope() == ("r-1", 5)
    wrong_run = CliRunner().invoke(main, ["run", "sinusoid", "--secure-dir", str(pki),
                                          "--run", "r-2"])  # fmt: skip
    assert wrong_run.exit_code == 2 and "made for run 'r-1'" in wrong_run.output
    too_few = CliRunner().invoke(main, ["certs", str(pki), "--run", "r-1", "--agents", "2"])
    assert too_few.exit_code == 0
    short = CliRunner().invoke(main, ["run", "sinusoid", "--secure-dir", str(pki)])
    assert short.exit_code == 2 and "identities for 2 agents" in short.output
    elsewhere = CliRunner().invoke(main, ["run", "sinusoid", "--secure", "-e", "tls/h:1"])
    assert elsewhere.exit_code == 2 and "--secure-dir" in elsewhere.output
