"""Tick records as ROS 2 messages of standard types (rosbags' classes for ROS 2 Jazzy).

Every message of tick k is stamped with the tick's simulated time, k·dt in ns from the start of
the run: the header stamps and the bag's log times agree on every topic. Positions and commands
are the log's float64 values, exactly; a 2-D run lies in the plane z = 0. The frames are
Foxglove's (tools/foxglove/scene.py): ``world``, and ``agent_<i>`` at agent i, not rotated (the
agents are points: single integrators have no attitude). A unicycle is a ROS robot instead:
``agent_<i>`` is its body frame, at the axle and turned by its heading (the point the laws move
is l ahead on its x axis). Topics (docs/ros2.md):

- ``/shoal/poses`` geometry_msgs/msg/PoseArray in ``world``: every agent in id order (a
  unicycle: its axle and heading);
- ``/tf`` tf2_msgs/msg/TFMessage: ``world`` → ``agent_<i>`` for every agent;
- ``/agent_<i>/cmd_vel`` geometry_msgs/msg/TwistStamped in ``agent_<i>``: the velocity the world
  applied to agent i during the tick (m/s, world axes: the agent's frame is not rotated); a
  unicycle's (v, ω) held over the tick, as linear.x (m/s) and angular.z (rad/s) in its frame;
- ``/shoal/obstacles`` visualization_msgs/msg/MarkerArray: one marker per obstacle (standing and
  moving, ns ``obstacles``, id = its 0-based index in the scenario) at its centre;
- ``/shoal/graph`` visualization_msgs/msg/MarkerArray: the sensing graph's edges, as Foxglove's
  graph layer derives them (followed, dropped while the other end evades, gone);
- ``/shoal/metrics/<name>`` std_msgs/msg/Float64 and ``/shoal/metrics/<name>/agents``
  std_msgs/msg/Float64MultiArray (data[i] is agent i + 1): tools/rosbag/metrics.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol, cast

import numpy as np
from rosbags.typesys.stores import ros2_jazzy as ros

from shoal.bus.messages import TickRecord
from shoal.geometry.vectors import FloatArray
from shoal.tools.foxglove.msgs import RGBA, vec3s, yaw
from shoal.tools.foxglove.scene import EDGE, MOVER, OBSTACLE, PILLAR_M, Layers, frame
from shoal.tools.foxglove.views import BLOCK, RunLog
from shoal.tools.rosbag.metrics import Metrics, metrics
from shoal.world.scenario import Scenario
from shoal.world.unicycle import body_centres, wheel_command

# The types, by their ROS names (rosbags names a class after its full type name).
Duration = ros.builtin_interfaces__msg__Duration
Time = ros.builtin_interfaces__msg__Time
Point = ros.geometry_msgs__msg__Point
Pose = ros.geometry_msgs__msg__Pose
PoseArray = ros.geometry_msgs__msg__PoseArray
Quaternion = ros.geometry_msgs__msg__Quaternion
Transform = ros.geometry_msgs__msg__Transform
TransformStamped = ros.geometry_msgs__msg__TransformStamped
Twist = ros.geometry_msgs__msg__Twist
TwistStamped = ros.geometry_msgs__msg__TwistStamped
Vector3 = ros.geometry_msgs__msg__Vector3
CompressedImage = ros.sensor_msgs__msg__CompressedImage
ColorRGBA = ros.std_msgs__msg__ColorRGBA
Float64 = ros.std_msgs__msg__Float64
Float64MultiArray = ros.std_msgs__msg__Float64MultiArray
Header = ros.std_msgs__msg__Header
MultiArrayDimension = ros.std_msgs__msg__MultiArrayDimension
MultiArrayLayout = ros.std_msgs__msg__MultiArrayLayout
TFMessage = ros.tf2_msgs__msg__TFMessage
Marker = ros.visualization_msgs__msg__Marker
MarkerArray = ros.visualization_msgs__msg__MarkerArray
MeshFile = ros.visualization_msgs__msg__MeshFile

WORLD = "world"
POSES = "/shoal/poses"
TF = "/tf"
OBSTACLES = "/shoal/obstacles"
GRAPH = "/shoal/graph"
METRICS = "/shoal/metrics"
NO_BYTES = np.zeros(0, dtype=np.uint8)
IDENTITY = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
FOREVER = Duration(sec=0, nanosec=0)  # a marker's lifetime: until replaced


class RosMessage(Protocol):
    __msgtype__: ClassVar[str]


@dataclass(frozen=True, slots=True)
class Message:
    topic: str
    ns: int  # the bag's log time and the header stamp: simulated time of the tick, ns
    message: RosMessage

    @property
    def msgtype(self) -> str:
        return self.message.__msgtype__


def cmd_vel(agent_id: int) -> str:
    """Agent ``agent_id``'s command topic."""
    return f"/agent_{agent_id}/cmd_vel"


