"""How a run's summary is shown to a person."""

from __future__ import annotations

import math
from typing import Any

from shoal.bus.report import reports_in


def _fmt(value: Any, unit: str = "", digits: int = 3) -> str:
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.{digits}f}{unit}"
    return f"{value}{unit}"


Row = tuple[str, str]  # a figure's name and its text


def render_summary(summary: dict[str, Any]) -> str:
    """A short, aligned, human-readable block of the figures that matter."""
    rows = [*_outcome(summary), *_safety(summary)]
    optional = (("plant", _plant), ("clock", _clock), ("safety layer", _layer),
                ("robots", _robots), ("agents' reports", _reports))  # fmt: skip
    for name, text_of in optional:
        text = text_of(summary)
        if text is not None:
            rows.append((name, text))
    rows += _endings(summary)
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def _outcome(summary: dict[str, Any]) -> list[Row]:
    """What happened: collisions and clearances, the theorem's margins, convergence and
    arrival, σ and Ω (a figure an older shoal's summary lacks is left out)."""
    bound = summary["convergence_bound"]  # None (JSON's inf): β ≤ the leader's speed
    if bound is not None and not math.isfinite(bound):
        bound = None
    rows = [
        (
            "scenario",
            f"{summary['scenario']}  ({summary['agents']} agents, "
            f"{summary['steps']} steps of {summary['dt']} s)",
        ),
        ("collisions", _fmt(summary["collisions"])),
        ("min clearance", _fmt(summary["min_clearance"], " m")),
    ]
    if summary.get("min_mover_clearance") is not None:  # a run with moving obstacles
        rows.append(
            (
                "moving obstacles",
                f"min clearance {_fmt(summary['min_mover_clearance'], ' m')}, contacts: "
                f"{_fmt(summary.get('agent_at_fault', 0))} agent at fault, "
                f"{_fmt(summary.get('obstacle_at_fault', 0))} obstacle at fault",
            )
        )
    rows.append(("min inter-agent distance", _fmt(summary["min_interagent_distance"], " m")))
    if summary.get("separation_margin") is not None:  # an older shoal's summary has none
        rows.append(("margins", _margins(summary)))
    rows.append(("convergence", _convergence(summary, bound)))
    if summary.get("arrived") is not None:
        rows.append(("arrival", _arrival(summary)))
    rows += [
        ("final formation error", _fmt(summary["final_formation_error"], " m")),
        ("agreed σ", _sigma(summary)),
        ("Ω episodes", _fmt(summary["omega_episodes"])),
    ]
    if summary.get("livelocks"):
        longest = _fmt(summary["longest_livelock"], " s", 2)
        rows.append(("livelocks", f"{summary['livelocks']} (longest {longest})"))
    return rows


def _safety(summary: dict[str, Any]) -> list[Row]:
    """The safety filter's activity, and the speed limit where the robots reached it."""
    if summary.get("safety", "filter") != "filter":
        rows = [("safety filter", "off (safety: paper, Algorithm 2 alone)")]
    else:
        rows = [
            (
                "safety filter",
                f"active {100 * summary.get('filter_activity', 0.0):.2f} % of agent-ticks, "
                f"stalls {_fmt(summary.get('stalls'))} "
                f"(longest {_fmt(summary.get('longest_stall'), ' s', 2)})",
            )
        ]
    if summary.get("at_speed_limit"):
        rows.append(
            (
                "speed limit",
                f"reached in {100 * summary['at_speed_limit']:.2f} % of agent-ticks (there the "
                "point moves slower than the law asks; Theorem 1's bound assumes it never does)",
            )
        )
    return rows


def _clock(summary: dict[str, Any]) -> str | None:
    """A run's clock: its rate, its commands' latency and the deadlines it missed."""
    if summary.get("clock") is None:
        return None
    return (
        f"{summary['clock']}: {_fmt(summary.get('ticks_per_s'), ' ticks/s', 1)}, "
        f"command latency p50 {_fmt(summary.get('latency_p50_ms'), ' ms', 2)} / "
        f"p99 {_fmt(summary.get('latency_p99_ms'), ' ms', 2)}, "
        f"missed deadlines {_fmt(summary.get('missed_deadlines'))}"
    )


