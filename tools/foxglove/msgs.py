"""Foxglove's message shapes as plain JSON values: the vocabulary the views are written in.

Foxglove's published JSON schemas (tools/foxglove/schemas/) *require* every field, so each
builder here fills all of them: an entity lists every primitive kind (empty when unused), a line
has ``colors`` and ``indices``. Times are ``{sec, nsec}`` objects, enums (line type, log level)
are integers, as in Foxglove's JSON encoding. Nothing here knows about formations.

Coordinates are rounded to 0.1 mm: the views are for looking at, the raw channels keep the exact
float64 values, and short numbers make the JSON (and the file) several times smaller.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

Json = dict[str, Any]
Point = Sequence[float] | NDArray[np.float64]  # 2 or 3 coordinates, m
RGBA = tuple[float, float, float, float]

LINE_STRIP, LINE_LOOP, LINE_LIST = 0, 1, 2  # foxglove.LinePrimitive type
DIGITS = 4  # 0.1 mm
IDENTITY: Json = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def stamp(ns: int) -> Json:
    """A foxglove time (or duration ≥ 0) from integer nanoseconds."""
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def vec3(p: Point) -> Json:
    """A 3-D point; a 2-D one lies in the z = 0 plane."""
    z = p[2] if len(p) > 2 else 0.0
    return {"x": round(p[0], DIGITS), "y": round(p[1], DIGITS), "z": round(z, DIGITS)}


def vec3s(points: Sequence[Point] | NDArray[np.float64]) -> list[Json]:
    """Many points at once (numpy rounds them): the scene layers convert each tick record's
    positions once and share the dicts between the frames, bodies, edges and trails."""
    a = np.asarray(points, dtype=np.float64)
    a = np.round(a.reshape(a.shape[0], -1), DIGITS)
    if a.shape[1] == 2:
        return [{"x": x, "y": y, "z": 0.0} for x, y in a.tolist()]
    return [{"x": x, "y": y, "z": z} for x, y, z in a.tolist()]


ORIGIN = vec3((0.0, 0.0, 0.0))


def pose(position: Json, orientation: Json = IDENTITY) -> Json:
    return {"position": position, "orientation": orientation}


def colour(rgba: RGBA) -> Json:
    r, g, b, a = rgba
    return {"r": r, "g": g, "b": b, "a": a}


def entity(
    ns: int,
    entity_id: str,
    *,
    frame_id: str = "world",
    frame_locked: bool = False,
    metadata: Mapping[str, str] | None = None,
    arrows: Sequence[Json] = (),
    spheres: Sequence[Json] = (),
    cylinders: Sequence[Json] = (),
    lines: Sequence[Json] = (),
    texts: Sequence[Json] = (),
) -> Json:
    """A foxglove.SceneEntity that stays until an entity with the same id on the same topic
    replaces it (lifetime 0): every layer republishes all its ids, so none is ever stale."""
    return {
        "timestamp": stamp(ns),
        "frame_id": frame_id,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": frame_locked,
        "metadata": [{"key": k, "value": v} for k, v in (metadata or {}).items()],
        "arrows": list(arrows),
        "cubes": [],
        "spheres": list(spheres),
        "cylinders": list(cylinders),
        "lines": list(lines),
        "triangles": [],
        "texts": list(texts),
        "models": [],
    }


def sphere(centre: Json, diameter: float, rgba: RGBA) -> Json:
    d = round(diameter, DIGITS)
    return {"pose": pose(centre), "size": {"x": d, "y": d, "z": d}, "color": colour(rgba)}


def cylinder(centre: Json, diameter: float, height: float, rgba: RGBA) -> Json:
    """Upright (along z), centred on ``centre``."""
    d, h = round(diameter, DIGITS), round(height, DIGITS)
    return {
        "pose": pose(centre),
        "size": {"x": d, "y": d, "z": h},
        "bottom_scale": 1.0,
        "top_scale": 1.0,
        "color": colour(rgba),
    }


def line(
    kind: int,
    points: list[Json],
    rgba: RGBA,
    thickness: float,
    *,
    origin: Json = ORIGIN,
    scale_invariant: bool = True,
) -> Json:
    """A foxglove.LinePrimitive; ``points`` relative to ``origin``. Scale-invariant thickness is
    in pixels, so graph edges and trails stay visible at any zoom."""
    return {
        "type": kind,
        "pose": pose(origin),
        "thickness": thickness,
        "scale_invariant": scale_invariant,
        "points": points,
        "color": colour(rgba),
        "colors": [],
        "indices": [],
    }


def dashes(a: Json, b: Json, count: int = 12) -> list[Json]:
    """Endpoint pairs (a LINE_LIST) of ``count`` dashes from a to b, each half its period:
    LinePrimitive has no dash style."""
    ends = [f for k in range(count) for f in (k / count, (k + 0.5) / count)]
    start = (a["x"], a["y"], a["z"])
    step = (b["x"] - a["x"], b["y"] - a["y"], b["z"] - a["z"])
    return vec3s([[p + f * d for p, d in zip(start, step, strict=True)] for f in ends])


@cache
def _circle(radius: float, segments: int) -> tuple[Json, ...]:
    turn = [2 * math.pi * k / segments for k in range(segments)]
    return tuple(vec3s([(radius * math.cos(a), radius * math.sin(a)) for a in turn]))


def circle(radius: float, segments: int = 48) -> list[Json]:
    """Points of a circle about the origin in the z = 0 plane (for a LINE_LOOP)."""
    return list(_circle(radius, segments))


def text(position: Json, label: str, rgba: RGBA, font_size: float = 14.0) -> Json:
    """A label that faces the camera and keeps its size in pixels at any zoom."""
    return {
        "pose": pose(position),
        "billboard": True,
        "font_size": font_size,
        "scale_invariant": True,
        "color": colour(rgba),
        "text": label,
    }


def arrow(tail: Json, vector: Point, rgba: RGBA, diameter: float) -> Json | None:
    """An arrow from ``tail`` along ``vector`` (its length is |vector|); None for a zero vector.
    An ArrowPrimitive points along its pose's +x axis: the orientation turns +x onto it."""
    v = [float(c) for c in vector] + [0.0] * (3 - len(vector))
    length = math.sqrt(sum(c * c for c in v))
    if length < 1e-9:
        return None
    head = min(length / 3, 3 * diameter)
    return {
        "pose": pose(tail, _turn_x_onto([c / length for c in v])),
        "shaft_length": round(length - head, DIGITS),
        "shaft_diameter": diameter,
        "head_length": round(head, DIGITS),
        "head_diameter": 2.5 * diameter,
        "color": colour(rgba),
    }


