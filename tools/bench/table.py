"""How ``shoal bench``'s figures are shown to a person: tables, each figure beside its floor,
and what every column means. The JSON (``--json``) keeps every figure; this keeps the ones
people compare."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any


def _cell(value: Any, digits: int = 1) -> str:
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """Right-aligned columns under their headers (the first column left-aligned)."""
    cells = [[_cell(v) for v in row] for row in rows]
    widths = [max(len(h), *(len(r[k]) for r in cells)) for k, h in enumerate(headers)]

    def line(values: Sequence[str]) -> str:
        rest = zip(values[1:], widths[1:], strict=True)
        return "  ".join([f"{values[0]:<{widths[0]}}", *(f"{v:>{w}}" for v, w in rest)])

    return [line(headers), *(line(r) for r in cells)]


LOCKSTEP_COLUMNS = (
    ("floor t/s", "ticks/s of a bare Zenoh exchange of the same messages by the same number "
     "of processes, no control: the most this machine's bus allows (measured in this run)"),
    ("shoal t/s", "ticks/s of the lockstep swarm: real processes, the control law and the log"),
    ("floor/shoal", "the ratio: how many times slower than the floor shoal runs (1 = the bus "
     "is all it costs)"),
    ("p50, p99 ms", "command latency: an agent's sensing received to its command received"),
    ("CPU µs/tick", "CPU of all processes per tick, shoal (floor); `--json` splits it into "
     "agent, world, logger, router and monitor (the process that follows the run)"),
    ("steal", "largest share of CPU time the hypervisor took from this VM during the size's "
     "runs: above a few % the figures are the VM's, not shoal's"),
)  # fmt: skip


def legend(columns: Sequence[tuple[str, str]]) -> list[str]:
    width = max(len(name) for name, _ in columns)
    return [f"  {name:<{width}}  {what}" for name, what in columns]


def render_bench(result: Mapping[str, Any]) -> str:
    """The main benchmark: the lockstep table against the floor, then start-up, realtime
    latency, memory and the safety filter's cost."""
    rows = []
    for r in result["lockstep"]:
        cpu = r["cpu_us_per_tick"]
        rows.append((
            r["agents"], r["ticks"], r["floor_ticks_per_s"], r["lockstep_ticks_per_s"],
            f"{r['floor_over_lockstep']:.2f}×",
            f"{_cell(r['latency_p50_ms'], 2)}, {_cell(r['latency_p99_ms'], 2)}",
            f"{cpu['lockstep']['total']:.0f} ({cpu['floor']['total']:.0f})",
            f"{100 * max(r['steal_floor'], r['steal_lockstep']):.1f} %",
        ))  # fmt: skip
    headers = ("agents", "ticks", "floor t/s", "shoal t/s", "floor/shoal", "p50, p99 ms",
               "CPU µs/tick", "steal")  # fmt: skip
    lines = ["lockstep runs beside their floor", *table(headers, rows), *legend(LOCKSTEP_COLUMNS)]
    startup = ", ".join(f"{n} agents {s:.1f} s" for n, s in result["startup_s"].items())
    lines += ["", f"start-up (every agent up)   {startup}"]
    rt = result["realtime_5_agents"]
    lines.append(
        f"realtime, 5 agents          {_cell(rt['ticks_per_s'])} ticks/s, command latency p50 "
        f"{_cell(rt['latency_p50_ms'], 2)} ms / p99 {_cell(rt['latency_p99_ms'], 2)} ms, "
        f"missed deadlines {rt['missed_deadlines']}"
    )
    rss, pss = result["agent_peak_rss_mb"], result["agent_pss_mb"]
    lines.append(
        f"memory per agent process    peak RSS median {_cell(rss['median'])} MB (max "
        f"{_cell(rss['max'])}), PSS median {_cell(pss['median'])} MB: what one more agent costs, "
        "shared pages counted once"
    )
    if "safety_filter" in result:
        lines.append(render_filter(result["safety_filter"]))
    return "\n".join(lines)


def render_filter(f: Mapping[str, Any]) -> str:
    """The safety filter's CPU per agent-tick beside its target and the simulator's."""
    active = _cell(f["filter_us_active"], 2)
    return (
        f"safety filter               {f['filter_us_per_agent_tick']:.2f} µs per agent-tick "
        f"(target ≤ {f['target_us']:g} µs; idle {f['filter_us_idle']:.2f}, active {active}; "
        f"acting on {100 * f['active_share']:.1f} % of {f['agent_ticks']} agent-ticks of "
        f"{f['field']}), beside the whole reference simulator's "
        f"{f['simulator_us_per_agent_tick']:.2f} µs"
    )


def render_rows(title: str, rows: Sequence[Mapping[str, Any]]) -> str:
    """A list of flat records (--drops runs, --capacity rates) as a table; nested values are
    left to --json."""
    keys = [k for k in rows[0] if not isinstance(rows[0][k], dict | list)] if rows else []
    body = [[r.get(k) for k in keys] for r in rows]
    return "\n".join([title, *table(keys, body), "(--json: every figure, per trial)"])
