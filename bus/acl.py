"""The router's access-control rules for one run: which process may do what on which keys.

Zenoh enforces them in the router (the ``access_control`` section of its configuration), so they
hold only for sessions that reach the run through that router: in the secured mode every shoal
process is a client of it, never a peer (a peer link would bypass the router). Default deny:
a message no rule allows is dropped by the router, whatever its payload.

Each process of a run is one identity (``world``, ``logger``, ``monitor``, ``agent-<i>``), and
its subject requires *both* a client certificate with that common name *and* that username
(Zenoh AND-s the lists of one subject), so a stolen password without the key, or the key
without the password, matches no subject and gets nothing. Flows are the router's view:
``ingress`` is what the process sends into the router, ``egress`` what the router forwards to it.

This module is pure (no I/O): :func:`access_control` returns the JSON-able section that
``shoal certs`` writes beside the router's material and ``shoal router --secure`` loads.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from shoal.bus.keys import Keys

WORLD = "world"
LOGGER = "logger"
MONITOR = "monitor"
ROUTER = "router"


def agent_name(agent: int) -> str:
    """The identity (certificate common name and username) of agent ``agent``."""
    return f"agent-{agent}"


@dataclass(frozen=True)
class Permissions:
    """What one identity may do in a run, by kind of traffic; every entry is a key expression."""

    name: str
    token: str  # the one liveliness token it may declare
    publishes: tuple[str, ...] = ()  # put, into the router
    discovers: tuple[str, ...] = ()  # be told of subscribers (a client puts only if one exists)
    subscribes: tuple[str, ...] = ()  # declare a subscriber, and be sent the puts
    watches: tuple[str, ...] = ()  # liveliness subscriber/query, and be sent the tokens
    queries: tuple[str, ...] = ()  # get, and be sent the replies
    serves: tuple[str, ...] = ()  # declare a queryable, be sent the queries, reply


def roles(run: str, agents: int) -> list[Permissions]:
    """Every identity of run ``run`` with agents 1..``agents`` and what it needs, no more.

    The world alone publishes sensing, ticks, events, the scenario, the summary, (driving
    robots) what the robots reported and were sent and (a physics plant) the engine's bodies,
    motors and contacts; it serves the
    configurations and asks for the agents' reports; agent i publishes only its own state and
    command, fetches only its own configuration and answers only for its own report; the logger
    and the monitor only listen.
    """
    k = Keys(run)
    world = Permissions(
        WORLD,
        token=k.alive_world,
        publishes=(k.sensings, k.tick, k.event, k.summary, k.scenario, k.robots, k.plant),
        discovers=(k.everything,),
        subscribes=(k.commands,),
        watches=(k.alive_everyone,),  # also its check for a second world on the run
        serves=(k.configs,),
        queries=(k.reports,),  # at the end of the run: every agent's figures (bus/report.py)
    )
    logger = Permissions(
        LOGGER,
        token=k.alive_logger,
        subscribes=(k.everything,),
        watches=(k.alive_world,),
    )
    monitor = Permissions(
        MONITOR,
        token=k.alive_process(MONITOR),
        subscribes=(k.tick, k.summary, k.event),  # events: for the live view's log
        watches=(k.alive_agents,),
    )
    agent_roles = [
        Permissions(
            agent_name(i),
            token=k.alive_agent(i),
            publishes=(k.state(i), k.command(i)),
            discovers=(k.everything,),
            subscribes=(k.sensing(i), k.states),
            watches=(k.alive_world, k.alive_agents),
            queries=(k.config(i),),
            serves=(k.report(i),),
        )
        for i in range(1, agents + 1)
    ]
    return [world, logger, monitor, *agent_roles]


def rules_of(role: Permissions) -> list[dict[str, Any]]:
    """Zenoh ACL rules (all "allow") that grant ``role`` exactly its entries."""
    grants: list[tuple[str, str, list[str], tuple[str, ...]]] = [
        ("token", "ingress", ["liveliness_token"], (role.token,)),
        ("publish", "ingress", ["put"], role.publishes),
        ("discover", "egress", ["declare_subscriber"], role.discovers),
        ("subscribe", "ingress", ["declare_subscriber"], role.subscribes),
        ("receive", "egress", ["put"], role.subscribes),
        ("watch", "ingress", ["declare_liveliness_subscriber", "liveliness_query"], role.watches),
        ("see", "egress", ["liveliness_token"], role.watches),
        ("query", "ingress", ["query"], role.queries),
        ("answer", "egress", ["reply"], role.queries),
        ("serve", "ingress", ["declare_queryable", "reply"], role.serves),
        ("asked", "egress", ["query"], role.serves),
    ]
    return [
        {
            "id": f"{role.name}/{what}",
            "permission": "allow",
            "flows": [flow],
            "messages": messages,
            "key_exprs": list(keys),
        }
        for what, flow, messages, keys in grants
        if keys
    ]


def access_control(run: str, agents: int) -> dict[str, Any]:
    """The router's ``access_control`` configuration section for the run (default deny)."""
    everyone = roles(run, agents)
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": [rule for role in everyone for rule in rules_of(role)],
        "subjects": [
            {"id": r.name, "cert_common_names": [r.name], "usernames": [r.name]} for r in everyone
        ],
        "policies": [
            {"id": r.name, "rules": [rule["id"] for rule in rules_of(r)], "subjects": [r.name]}
            for r in everyone
        ],
    }
