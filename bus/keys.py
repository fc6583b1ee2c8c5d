"""Zenoh key expressions of one run. Documented in docs/wire.md.

Every data key lives under ``shoal/<run>/`` so that two runs on one router never see each other,
and there is one key per agent and message kind, so an agent subscribes to its neighbours only.
Presence is a liveliness token under ``@shoal/<run>/``: the ``@`` keeps tokens out of a
``shoal/**`` recorder.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from shoal.bus.errors import WireError

_RUN_ID = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
_AGENT = re.compile(r"/agent/([1-9][0-9]{0,8})(?:/|$)")  # canonical ids only: not 01 or 007


@dataclass(frozen=True, slots=True)
class Keys:
    """The keys of run ``run``."""

    run: str

    def __post_init__(self) -> None:
        if not _RUN_ID.match(self.run):
            raise WireError(f"run id {self.run!r}: use 1-64 letters, digits, '-' or '_'")

    @property
    def root(self) -> str:
        return f"shoal/{self.run}"

    @property
    def everything(self) -> str:
        """Every data key of the run (what the logger records)."""
        return f"{self.root}/**"

    def sensing(self, agent: int) -> str:
        """World → agent: position and sensed obstacles at the start of a tick."""
        return f"{self.root}/agent/{agent}/sensing"

    def state(self, agent: int) -> str:
        """Agent → neighbours: position, Ω flag, σ bid."""
        return f"{self.root}/agent/{agent}/state"

    def command(self, agent: int) -> str:
        """Agent → world: the velocity for the tick, with what the agent announced."""
        return f"{self.root}/agent/{agent}/cmd"

    def report(self, agent: int) -> str:
        """Agent ``agent``'s queryable: its figures at the end of the run (bus/report.py)."""
        return f"{self.root}/agent/{agent}/report"

    @property
    def reports(self) -> str:
        return f"{self.root}/agent/*/report"

    @property
    def commands(self) -> str:
        return f"{self.root}/agent/*/cmd"

    @property
    def states(self) -> str:
        return f"{self.root}/agent/*/state"

    @property
    def sensings(self) -> str:
        return f"{self.root}/agent/*/sensing"

    def config(self, agent: int) -> str:
        """Queryable of the world: the agent's configuration."""
        return f"{self.root}/world/config/{agent}"

    @property
    def configs(self) -> str:
        return f"{self.root}/world/config/*"

    @property
    def scenario(self) -> str:
        """World → all, once at the start: the scenario file."""
        return f"{self.root}/world/scenario"

    @property
    def tick(self) -> str:
        """World → all, every tick: the ground-truth record of the tick."""
        return f"{self.root}/world/tick"

    @property
    def robots(self) -> str:
        """World → all, every tick of a run that drives robots: their pose ages and Twists."""
        return f"{self.root}/world/robots"

    @property
    def plant(self) -> str:
        """World → all, every tick of a run on a physics plant: the robots' bodies, motors
        and contacts as the engine moved them."""
        return f"{self.root}/world/plant"

    @property
    def event(self) -> str:
        """World → all: something worth a line in the log (an agent gone, the run done)."""
        return f"{self.root}/world/event"

    @property
    def summary(self) -> str:
        """World → all, once at the end: the run's metrics."""
        return f"{self.root}/world/summary"

    # -- presence -------------------------------------------------------------------------------

    @property
    def alive_root(self) -> str:
        return f"@shoal/{self.run}"

    def alive_agent(self, agent: int) -> str:
        return f"{self.alive_root}/agent/{agent}"

    @property
    def alive_agents(self) -> str:
        return f"{self.alive_root}/agent/*"

    @property
    def alive_world(self) -> str:
        return f"{self.alive_root}/world"

    @property
    def alive_logger(self) -> str:
        return self.alive_process("logger")

    def alive_process(self, name: str) -> str:
        """Token of a helper process of the run: "logger", "monitor"."""
        return f"{self.alive_root}/{name}"

    @property
    def alive_everyone(self) -> str:
        return f"{self.alive_root}/**"


@functools.lru_cache(maxsize=1024)  # a process meets a handful of keys, every tick
def agent_of(key: str) -> int | None:
    """The agent id in ``…/agent/<id>/…`` or ``…/agent/<id>``, None if there is none."""
    found = _AGENT.search(key)
    return int(found.group(1)) if found else None
