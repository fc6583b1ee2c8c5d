"""Algorithm 1 (max-consensus on the contraction factor σ) and the bid an agent makes.

Timing, which the paper leaves open: rounds run one per tick in fixed epochs of L_G ticks. At the
first tick of an epoch every agent sets its value to its own bid; each tick it keeps the maximum
of its value and its neighbours' (one round); after L_G rounds (Proposition 1) all hold the same
maximum, and every agent applies it from the first tick of the next epoch, the same tick for all.
A formation that no longer sees a narrow passage bids 1 and so expands again one epoch later.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from shoal.geometry.vectors import PointsLike, VectorLike, add, dot, floats, norm, scale, sub

# A passage is only entered if the heading crosses the gap at least this steeply:
# cos of the angle between the heading and the line through the two centres.
_MAX_ALONG_COS = math.cos(math.radians(30.0))


# m/s: with ``strict`` bidding, an agent slower than this (a settled formation's chattering)
# asks for no contraction.
BID_SPEED = 0.1


def epoch_of(tick: int, rounds: int) -> int:
    """The epoch ``tick`` belongs to: epochs are ``rounds`` ticks long, the first starts at 0."""
    return tick // max(rounds, 1)


def epoch_start(tick: int, rounds: int) -> bool:
    """True on the first tick of an epoch of ``rounds`` ticks."""
    return tick % max(rounds, 1) == 0


def consensus_round(own: float, received: Iterable[float]) -> float:
    """One round of Algorithm 1: σ^ℓ ← max over N_ℓ ∪ {ℓ}."""
    return max([own, *received])


def passage_bid(
    position: VectorLike,
    heading: VectorLike,
    centres: PointsLike,
    radii: VectorLike,
    *,
    formation_radius: float,
    slot_shift: VectorLike,
    safety_margin: float,
    epsilon: float,
    sigma_max: float,
    strict: bool = False,
) -> float:
    """σ^i: the contraction this agent asks for, ≥ 1 (1 = no narrow passage in its way).

    A pair of sensed obstacles j, k is a narrow passage when its usable width w - 2(ρ + ε)
    (w = ‖c_j - c_k‖ - r_j - r_k, the free width) is less than the formation's diameter
    2·formation_radius and the agent heads through the gap rather than along it. The agent bids
    for it until both its own position and ``position + slot_shift`` (where its slot moves once
    the formation expands again) are beyond the far side of the pair's guard circles, so
    expansion never pulls an agent back into the passage. The leader goes through a passage's
    middle and the formation is scaled about the leader, so it fits when
    formation_radius / σ ≤ w/2 - ρ - ε. A gap with no usable width bids ``sigma_max``.

    ``strict`` (on with the safety filter; off keeps the paper mode's trajectories as they
    were): only a gap the agent is actually in line with counts — its position across the pair
    lies between the two centres — and only while it moves at least :data:`BID_SPEED`. Without
    these, an agent beside a pair, whose heading is dominated by the formation's own reshaping,
    bids and unbids every epoch, and σ flips for good (docs/safety.md, liveness).
    """
    # Arrays (a campaign's gap check passes them) as plain floats, for the compiled module.
    position, heading, radii, slot_shift = (
        floats(v) for v in (position, heading, radii, slot_shift)
    )
    centres = [floats(c) for c in centres]
    speed = norm(heading)
    if speed < (BID_SPEED if strict else 1e-9) or formation_radius <= 0.0:
        return 1.0
    unit = [h / speed for h in heading]
    bid = 1.0
    m = len(centres)
    for j in range(m):
        for k in range(j + 1, m):
            span = sub(centres[k], centres[j])
            length = norm(span)
            usable = length - radii[j] - radii[k] - 2.0 * (safety_margin + epsilon)
            if usable >= 2.0 * formation_radius or length == 0.0:
                continue  # the whole formation fits with its margins, or degenerate
            across = [x / length for x in span]
            if abs(dot(unit, across)) > _MAX_ALONG_COS:
                continue  # moving along the pair, not through it
            through = sub(unit, scale(dot(unit, across), across))
            size = norm(through)
            through = tuple([x / size for x in through])
            mid = [x / 2.0 for x in add(centres[j], centres[k])]
            from_mid = sub(position, mid)
            if strict and abs(dot(from_mid, across)) > length / 2.0:
                continue  # beside the pair, not in line with its gap
            far = max(radii[j], radii[k]) + safety_margin + epsilon
            ahead = min(dot(from_mid, through), dot(sub(add(position, slot_shift), mid), through))
            if ahead >= far:
                continue  # through, and so is the slot it will expand to
            need = sigma_max if usable <= 0 else 2.0 * formation_radius / usable
            bid = max(bid, min(sigma_max, need))
    return bid