def tick_ns(scenario: Scenario) -> int:
    """ns per tick: dt rounded to whole nanoseconds (exact for every dt of a few digits), so a
    tick's stamp is an exact multiple and every topic of a tick carries the same one."""
    return round(scenario.dt * 1e9)


def messages(run: RunLog, progress: Callable[[int], None] | None = None) -> Iterator[Message]:
    """Every message of the bag in time order; ``progress(k)`` after the k-th record (0-based)."""
    s = run.scenario
    step = tick_ns(s)
    layers = Layers(s)
    records = [r for _ns, r in run.ticks]
    for start in range(0, len(records), BLOCK):
        block = records[start : start + BLOCK]
        m = metrics(s, block)
        for j, r in enumerate(block):
            ns = r.tick * step
            yield from _tick(s, layers, ns, r, m, j)
            if progress is not None:
                progress(start + j)


def _tick(
    s: Scenario, layers: Layers, ns: int, r: TickRecord, m: Metrics, j: int
) -> Iterator[Message]:
    world = header(ns, WORLD)
    ells = s.lookaheads
    if ells is not None and len(r.headings) == s.n:
        yield from _unicycles(s, ns, r, world, ells)
    else:
        points = [_point(p) for p in r.positions]
        yield Message(POSES, ns, PoseArray(header=world, poses=[_pose(p) for p in points]))
        yield Message(TF, ns, TFMessage(transforms=_transforms(world, points)))
        for i, v in enumerate(r.velocities):
            twist = Twist(linear=_vector(v), angular=Vector3(x=0.0, y=0.0, z=0.0))
            yield Message(
                cmd_vel(i + 1), ns, TwistStamped(header=header(ns, frame(i + 1)), twist=twist)
            )
    if s.obstacles:
        yield Message(OBSTACLES, ns, marker_array(_obstacles(s, world, r)))
    if s.edges:
        yield Message(GRAPH, ns, marker_array(_edges(layers, world, ns, r)))
    yield from _metrics(ns, m, j)


def header(ns: int, frame_id: str) -> Header:
    return Header(
        stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=frame_id
    )


def _point(p: Sequence[float]) -> Point:
    return Point(x=p[0], y=p[1], z=p[2] if len(p) > 2 else 0.0)


def _vector(v: Sequence[float]) -> Vector3:
    return Vector3(x=v[0], y=v[1], z=v[2] if len(v) > 2 else 0.0)


def _pose(p: Point, orientation: Quaternion = IDENTITY) -> Pose:
    return Pose(position=p, orientation=orientation)


def _transforms(
    world: Header, points: list[Point], turns: Sequence[Quaternion] = ()
) -> list[TransformStamped]:
    return [
        TransformStamped(
            header=world,
            child_frame_id=frame(i + 1),
            transform=Transform(
                translation=Vector3(x=p.x, y=p.y, z=p.z),
                rotation=turns[i] if i < len(turns) else IDENTITY,
            ),
        )
        for i, p in enumerate(points)
    ]


def _unicycles(
    s: Scenario, ns: int, r: TickRecord, world: Header, ells: FloatArray
) -> Iterator[Message]:
    """A unicycle as a ROS robot: its pose and frame at the axle, x along its heading (the point
    the laws move is l ahead on that axis), and the (v, ω) the world held over the tick as the
    command in its own frame (world/unicycle.py). A single integrator of a mixed formation
    (l = 0) as elsewhere: its pose unturned at its point, its velocity as the command."""
    points = np.asarray(r.positions, dtype=np.float64)
    headings = np.asarray(r.headings, dtype=np.float64)
    velocities = np.asarray(r.velocities, dtype=np.float64)
    axles = [_point(c) for c in body_centres(points, headings, ells).tolist()]
    turns = [Quaternion(**yaw(float(h))) if ell > 0 else IDENTITY
             for h, ell in zip(headings, ells, strict=True)]  # fmt: skip
    poses = [_pose(c, q) for c, q in zip(axles, turns, strict=True)]
    yield Message(POSES, ns, PoseArray(header=world, poses=poses))
    yield Message(TF, ns, TFMessage(transforms=_transforms(world, axles, turns)))
    speeds, rates = wheel_command(velocities, headings, ells, s.dt)
    for i, (v, w) in enumerate(zip(speeds.tolist(), rates.tolist(), strict=True)):
        if ells[i] > 0:
            twist = Twist(linear=Vector3(x=v, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=w))
        else:
            twist = Twist(linear=_vector(velocities[i]), angular=Vector3(x=0.0, y=0.0, z=0.0))
        yield Message(
            cmd_vel(i + 1), ns, TwistStamped(header=header(ns, frame(i + 1)), twist=twist)
        )