def _turn_x_onto(d: list[float]) -> Json:
    """The unit quaternion turning (1, 0, 0) onto the unit vector d: half-way between them."""
    w, x, y, z = 1.0 + d[0], 0.0, -d[2], d[1]  # (1 + x·d, x × d), normalised below
    if w < 1e-9:  # d = -x: half a turn about z
        return {"x": 0.0, "y": 0.0, "z": 1.0, "w": 0.0}
    norm = math.sqrt(w * w + y * y + z * z)
    return {"x": x, "y": round(y / norm, 6), "z": round(z / norm, 6), "w": round(w / norm, 6)}


def scene_update(entities: list[Json]) -> Json:
    return {"deletions": [], "entities": entities}


def frame_transforms(
    ns: int,
    frames: Iterable[tuple[str, Json]],
    parent: str = "world",
    rotations: Sequence[Json] = (),
) -> Json:
    """foxglove.FrameTransforms: each child frame at a position, turned by its entry of
    ``rotations`` (a unicycle's heading, :func:`yaw`) or, where there is none, not at all
    (single integrators are points, with no attitude)."""
    return {
        "transforms": [
            {
                "timestamp": stamp(ns),
                "parent_frame_id": parent,
                "child_frame_id": child,
                "translation": p,
                "rotation": rotations[k] if k < len(rotations) else IDENTITY,
            }
            for k, (child, p) in enumerate(frames)
        ]
    }


def yaw(theta: float) -> Json:
    """The unit quaternion of a turn by ``theta`` rad about z (a unicycle's heading)."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(theta / 2), "w": math.cos(theta / 2)}


def log(ns: int, level: int, message: str, name: str) -> Json:
    """foxglove.Log; level 1 debug, 2 info, 3 warning, 4 error, 5 fatal (shoal's event levels
    are the same numbers)."""
    return {
        "timestamp": stamp(ns),
        "level": level,
        "message": message,
        "name": name,
        "file": "",
        "line": 0,
    }
