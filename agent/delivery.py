"""What reaches the controller in realtime: the freshest state of each neighbour, its age, and
(for fault injection) which incoming messages are thrown away.

In realtime nothing waits for a neighbour: an agent acts at once on its sensing with whatever it
has heard. A lost state therefore does not stall anyone; it only makes the neighbour's latest
state older. The age of a state is counted in ticks, ``now - state.tick``, where ``now`` is the
tick of the agent's own sensing. A state at most ``max_age`` ticks old is used as it is (its
position is off by at most ``max_age · dt · |v_j|``); an older one is treated like a missing
neighbour: the edge is dropped for this tick, exactly as Algorithm 2 drops the edge to an
evading neighbour. An agent with no usable neighbour left has a zero consensus error and so
holds still (law (1) with e = 0), rather than chase a position that may be far out of date.

Pure functions and a seeded random source: no I/O, no clock.
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from shoal.bus.messages import AgentState

MAX_AGE = 10
"""Ticks after which a neighbour's latest state is no longer followed (0.1 s at dt = 0.01 s).

Why 10: on a healthy loopback run the age is 0–2 ticks; with 20 % of states lost, ten losses in
a row (probability 0.2¹⁰ ≈ 1e-7 per edge and tick) are needed to reach it, so the edge is
practically never dropped for message loss alone, while a neighbour that is cut off or hung is
dropped after 0.1 s, long before its stale position (≤ 10·dt·(α|e| + β) ≈ 0.2 m off at β = 2 m/s
and a converged formation) would pull the formation further than its tolerance.
"""


def freshest(
    latest: Mapping[int, AgentState], listens_to: Iterable[int], now: int, max_age: int
) -> tuple[dict[int, AgentState], dict[int, int]]:
    """The neighbour states to act on at tick ``now``, and the age (ticks) of each one heard.

    latest : the newest state heard from each neighbour (any tick ≤ now + STALE_AFTER: a
        neighbour may already have announced later ticks than this agent has sensed).
    Returns (used, ages): ``used`` holds the states at most ``max_age`` ticks old; ``ages`` has
    an entry, clipped at 0, for every neighbour in ``listens_to`` that was heard at all.
    """
    used: dict[int, AgentState] = {}
    ages: dict[int, int] = {}
    for j in listens_to:
        state = latest.get(j)
        if state is None:
            continue
        age = max(now - state.tick, 0)
        ages[j] = age
        if age <= max_age:
            used[j] = state
    return used, ages


@dataclass
class Dropper:
    """Throws away a fraction ``rate`` of incoming neighbour messages, for fault injection.

    The random source is seeded with (seed, agent id), so every agent draws its own repeatable
    sequence; which message meets which draw still depends on arrival order, which realtime does
    not fix. ``offered`` and ``dropped`` count every decision.
    """

    rate: float
    seed: int
    agent_id: int
    offered: int = 0
    dropped: int = 0
    _rng: random.Random = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not 0.0 <= self.rate < 1.0:
            raise ValueError(f"drop rate must be in [0, 1), got {self.rate}")
        self._rng = random.Random(f"shoal-drop-{self.seed}-{self.agent_id}")

    def drop(self) -> bool:
        """Whether to throw away the message that just arrived (counted either way)."""
        self.offered += 1
        if self.rate > 0.0 and self._rng.random() < self.rate:
            self.dropped += 1
            return True
        return False


@dataclass
class AgeStats:
    """How old the neighbour states an agent acted on were: a histogram in ticks, and how many
    times an edge was dropped because its latest state was older than ``MAX_AGE``."""

    histogram: dict[int, int] = field(default_factory=dict)
    stale_edges: int = 0

    def add(self, ages: Mapping[int, int], max_age: int) -> None:
        for age in ages.values():
            if age > max_age:
                self.stale_edges += 1
            else:
                self.histogram[age] = self.histogram.get(age, 0) + 1

    def quantile(self, q: float) -> int | None:
        """The smallest age with at least a fraction ``q`` of the used states at or below it."""
        total = sum(self.histogram.values())
        if total == 0:
            return None
        seen = 0
        for age in sorted(self.histogram):
            seen += self.histogram[age]
            if seen >= q * total:
                return age
        return max(self.histogram)
