"""`shoal export F.mcap --ros2 DIR`: the run as a ROS 2 bag, read back with an independent
decoder (mcap-ros2-support, Foxglove's: it parses the ros2msg schemas the bag carries and
decodes the CDR itself), not with rosbags, which wrote it.

The log is the reference simulator's run written with the logger's own writer, as in
tests/integration/test_foxglove.py: four agents, one standing and two moving obstacles, follower 2
evading, agent 4's process gone from tick 120 on.
"""

from __future__ import annotations

import json
import math
import sys
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from runlogs import GONE_AT, TINY_3D, TINY_PEOPLE, raw_log, reference_log

from shoal.tools.cli import main
from shoal.tools.foxglove.views import RunLog
from shoal.world.metrics import clearances, formation_errors, pair_distances
from shoal.world.trajectory import Trajectory
from shoal.world.unicycle import body_centres, drive, wheel_command

STEP_NS = 20_000_000  # dt = 0.02 s in the TINY scenarios
TICKS = 200
METRICS = ("formation_error", "sigma", "omega", "alive", "filtered", "clearance")
TOPICS = {
    "/shoal/poses": "geometry_msgs/msg/PoseArray",
    "/tf": "tf2_msgs/msg/TFMessage",
    **{f"/agent_{i}/cmd_vel": "geometry_msgs/msg/TwistStamped" for i in range(1, 5)},
    "/shoal/obstacles": "visualization_msgs/msg/MarkerArray",
    "/shoal/graph": "visualization_msgs/msg/MarkerArray",
    **{f"/shoal/metrics/{m}": "std_msgs/msg/Float64" for m in (*METRICS, "distance")},
    **{f"/shoal/metrics/{m}/agents": "std_msgs/msg/Float64MultiArray" for m in METRICS},
}