def _layer(summary: dict[str, Any]) -> str | None:
    """What stood between the commands and the robots' motion, and what a referee would have
    changed where there was none."""
    layer = summary.get("safety_layer")
    if layer == "reach":
        return (
            f"reach: each step certified from what the robot can reach; "
            f"{_fmt(summary.get('reach_brakes'))} robot-ticks told to stop (bounds broken), "
            f"{_fmt(summary.get('reach_slowed'))} agent-ticks slowed by the braking cap, "
            f"largest margin {_fmt(summary.get('reach_largest_margin'), ' m', 3)}"
        )
    if layer in ("onboard", "none"):
        would = summary.get("referee_would_correct")
        how = (
            f"onboard: each robot's own layer, with its own position, sensor and radio; it "
            f"changed {_fmt(summary.get('actuator_corrections'))} commands and stood "
            f"{_fmt(summary.get('layer_standing'))} robot-ticks waiting for a snapshot"
            if layer == "onboard"
            else "none: commands applied as the agents sent them"
        )
        largest = _fmt(summary.get("referee_largest_change"), " m/s", 3)
        return f"{how}; a referee would have changed {_fmt(would)} (largest change {largest})"
    if summary.get("clock") == "realtime":
        return (
            f"referee: the world filtered every command again, and changed "
            f"{_fmt(summary.get('actuator_corrections'))}"
        )
    return None


def _plant(summary: dict[str, Any]) -> str | None:
    """--plant mujoco: the presets, what the engine reported, and how well the robots
    tracked their commands (collisions, clearances and margins above are the engine's)."""
    if summary.get("plant") != "mujoco":
        return None
    deepest = abs(summary.get("engine_deepest_contact") or 0.0)
    return (
        f"mujoco ({summary.get('dynamics')}), {_fmt(summary.get('physics_steps'))} physics steps "
        f"of {_fmt(1000 * summary.get('physics_step', 0.0), ' ms', 2)}; engine contacts "
        f"{_fmt(summary.get('engine_contacts'))} (deepest {_fmt(deepest, ' m', 4)}); "
        f"tracking error p50 {_fmt(summary.get('tracking_error_p50'), ' m/s', 3)} / "
        f"p99 {_fmt(summary.get('tracking_error_p99'), ' m/s', 3)} / "
        f"max {_fmt(summary.get('tracking_error_max'), ' m/s', 3)}"
    )


def _robots(summary: dict[str, Any]) -> str | None:
    """--robots ros2: the poses heard and the commands sent to real (or simulated) robots."""
    if summary.get("robot_poses") is None:
        return None
    return (
        f"ROS 2: {_fmt(summary['robot_poses'])} poses heard "
        f"({_fmt(summary.get('robot_poses_dropped'))} malformed dropped; age when used "
        f"p99 {_fmt(summary.get('pose_age_p99_ms'), ' ms', 1)}, max "
        f"{_fmt(summary.get('pose_age_max_ms'), ' ms', 1)}), "
        f"{_fmt(summary.get('robot_commands'))} Twists sent, "
        f"{_fmt(summary.get('pose_holds'))} robot-ticks held for a stale pose"
    )


def _reports(summary: dict[str, Any]) -> str | None:
    """The agents' own end-of-run figures (bus/report.py): memory and bad messages."""
    reports = reports_in(summary)
    if not reports:
        return None
    rss = [r["peak_rss_kb"] for r in reports.values() if r.get("peak_rss_kb")]
    pss = [r["pss_kb"] for r in reports.values() if r.get("pss_kb")]
    shared = f" (PSS max {_fmt(max(pss) / 1024, ' MB', 1)})" if pss else ""
    bad = sum(r.get("bad_messages") or 0 for r in reports.values())
    return (
        f"{len(reports)} of {summary.get('agents', '?')}: "
        f"peak memory max {_fmt(max(rss) / 1024 if rss else None, ' MB', 1)}{shared}, "
        f"{bad} bad messages dropped"
    )


