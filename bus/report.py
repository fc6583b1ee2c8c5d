"""What an agent reports of itself at the end of a run, and how it travels in the summary.

At the end of a run the world asks every agent's queryable ``shoal/<run>/agent/<i>/report``
(docs/wire.md) for a ``report`` document — the figures only the agent knows: the messages it
dropped as malformed, the neighbour states it heard and the ones the fault injection threw
away, how old the states it acted on were, its memory (peak RSS, and PSS, which counts the
pages it shares with the other agents once among them) — and folds the answers into the
run's summary as ``agent_<i>.<figure>`` entries, so they are on the bus, in the log, and in
what ``shoal run`` prints, and nobody reads them from an agent's stderr.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

# The figures of a report, each an int or None (an age when no state was heard).
FIGURES = (
    "last_tick",  # the last tick the agent sensed
    "bad_messages",  # malformed or impossible messages counted and dropped
    "states_heard",  # neighbour states offered to the fault injection
    "injected_drops",  # … and thrown away by it (--drop-rate)
    "delayed_messages",  # outgoing states and commands held back (--delay-ms, agent/latency.py)
    "age_p50",  # ticks: how old the neighbour states it acted on were (realtime)
    "age_p99",
    "age_max",
    "stale_edges",  # edges not followed because the neighbour's state was too old
    "peak_rss_kb",  # the agent process's peak resident memory
    "pss_kb",  # its proportional set size at the report: shared pages counted once (Linux)
)

# s the world waits for the reports; an agent that is gone does not answer.
REPORT_TIMEOUT_S = 2.0

_ENTRY = re.compile(r"^agent_(\d+)\.([a-z0-9_]+)$")


def report_body(figures: Mapping[str, int | None]) -> dict[str, int | None]:
    """A ``report`` document's body: every figure, None for one the agent does not have."""
    return {name: figures.get(name) for name in FIGURES}


def summary_entries(agent: int, body: Mapping[str, Any]) -> dict[str, int | None]:
    """Agent ``agent``'s report as summary entries; a figure that is not an int (or None) in a
    report from the wire is left out, never passed on."""
    out: dict[str, int | None] = {}
    for name in FIGURES:
        value = body.get(name)
        if value is None or (type(value) is int):
            out[f"agent_{agent}.{name}"] = value
    return out


def reports_in(summary: Mapping[str, Any]) -> dict[int, dict[str, Any]]:
    """The agents' reports folded into ``summary``, by agent id (those that answered)."""
    out: dict[int, dict[str, Any]] = {}
    for key, value in summary.items():
        m = _ENTRY.match(key)
        if m and m.group(2) in FIGURES:
            out.setdefault(int(m.group(1)), {})[m.group(2)] = value
    return dict(sorted(out.items()))


def pss_kb() -> int | None:
    """This process's proportional set size, kB (``Pss:`` of /proc/self/smaps_rollup): its
    private pages plus its share of each page it maps with other processes, so that the PSS
    of all a run's agents adds up to the memory they take together. None off Linux."""
    try:
        with open("/proc/self/smaps_rollup", encoding="ascii") as f:
            for line in f:
                if line.startswith("Pss:"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None