class Bag:
    """An exported bag, decoded: topic → [(log time, message)] in log-time order."""

    def __init__(self, run: RunLog, raw: Path, path: Path, report: dict[str, Any]) -> None:
        self.run, self.raw, self.path, self.report = run, raw, path, report
        self.records = [r for _ns, r in run.ticks]
        self.messages: dict[str, list[tuple[int, Any]]] = {}
        with (path / f"{path.name}.mcap").open("rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _schema, channel, message, decoded in reader.iter_decoded_messages():
                self.messages.setdefault(channel.topic, []).append((message.log_time, decoded))

    def at_ticks(self, topic: str) -> list[Any]:
        """The messages of ``topic``, checked to be one per tick stamped tick·dt."""
        got = self.messages[topic]
        assert [ns for ns, _m in got] == [r.tick * STEP_NS for r in self.records]
        return [m for _ns, m in got]


def export_bag(tmp: Path, text: str, *, gone: int | None = None) -> Bag:
    run = reference_log(text, gone=gone)
    raw = tmp / "run.mcap"
    raw_log(raw, run)
    out = tmp / "run_bag"
    done = CliRunner().invoke(main, ["export", str(raw), "--ros2", str(out), "--json"])
    assert done.exit_code == 0, done.output
    return Bag(run, raw, out, json.loads(done.output))


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A raw log of TINY_PEOPLE, alone in its folder (the refusal tests' input)."""
    raw = tmp_path_factory.mktemp("log") / "run.mcap"
    raw_log(raw, reference_log(TINY_PEOPLE))
    return raw


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Bag:
    return export_bag(tmp_path_factory.mktemp("ros2"), TINY_PEOPLE, gone=GONE_AT)


def stamp_ns(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


# -- the format -----------------------------------------------------------------------------


def test_the_bag_is_a_rosbag2_directory_of_one_mcap_file_with_cdr_and_ros2msg(bag: Bag) -> None:
    assert sorted(p.name for p in bag.path.iterdir()) == ["metadata.yaml", "run_bag.mcap"]
    assert sorted(p.name for p in bag.path.parent.iterdir()) == ["run.mcap", "run_bag"]  # no .part
    with (bag.path / "run_bag.mcap").open("rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2"
    assert summary is not None and summary.statistics is not None
    stats = summary.statistics
    total = len(TOPICS) * TICKS
    assert stats.message_count == total == bag.report["messages"]
    assert (stats.message_start_time, stats.message_end_time) == (0, (TICKS - 1) * STEP_NS)
    assert {c.topic: c.message_encoding for c in summary.channels.values()} == dict.fromkeys(
        TOPICS, "cdr"
    )
    assert {summary.channels[c].topic: n for c, n in stats.channel_message_counts.items()} == (
        dict.fromkeys(TOPICS, TICKS)
    )
    schemas = {summary.channels[c].topic: summary.schemas[ch.schema_id] for c, ch in
               summary.channels.items()}  # fmt: skip
    assert {t: s.name for t, s in schemas.items()} == TOPICS
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    assert len(summary.schemas) == len(set(TOPICS.values())) == 6
    assert summary.chunk_indexes and all(
        c.compression == "zstd" and c.message_index_offsets for c in summary.chunk_indexes
    )
    indexed = {channel for c in summary.chunk_indexes for channel in c.message_index_offsets}
    assert indexed == set(summary.channels)  # every channel has message indexes


def test_metadata_names_the_storage_the_topics_and_their_counts(bag: Bag) -> None:
    meta = yaml.safe_load((bag.path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["relative_file_paths"] == ["run_bag.mcap"]
    assert meta["message_count"] == len(TOPICS) * TICKS
    assert meta["starting_time"]["nanoseconds_since_epoch"] == 0
    assert meta["duration"]["nanoseconds"] == (TICKS - 1) * STEP_NS
    topics = {t["topic_metadata"]["name"]: t for t in meta["topics_with_message_count"]}
    assert {name: t["topic_metadata"]["type"] for name, t in topics.items()} == TOPICS
    assert {name: t["message_count"] for name, t in topics.items()} == dict.fromkeys(TOPICS, TICKS)
    assert {t["topic_metadata"]["serialization_format"] for t in topics.values()} == {"cdr"}
    assert bag.report["topics"] == dict.fromkeys(TOPICS, TICKS)
    custom = meta["custom_data"]
    assert custom["shoal.source"] == "run.mcap" and custom["shoal.run"] == "fox-1"
    assert custom["shoal.scenario"] == "tinypeople" and custom["shoal.dt_s"] == "0.02"


# -- what the messages say --------------------------------------------------------------------


def test_poses_and_transforms_are_the_logs_positions_exactly(bag: Bag) -> None:
    poses, tfs = bag.at_ticks("/shoal/poses"), bag.at_ticks("/tf")
    for r, pose_array, tf in zip(bag.records, poses, tfs, strict=True):
        assert pose_array.header.frame_id == "world"
        assert stamp_ns(pose_array.header) == r.tick * STEP_NS
        got = [(p.position.x, p.position.y, p.position.z) for p in pose_array.poses]
        assert got == [(x, y, 0.0) for x, y in r.positions]  # float64, bit for bit
        assert {(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)
                for p in pose_array.poses} == {(0.0, 0.0, 0.0, 1.0)}  # fmt: skip
        assert [(t.header.frame_id, t.child_frame_id) for t in tf.transforms] == [
            ("world", f"agent_{i}") for i in range(1, 5)
        ]
        assert {stamp_ns(t.header) for t in tf.transforms} == {r.tick * STEP_NS}
        moved = [(t.transform.translation.x, t.transform.translation.y) for t in tf.transforms]
        assert moved == list(r.positions)
    held = [p.poses[3].position for p in poses[GONE_AT:]]
    assert len({(p.x, p.y) for p in held}) == 1  # agent 4 gone: held still
    assert len({(p.poses[0].position.x) for p in poses}) == TICKS  # the leader moves every tick


def test_commands_are_the_velocities_the_world_applied(bag: Bag) -> None:
    for i in range(4):
        twists = bag.at_ticks(f"/agent_{i + 1}/cmd_vel")
        for r, t in zip(bag.records, twists, strict=True):
            assert t.header.frame_id == f"agent_{i + 1}"
            assert stamp_ns(t.header) == r.tick * STEP_NS
            assert (t.twist.linear.x, t.twist.linear.y, t.twist.linear.z) == (*r.velocities[i], 0.0)
            assert (t.twist.angular.x, t.twist.angular.y, t.twist.angular.z) == (0.0, 0.0, 0.0)
    last = bag.at_ticks("/agent_4/cmd_vel")[-1].twist.linear
    assert (last.x, last.y) == (0.0, 0.0)  # gone


def test_one_marker_per_obstacle_at_its_centre_moving_ones_where_they_are(bag: Bag) -> None:
    s = bag.run.scenario
    assert s.standing_ids == (0,) and s.mover_ids == (1, 2)
    start_y = None
    for r, array in zip(bag.records, bag.at_ticks("/shoal/obstacles"), strict=True):
        markers = array.markers
        assert [(m.ns, m.id, m.type, m.action) for m in markers] == [
            ("obstacles", k, 3, 0)
            for k in range(3)  # CYLINDER, ADD
        ]
        centres = [(m.pose.position.x, m.pose.position.y, m.pose.position.z) for m in markers]
        assert centres == [(*s.obstacles[0].centre, 0.0), *((*c, 0.0) for c in r.mover_centres)]
        assert [(m.scale.x, m.scale.y, m.scale.z) for m in markers] == [
            (2 * o.radius, 2 * o.radius, 1.0) for o in s.obstacles
        ]
        assert {m.header.frame_id for m in markers} == {"world"}
        assert {stamp_ns(m.header) for m in markers} == {r.tick * STEP_NS}
        start_y = markers[1].pose.position.y if start_y is None else start_y
    assert start_y == 3.0 and centres[1][1] < 3.0  # mover 1 walked from (4, 3) towards (4, -3)


def test_graph_edges_are_followed_dropped_or_gone_as_the_records_say(bag: Bag) -> None:
    arrays = bag.at_ticks("/shoal/graph")
    states = []
    for r, array in zip(bag.records, arrays, strict=True):
        assert [(m.ns, m.id, m.type) for m in array.markers] == [("edges", k, 5) for k in range(3)]
        followed = array.markers[0]
        ends = {(round(p.x, 4), round(p.y, 4)) for p in followed.points}
        assert ends <= {(round(x, 4), round(y, 4)) for x, y in r.positions}
        states.append(tuple(m.action for m in array.markers))  # 0 ADD, 2 DELETE (no edge)
        assert len(followed.points) == 2 * len([e for e in followed.text.split(", ") if e])
    evading = [k for k, r in enumerate(bag.records) if r.omega[1] and r.alive[3]]
    assert evading and all(states[k][1] == 0 for k in evading)  # agent 2's edges dropped
    assert "2-3 (agent 2 evades)" in arrays[evading[0]].markers[1].text
    assert states[0] == (0, 2, 2)  # at the start every edge is followed
    assert states[-1][2] == 0 and "agent 4 gone" in arrays[-1].markers[2].text


def test_metrics_are_world_metrics_of_the_records_exactly(bag: Bag) -> None:
    s, records = bag.run.scenario, bag.records
    traj = Trajectory.from_records(records, s.dt)
    errors = formation_errors(s, traj)  # (T, n-1)
    clear = clearances(s, traj)[:-1].min(axis=2)  # (T, n)

    def values(name: str) -> list[float]:
        return [m.data for m in bag.at_ticks(f"/shoal/metrics/{name}")]

    def rows(name: str) -> list[list[float]]:
        got = bag.at_ticks(f"/shoal/metrics/{name}/agents")
        assert {(m.layout.dim[0].label, m.layout.dim[0].size) for m in got} == {("agent", 4)}
        return [list(m.data) for m in got]

    assert values("formation_error") == errors.max(axis=1).tolist()
    assert rows("formation_error") == [[0.0, *e] for e in errors.tolist()]
    assert values("distance") == pair_distances(traj)[:-1].min(axis=1).tolist()
    assert values("clearance") == clear.min(axis=1).tolist()
    assert rows("clearance") == clear.tolist()
    assert values("sigma") == [max(r.sigma) for r in records]
    assert rows("sigma") == [list(r.sigma) for r in records]
    assert values("omega") == [float(sum(r.omega)) for r in records]
    assert rows("omega") == [[float(w) for w in r.omega] for r in records]
    assert values("alive") == [4.0] * GONE_AT + [3.0] * (TICKS - GONE_AT)
    assert values("filtered") == [float(sum(r.filtered)) for r in records]
    assert max(values("omega")) == 1.0 and max(values("sigma")) == 1.5  # evasion, reshape
    assert errors[-1].max() == values("formation_error")[-1] > 0.0


def test_a_3d_run_has_sphere_obstacles_and_z(tmp_path: Path) -> None:
    bag = export_bag(tmp_path, TINY_3D)
    s = bag.run.scenario
    poses = bag.at_ticks("/shoal/poses")
    assert [[(p.position.x, p.position.y, p.position.z) for p in a.poses] for a in poses] == [
        list(r.positions) for r in bag.records
    ]
    (obstacle,) = bag.at_ticks("/shoal/obstacles")[-1].markers
    assert obstacle.type == 2  # SPHERE
    assert (obstacle.pose.position.x, obstacle.pose.position.y, obstacle.pose.position.z) == (
        s.obstacles[0].centre
    )
    assert (obstacle.scale.x, obstacle.scale.y, obstacle.scale.z) == (1.0, 1.0, 1.0)
    assert bag.report["ticks"] == TICKS


def test_a_unicycle_is_a_robot_at_its_axle_facing_its_heading_driven_by_v_and_omega(
    tmp_path: Path,
) -> None:
    """For unicycles the bag speaks as a ROS robot would: poses and frames at the axle turned
    by the heading, and cmd_vel the (v, ω) the world held, in the robot's frame; driving each
    record's bodies with those commands for a tick reaches the next record."""
    text = resources.files("shoal.world.scenarios").joinpath("robotarium.yaml").read_text()
    bag = export_bag(tmp_path, text.replace("duration: 75.0", "duration: 3.3"))
    s = bag.run.scenario
    ell = s.lookahead or 0.0
    poses = [m for _ns, m in bag.messages["/shoal/poses"]]
    commands = [[m.twist for _ns, m in bag.messages[f"/agent_{i}/cmd_vel"]] for i in (1, 2, 3)]
    assert len(poses) == len(bag.records) == 100
    for k, (r, pose_array) in enumerate(zip(bag.records, poses, strict=True)):
        points, headings = np.array(r.positions), np.array(r.headings)
        axles = body_centres(points, headings, ell)
        assert [(p.position.x, p.position.y) for p in pose_array.poses] == [
            tuple(c) for c in axles.tolist()
        ]
        for p, theta in zip(pose_array.poses, headings, strict=True):
            assert (p.orientation.z, p.orientation.w) == (
                math.sin(theta / 2), math.cos(theta / 2)
            )  # fmt: skip
        v, w = wheel_command(np.array(r.velocities), headings, ell, s.dt)
        for i in range(3):
            twist = commands[i][k]
            assert (twist.linear.x, twist.angular.z) == (v[i], w[i])
            assert (twist.linear.y, twist.angular.x, twist.angular.y) == (0.0, 0.0, 0.0)
        if k + 1 < len(bag.records):
            after, _ = drive(points, headings, v, w, ell, s.dt)
            assert after == pytest.approx(np.array(bag.records[k + 1].positions), abs=1e-12)


def test_a_mixed_formations_single_integrators_are_driven_by_their_velocity(
    tmp_path: Path,
) -> None:
    """Followers 2 and 5 holonomic among GRITSbots: their poses sit unturned at their points
    and their cmd_vel is the velocity the world applied; the unicycles keep their (v, ω)."""
    text = resources.files("shoal.world.scenarios").joinpath("robotarium.yaml").read_text()
    text = text.replace("duration: 75.0", "duration: 1.0")
    for offset in ("[-0.4, 0.4]}", "[-0.8, -0.8]}"):
        text = text.replace(offset, offset[:-1] + ", kinematics: single}")
    bag = export_bag(tmp_path, text)
    s = bag.run.scenario
    assert s.lookaheads is not None and s.lookaheads.tolist() == [0.05, 0.0, 0.05, 0.05, 0.0]
    poses = [m for _ns, m in bag.messages["/shoal/poses"]]
    commands = {i: [m.twist for _ns, m in bag.messages[f"/agent_{i}/cmd_vel"]] for i in (1, 2, 5)}
    for k, (r, pose_array) in enumerate(zip(bag.records, poses, strict=True)):
        for i in (1, 4):  # followers 2 and 5
            p = pose_array.poses[i]
            assert (p.position.x, p.position.y) == tuple(r.positions[i])
            assert (p.orientation.z, p.orientation.w) == (0.0, 1.0)
            twist = commands[i + 1][k]
            assert (twist.linear.x, twist.linear.y) == tuple(r.velocities[i])
            assert twist.angular.z == 0.0
        v, w = wheel_command(np.array(r.velocities[:1]), np.array(r.headings[:1]), 0.05, s.dt)
        assert (commands[1][k].linear.x, commands[1][k].angular.z) == (v[0], w[0])


# -- refusals -----------------------------------------------------------------------------------


def test_an_existing_dir_is_replaced_only_with_force_and_only_if_it_is_a_bag(
    log: Path, tmp_path: Path
) -> None:
    raw = log
    out = tmp_path / "bag"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    taken = CliRunner().invoke(main, ["export", str(raw), "--ros2", str(out)])
    assert taken.exit_code == 1
    assert taken.output == f"Error: {out} exists; pass --force to replace it\n"
    forced = CliRunner().invoke(main, ["export", str(raw), "--ros2", str(out), "--force"])
    assert forced.exit_code == 1 and "is not a rosbag2 directory; not replacing it" in forced.output
    assert [p.name for p in out.iterdir()] == ["notes.txt"]  # untouched

    other = tmp_path / "bag2"
    first = CliRunner().invoke(main, ["export", str(raw), "--ros2", str(other)])
    assert first.exit_code == 0 and "21 topics, 4200 messages from 200 tick records" in first.output
    (other / "metadata.yaml").write_text("old")
    again = CliRunner().invoke(main, ["export", str(raw), "--ros2", str(other), "--force"])
    assert again.exit_code == 0, again.output
    assert "rosbag2_bagfile_information" in (other / "metadata.yaml").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "bag2"]  # no .part left

    views_option = CliRunner().invoke(main, ["export", str(raw), "--ros2", "x", "-o", "y.mcap"])
    assert views_option.exit_code == 2 and "--out: for the Foxglove views" in views_option.output


def test_a_truncated_or_garbage_log_is_a_one_line_error_and_leaves_nothing(
    log: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[: log.stat().st_size // 2])
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"not an mcap file at all\n" * 40)
    for path, why in ((cut, "shoal recover"), (garbage, "garbage.mcap")):
        done = CliRunner().invoke(main, ["export", str(path), "--ros2", str(tmp_path / "bag")])
        assert done.exit_code == 1, done.output
        assert done.output.startswith("Error: ") and done.output.count("\n") == 1
        assert why in done.output and "Traceback" not in done.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap", "garbage.mcap"]


def test_without_rosbags_it_says_how_to_install_it(
    log: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    raw = log
    for module in [m for m in sys.modules if m == "rosbags" or m.startswith("rosbags.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "rosbags", None)  # import rosbags… raises ImportError
    done = CliRunner().invoke(main, ["export", str(raw), "--ros2", str(tmp_path / "bag")])
    assert done.exit_code == 1 and isinstance(done.exception, SystemExit)
    assert "--ros2 needs the rosbags package" in done.output
    assert "install it with: pip install 'shoal[ros2]'" in done.output
    assert list(tmp_path.iterdir()) == []