def _endings(summary: dict[str, Any]) -> list[Row]:
    """A run that ended early, and Assumption 2 broken during the run."""
    rows = []
    if summary.get("aborted"):
        rows.append(("ended early", str(summary["aborted"])))
    if summary.get("assumption2_violations"):
        rows.append(
            (
                "Assumption 2 in the run",
                f"{summary['assumption2_violations']} ticks in which an evading agent and all "
                "its neighbours evaded at once (the paper's wording taken literally; the graph "
                "passed the load-time check, and the filter keeps everyone safe regardless: "
                "docs/paper-notes.md)",
            )
        )
    return rows


def json_safe(summary: dict[str, Any]) -> dict[str, Any]:
    """inf is not JSON: an unbounded figure becomes null."""
    return {k: (None if isinstance(v, float) and math.isinf(v) else v) for k, v in summary.items()}


def _margins(summary: dict[str, Any]) -> str:
    """The least margins against the safety theorem's bounds: clearance − ρ, distance − 2R."""
    guard = summary.get("guard_margin")
    text = f"guard {guard:+.4g} m, " if guard is not None else "guard — (no obstacles), "
    text += f"separation {summary['separation_margin']:+.4g} m"
    if summary.get("safety", "filter") != "filter":
        return f"{text} (no filter: no bound)"
    if summary.get("plant") == "mujoco" and summary.get("safety_layer") == "reach":
        return (
            f"{text} (along the engine's motion; the reach layer's theorem for robots with "
            f"mass: ≥ −{summary.get('contact_slack', 0.0):.1e} m while its bounds hold)"
        )
    if summary.get("plant") == "mujoco":
        return (
            f"{text} (along the engine's motion; the filter's theorem is for robots that move "
            "as commanded)"
        )
    return f"{text} (the filter's theorem: ≥ −{summary.get('contact_slack', 0.0):.1e} m)"


def _arrival(summary: dict[str, Any]) -> str:
    """Whether and when the run arrived (world/arrival.py), or why not."""
    tol = _fmt(summary.get("arrival_tolerance"), " m")
    if summary["arrived"]:
        return (
            f"yes at {_fmt(summary['arrival_time'], ' s', 2)} (leader home, formation within {tol})"
        )
    cause = summary.get("not_arrived")
    leader = f"leader {_fmt(summary.get('leader_shortfall'), ' m', 2)} short"
    follower = f"a follower {_fmt(summary.get('slot_distance'), ' m', 2)} off its slot"
    detail = {"leader trapped": leader, "out of time": f"{leader}, {follower}"}
    return f"no: {cause} ({detail.get(str(cause), follower)}; tolerance {tol})"


def _convergence(summary: dict[str, Any], bound: float | None) -> str:
    """When the formation error first came within tolerance, against Theorem 1's ``bound``
    (None: no bound); a bound of 0 s says the agents started within tolerance, not that
    something failed."""
    conv, tol = summary["convergence_time"], _fmt(summary["tolerance"], " m")
    within = conv is not None and bound is not None and conv <= bound
    shown = f"bound {_fmt(bound, ' s', 2)}" if bound is not None else "no bound: β ≤ leader speed"
    if bound == 0.0 and conv == 0.0:
        return f"0.00 s: the agents started within tolerance ({tol}) of their slots"
    return f"{_fmt(conv, ' s', 2)} ({shown}, tolerance {tol}{', within bound' if within else ''})"


def _sigma(summary: dict[str, Any]) -> str:
    """The largest σ applied and the rounds it took; and, if the agents did not all apply the
    same σ at every tick (Proposition 1 is for lockstep), in how many ticks they differed."""
    text = f"{_fmt(summary['sigma'], '', 3)} (rounds {_fmt(summary['sigma_rounds'])})"
    if summary["sigma"] is not None and summary["sigma"] > 1.0:
        text += ": Algorithm 1 contracted the formation to pass a gap"
    split = summary.get("sigma_disagreement") or 0
    return text if not split else f"{text}; agents applied different σ in {split} ticks"
