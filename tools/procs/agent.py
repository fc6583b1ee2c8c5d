"""One agent process, as ``shoal agent`` runs it: its Zenoh session, its node until the run
ends, and its last words on stderr (bad messages dropped, last tick, stats, peak RSS).

It lives here, under the command (tools/commands/agent.py only parses the options), so that the
agents' fork server (zygote.py) imports everything an agent needs once, without importing the
commands or the CLI above it.
"""

from __future__ import annotations

import resource

from shoal.agent.process import AgentNode, AgentOptions
from shoal.bus.acl import agent_name
from shoal.bus.runtime import warn
from shoal.bus.seam import ZenohBus
from shoal.tools.procs.children import AgentSpec
from shoal.tools.procs.session import client_session


def run_agent(spec: AgentSpec) -> None:
    """Run agent ``spec.agent_id`` of run ``spec.run_id`` until the run ends. AgentAbort
    (agent/process.py) if it cannot take part: the world refuses it, or its configuration."""
    agent_id = spec.agent_id
    options = AgentOptions(
        run=spec.run_id,
        agent_id=agent_id,
        start_timeout=spec.start_timeout,
        drop_rate=spec.drop_rate,
        drop_seed=spec.drop_seed,
        delay_ms=spec.delay_ms,
        jitter_ms=spec.jitter_ms,
    )
    with client_session(spec, agent_name(agent_id), f"agent {agent_id}") as session:
        node = AgentNode(options, ZenohBus(session))
        try:
            with node:
                node.run()
        finally:
            if node.dropped:
                warn(f"agent {agent_id}: {node.dropped} bad messages dropped")
            warn(f"agent {agent_id}: stopped after tick {node.tick}")
            warn(node.stats())
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            warn(f"agent {agent_id}: peak_rss_kb {peak}")