def _obstacles(s: Scenario, world: Header, r: TickRecord) -> list[Marker]:
    """A body per obstacle at its centre: an upright cylinder PILLAR_M high in 2-D, a sphere in
    3-D; standing ones brown, moving ones (at their centre this tick) purple."""
    where = dict(zip(s.mover_ids, r.mover_centres, strict=True))
    out = []
    for k, o in enumerate(s.obstacles):
        moving = k in where
        d = 2 * o.radius
        out.append(
            marker(
                world,
                "obstacles",
                k,
                Marker.SPHERE if s.dim == 3 else Marker.CYLINDER,
                pose=_pose(_point(where[k] if moving else o.centre)),
                scale=Vector3(x=d, y=d, z=d if s.dim == 3 else PILLAR_M),
                rgba=MOVER if moving else OBSTACLE,
            )
        )
    return out


def _edges(layers: Layers, world: Header, ns: int, r: TickRecord) -> list[Marker]:
    """The graph layer of the Foxglove views (tools/foxglove/scene.py), as LINE_LIST markers
    ``edges`` 0 followed, 1 dropped, 2 gone; an empty group is a DELETE of its id (RViz warns of
    a line list without points). Points rounded to 0.1 mm, as in the views."""
    update = layers.graph(ns, r, vec3s(r.positions))
    width = layers.scenario.agent_radius  # m: RViz draws line widths in metres
    out = []
    for k, entity in enumerate(update["entities"]):
        (line,) = entity["lines"]
        points = [Point(x=p["x"], y=p["y"], z=p["z"]) for p in line["points"]]
        c = line["color"]
        out.append(
            marker(
                world,
                "edges",
                k,
                Marker.LINE_LIST,
                action=Marker.ADD if points else Marker.DELETE,
                scale=Vector3(x=width, y=0.0, z=0.0),
                rgba=(c["r"], c["g"], c["b"], c["a"]) if points else EDGE,
                points=points,
                text=next(kv["value"] for kv in entity["metadata"] if kv["key"] == "edges"),
            )
        )
    return out


def marker_array(markers: list[Marker]) -> MarkerArray:
    # rosbags' Jazzy store reuses an older MarkerArray class, annotated with the older Marker
    # (without texture and mesh fields); the serializer goes by type name, so Jazzy's is used.
    return MarkerArray(markers=cast("list[Any]", markers))


def marker(
    world: Header,
    ns: str,
    marker_id: int,
    kind: int,
    *,
    rgba: RGBA,
    scale: Vector3,
    pose: Pose | None = None,
    action: int = Marker.ADD,
    points: Sequence[Point] = (),
    text: str = "",
) -> Marker:
    """A visualization_msgs Marker with every field of the type filled (no texture, no mesh)."""
    r, g, b, a = rgba
    return Marker(
        header=world,
        ns=ns,
        id=marker_id,
        type=kind,
        action=action,
        pose=pose or _pose(Point(x=0.0, y=0.0, z=0.0)),
        scale=scale,
        color=ColorRGBA(r=r, g=g, b=b, a=a),
        lifetime=FOREVER,
        frame_locked=False,
        points=list(points),
        colors=[],
        texture_resource="",
        texture=CompressedImage(header=world, format="", data=NO_BYTES),
        uv_coordinates=[],
        text=text,
        mesh_resource="",
        mesh_file=MeshFile(filename="", data=NO_BYTES),
        mesh_use_embedded_materials=False,
    )


def _metrics(ns: int, m: Metrics, j: int) -> Iterator[Message]:
    """Headline values (Float64) and per-agent rows (Float64MultiArray)."""
    rows: dict[str, tuple[float, Any]] = {
        "formation_error": (float(m.formation_error[j].max()), m.formation_error[j]),
        "sigma": (float(m.sigma[j].max()), m.sigma[j]),
        "omega": (float(m.omega[j].sum()), m.omega[j]),
        "alive": (float(m.alive[j].sum()), m.alive[j]),
        "filtered": (float(m.filtered[j].sum()), m.filtered[j]),
    }
    if m.clearance is not None:
        rows["clearance"] = (float(m.clearance[j].min()), m.clearance[j])
    if not math.isnan(m.distance[j]):
        rows["distance"] = (float(m.distance[j]), None)
    for name, (value, per_agent) in rows.items():
        yield Message(f"{METRICS}/{name}", ns, Float64(data=value))
        if per_agent is not None:
            yield Message(f"{METRICS}/{name}/agents", ns, _row(per_agent))


def _row(values: Any) -> Float64MultiArray:
    data = np.array(values, dtype=np.float64)
    dim = MultiArrayDimension(label="agent", size=len(data), stride=len(data))
    return Float64MultiArray(layout=MultiArrayLayout(dim=[dim], data_offset=0), data=data)
