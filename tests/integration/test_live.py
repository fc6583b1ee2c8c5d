"""The live view (``shoal run --live``, ``shoal replay --live``): the export's views, served
while the run runs or replays.

The stream builder is checked against the export message for message, and the live view's
decimation of the metrics to the wall clock on a clock of the test's own; the whole thing with
Foxglove's own WebSocket client (npm @foxglove/ws-protocol, tests/live/client.mjs) against a
real ``shoal run`` and a ``shoal replay`` of a log, whose positions and metrics must be the log's
and the exported file's.
"""

from __future__ import annotations

import itertools
import json
import shutil
import socket
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import PYTHON, ROOT, run_cli, stop
from mcap.reader import make_reader
from runlogs import GONE_AT, LOG_STEP, TINY, TINY_PEOPLE, raw_log, reference_log

from shoal.bus import codec
from shoal.tools.foxglove import stream as stream_module
from shoal.tools.foxglove.export import sibling
from shoal.tools.foxglove.live import BACKLOG, PLOT_RATE, LiveView
from shoal.tools.foxglove.plots import FILTER, TRACKING, plots
from shoal.tools.foxglove.plots import TOPICS as METRICS
from shoal.tools.foxglove.stream import Stream
from shoal.tools.foxglove.views import (
    AGENTS,
    FRAMES,
    LOG,
    SENSING,
    TOPICS,
    RunLog,
    View,
    ViewOptions,
    every,
    views,
)
from shoal.tools.log.reader import read_ticks, read_trajectory
from shoal.tools.procs.launch import free_port
from shoal.world.loader import load_scenario

CLIENT = ROOT / "tests" / "live"


def streamed(run: RunLog, options: ViewOptions) -> list[View]:
    """A Stream fed ``run`` record by record, asked for the scene and trails at the ticks the
    export draws them (the live server asks by the wall clock instead)."""
    s = Stream(run.scenario, run.start_ns, options)
    dt = run.scenario.dt
    scene, trail = every(options.scene_hz, dt), every(options.trail_hz, dt)
    events = list(run.events)
    out = s.static()
    for k, (ns, r) in enumerate(run.ticks):
        while events and events[0][0] <= ns:
            out.append(s.event(*events.pop(0)))
        out += s.take(ns, r)
        final = k == len(run.ticks) - 1
        if r.tick % scene == 0 or k == 0 or final:
            out += s.scene()
        if r.tick % trail == 0 or final:
            out += s.trails()
        out += s.metrics(final=final)
    return out + [s.event(*e) for e in events]


def keyed(msgs: list[View]) -> list[tuple[str, int, str]]:
    """Order-free comparable form (the sensing layer is stamped with the run's start here and
    with the first record in the export: left out)."""
    return sorted((v.topic, v.ns, json.dumps(v.message)) for v in msgs if v.topic != SENSING)


CROSSING = load_scenario("crossing").source  # people walk at it: the filter acts


@pytest.mark.parametrize("text, gone", [(TINY, GONE_AT), (TINY_PEOPLE, None), (CROSSING, None)])
def test_the_stream_builds_the_exports_messages(text: str, gone: int | None) -> None:
    """Every message but the tracking metric, which only the export has: a tick's achieved
    velocity needs the next tick's positions, which a live view has not had yet."""
    run = reference_log(text, gone=gone)
    options = ViewOptions(scene_hz=10.0, plot_hz=20.0)
    exported = [v for v in views(run, options) if v.topic != TRACKING]
    live = streamed(run, options)
    assert len(live) == len(exported) > 600
    assert keyed(live) == keyed(exported)
    assert {v.topic for v in live} == {v.topic for v in exported}


def test_the_monitor_never_waits_for_the_publisher() -> None:
    """tick() only queues: a publisher that does not keep up loses the oldest records."""
    run = reference_log(TINY)
    view = LiveView(run.scenario, "unit", port=0)  # never entered: nothing drains the queue
    payload = codec.encode_tick(run.ticks[0][1])
    for k in range(BACKLOG + 100):
        view.tick(k, payload)
    assert (view.dropped, len(view._queue), view._queue[0][1]) == (100, BACKLOG, 100)


def test_without_a_viewer_nothing_is_published_and_every_record_is_taken() -> None:
    run = reference_log(TINY)
    with LiveView(run.scenario, "unit", port=0) as view:
        assert view.url == f"ws://127.0.0.1:{view.port}" and view.port > 0
        for ns, r in run.ticks:
            view.tick(ns, codec.encode_tick(r))
        view.tick(0, b"not a record")
    assert view.published == 0 and view.skipped == 1 and view.dropped == 0
    assert view.stream.latest is not None and view.stream.latest.record == run.ticks[-1][1]
    assert view.stream.due == []  # nobody plots: the metrics were never computed
    assert view.wait_for_viewer(timeout=0.3) is False


def test_a_run_that_starts_again_starts_its_views_again() -> None:
    """shoal replay --loop hands over tick 0 again after the last tick: trails start afresh."""
    run = reference_log(TINY)
    payloads = [codec.encode_tick(r) for _ns, r in run.ticks]
    with LiveView(run.scenario, "unit", port=0) as view:
        for k, payload in enumerate(payloads):
            view.tick(k, payload)
        first = view.stream
        for k, payload in enumerate(payloads[:30]):
            view.tick(1000 + k, payload)
    assert view.stream is not first and first.latest is not None
    assert first.latest.record.tick == 199 and [len(h) for h in first.history] == [17] * 4
    assert view.stream.latest is not None and view.stream.latest.record.tick == 29
    assert [len(h) for h in view.stream.history] == [3] * 4  # ticks 0, 12, 24: 0.25 s apart
    assert view.stream.start_ns == 1000 and view.skipped == view.dropped == 0


class _Recording(LiveView):
    """A live view whose metric messages are kept as they go out (no server needed)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.sent: dict[str, list[View]] = defaultdict(list)
        self._subs._count.update(dict.fromkeys(METRICS, 1))  # as if a client plotted them all

    def _publish(self, views: list[View]) -> None:
        for v in views:
            if v.topic in METRICS and v.topic in self._channels:
                self.sent[v.topic].append(v)
        super()._publish(views)


def _plotted(
    run: RunLog, apart_ns: int, cycle_ns: int, monkeypatch: pytest.MonkeyPatch
) -> tuple[_Recording, float, int]:
    """The live view's builder driven by hand on a clock of its own (no thread): ``run``'s
    records arriving ``apart_ns`` apart from the view's start, a cycle every ``cycle_ns``, then
    the final one. Returns the view, the seconds from its start to the last record, and how
    many records the metrics were computed for."""
    computed = [0]

    def counted(scenario: Any, records: Any) -> Any:
        computed[0] += len(records)
        return plots(scenario, records)

    monkeypatch.setattr(stream_module, "plots", counted)
    view = _Recording(run.scenario, "unit", port=0, plot_rate=PLOT_RATE)
    start = view.stream.start_ns
    cycle = start + cycle_ns
    for k, (_ns, r) in enumerate(run.ticks):
        ns = start + (k + 1) * apart_ns
        while cycle <= ns:
            view._cycle()
            cycle += cycle_ns
        view.tick(ns, codec.encode_tick(r))
    view._cycle(final=True)
    return view, len(run.ticks) * apart_ns / 1e9, computed[0]


def _exported(run: RunLog) -> dict[str, dict[int, dict[str, Any]]]:
    out: dict[str, dict[int, dict[str, Any]]] = defaultdict(dict)
    for v in views(run):
        if v.topic in METRICS:
            out[v.topic][v.message["tick"]] = v.message
    return out


@pytest.mark.parametrize("text", [TINY_PEOPLE, CROSSING])
def test_a_fast_run_is_plotted_at_most_plot_rate_times_a_second(
    text: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """500 ticks/s, cycles at 30/s: of every 1/PLOT_RATE s of wall clock, the latest tick's
    messages go out (they are the export's of that tick), the ticks between are never computed,
    and the run's last tick goes out at the end."""
    run = reference_log(text)
    view, elapsed, computed = _plotted(run, 2_000_000, 33_333_333, monkeypatch)
    exported, last = _exported(run), run.ticks[-1][1].tick
    assert set(view.sent) == set(exported)  # every topic the run has
    for topic, sent in view.sent.items():
        ticks = [v.message["tick"] for v in sent]
        assert all(a < b for a, b in itertools.pairwise(ticks)) and ticks[-1] == last, topic
        assert all(v.message == exported[topic][v.message["tick"]] for v in sent), topic
        # One per 1/PLOT_RATE s slot (PLOT_RATE × elapsed + 1 slots at most), and the run's
        # last tick, which may share its slot with an earlier one.
        assert PLOT_RATE * elapsed - 1 <= len(ticks) <= PLOT_RATE * elapsed + 2, (topic, ticks)
        assert computed == len(ticks)  # the ticks left out were never computed
    assert view.dropped == view.skipped == 0


@pytest.mark.parametrize("cycle_ms", [33, 200])  # the builder at its pace, and lagging behind
def test_a_run_slower_than_plot_rate_has_every_tick_plotted(
    cycle_ms: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """20 ticks/s (realtime at dt 0.05) is under PLOT_RATE: every tick goes out, as exported,
    however many of them one cycle finds waiting."""
    run = reference_log(TINY_PEOPLE)
    view, _elapsed, computed = _plotted(run, 50_000_000, cycle_ms * 1_000_000, monkeypatch)
    exported = _exported(run)
    assert set(view.sent) == set(exported)
    for topic, sent in view.sent.items():
        assert [v.message for v in sent] == [exported[topic][r.tick] for _ns, r in run.ticks]
    assert computed == len(run.ticks)


@pytest.fixture(scope="session")
def live_client(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """tests/live/client.mjs with its pinned packages installed (`npm ci`) in a folder of its
    own; the checkout gets no node_modules."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip("needs node and npm (Foxglove's WebSocket client)")
    folder = tmp_path_factory.mktemp("live-client")
    for name in ("package.json", "package-lock.json", "client.mjs"):
        shutil.copy(CLIENT / name, folder / name)
    subprocess.run(
        ["npm", "ci", "--silent", "--no-audit", "--no-fund"], cwd=folder, check=True, timeout=300
    )
    return folder / "client.mjs"


def _url(proc: subprocess.Popen[str]) -> str:
    """The live view's URL, from the line `shoal run --live` prints once its server is up."""
    assert proc.stderr is not None
    seen = []
    while line := proc.stderr.readline():
        seen.append(line)
        if "live view: ws://" in line:
            return line.split()[2]
    raise AssertionError(f"no live view URL: {''.join(seen)}")


def _positions(message: dict[str, Any]) -> dict[int, list[float]]:
    """Agent id → the centre of its body, from a /shoal/scene/agents message."""
    out = {}
    for e in message["entities"]:
        if e["id"].startswith("agent/"):
            p = e["spheres"][0]["pose"]["position"]
            out[int(e["id"].removeprefix("agent/"))] = [p["x"], p["y"], p["z"]]
    return out


@pytest.mark.integration
def test_foxglove_client_sees_the_run_the_log_records(tmp_path: Path, live_client: Path) -> None:
    out = tmp_path / "crossing.mcap"
    port = free_port()
    proc = subprocess.Popen(
        [*PYTHON, "run", "crossing", "--live", "--live-port", str(port), "--live-wait", "--out",
         str(out), "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        url = _url(proc)
        assert url == f"ws://127.0.0.1:{port}"
        client = subprocess.run(
            ["node", str(live_client), url], capture_output=True, text=True, timeout=300
        )
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        stop(proc)
    assert proc.returncode == 0, stderr
    assert client.returncode == 0, client.stderr
    lines = [json.loads(line) for line in client.stdout.splitlines()]
    advertised = {c["topic"]: c for c in lines[0]["advertised"]}
    assert set(advertised) == set(TOPICS)  # crossing has obstacles: every channel
    assert {(c["encoding"], c["schemaEncoding"]) for c in advertised.values()} == {
        ("json", "jsonschema")
    }
    assert all(advertised[t]["schemaName"] == name for t, name in TOPICS.items())
    got: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for m in lines[1:]:
        got[m["topic"]].append(m)

    # Each record's views share its arrival time: the metrics say which tick it was.
    scenario = load_scenario("crossing")
    tick_at = {m["timestamp"]: m["message"]["tick"] for m in got[FORMATION_ERROR_TOPIC]}
    traj = read_trajectory(out, dt=scenario.dt)
    compared = 0
    for m in got[AGENTS]:
        tick = tick_at.get(m["timestamp"])
        if tick is None:  # drawn before the client's subscription to the metrics took
            continue
        logged = np.round(traj.positions[tick], 4)
        seen = _positions(m["message"])
        assert sorted(seen) == list(range(1, scenario.n + 1))
        assert np.array_equal(np.array([seen[i][:2] for i in sorted(seen)]), logged), tick
        compared += 1
    for m in got[FRAMES]:
        if (tick := tick_at.get(m["timestamp"])) is None:
            continue
        moved = [[t["translation"]["x"], t["translation"]["y"]] for t in m["message"]["transforms"]]
        assert np.array_equal(np.array(moved), np.round(traj.positions[tick], 4)), tick
    assert compared >= 20, compared  # 800 ticks, drawn at a frame rate of the wall clock

    # The metrics are the exported file's of their ticks (dt 0.05 s: the export writes every
    # tick), at most PLOT_RATE ticks a second of wall clock, in order, up to the run's last.
    exported = _exported_metrics(sibling(out))
    for topic in METRICS:
        ticks = _assert_plotted(got[topic], exported[topic], scenario.steps)
        assert ticks[0] < scenario.steps // 2, (topic, ticks[:3])
    assert json.loads(stdout)["steps"] == scenario.steps

    # The filter's activity is the log's filtered flags, and the filter acts in this run.
    records = {r.tick: r for r in read_ticks(out)}
    for m in got[FILTER]:
        flags = records[m["message"]["tick"]].filtered
        assert [a["value"] for a in m["message"]["agents"]] == [int(f) for f in flags]
    assert sum(sum(r.filtered) for r in records.values()) > 50
    assert any(m["message"]["value"] for m in got[FILTER])  # of the ticks plotted live too


FORMATION_ERROR_TOPIC = "/shoal/metrics/formation_error"


def _assert_plotted(
    got: list[dict[str, Any]], exported: dict[int, dict[str, Any]], steps: int
) -> list[int]:
    """A metric topic as a client saw it: each message the exported one of its tick, ticks in
    order up to the run's last, at most one per 1/PLOT_RATE s slot of their stamps but for the
    last (S s of stamps meet at most PLOT_RATE × S + 2 slots; the last, + 1). Returns the
    ticks."""
    ticks = [m["message"]["tick"] for m in got]
    assert ticks and all(a < b for a, b in itertools.pairwise(ticks)), ticks
    assert ticks[-1] == steps - 1, ticks
    assert all(m["message"] == exported[m["message"]["tick"]] for m in got)
    span = (int(got[-1]["timestamp"]) - int(got[0]["timestamp"])) / 1e9
    assert len(ticks) <= PLOT_RATE * span + 3, (len(ticks), span)
    return ticks


@pytest.mark.integration
@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl")
def test_a_secured_run_serves_the_worlds_events(tmp_path: Path, live_client: Path) -> None:
    """--secure: the router's rules let the monitor hear the world's events (bus/acl.py), so
    the live log has "run finished" as the file's has."""
    scenario = tmp_path / "short.yaml"
    scenario.write_text(load_scenario("passage").source.replace("duration: 45.0", "duration: 0.5"))
    out = tmp_path / "short.mcap"
    proc = subprocess.Popen(  # --live-wait: the run starts once the client has subscribed
        [*PYTHON, "run", str(scenario), "--secure", "--live", "--live-port", "0", "--live-wait",
         "--out", str(out), "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        url = _url(proc)
        client = subprocess.run(
            ["node", str(live_client), url, "--topics", f"/shoal/log,{FORMATION_ERROR_TOPIC}"],
            capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        stop(proc)
    assert proc.returncode == 0, stderr
    assert client.returncode == 0, client.stderr
    assert json.loads(stdout)["secure"] is True
    got = [json.loads(line) for line in client.stdout.splitlines()[1:]]
    # Subscribed before the run began (its first 1/PLOT_RATE s: the latest tick of those).
    plotted = [m for m in got if m["topic"] == FORMATION_ERROR_TOPIC]
    exported = _exported_metrics(sibling(out))[FORMATION_ERROR_TOPIC]
    _assert_plotted(plotted, exported, 50)
    world = [(m["message"]["name"], m["message"]["message"]) for m in got if m["topic"] == LOG]
    assert world.count(("world", "tick 50: run finished; 0 bad messages dropped")) == 1, world


@pytest.mark.integration
def test_a_replay_serves_the_logged_run_at_its_pace(tmp_path: Path, live_client: Path) -> None:
    """shoal replay --live, no router: Foxglove's client sees the log's positions, the export's
    metrics and the world's events, stamped by the replay's clock at the replay's rate."""
    run = reference_log(CROSSING)  # 800 ticks, 7 ms of log time apart: 5.6 s
    log = tmp_path / "crossing-fox-1.mcap"
    raw_log(log, run)
    port = free_port()
    before = time.time_ns()
    proc = subprocess.Popen(
        [*PYTHON, "replay", str(log), "--live", "--live-port", str(port), "-r", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        url = _url(proc)
        assert url == f"ws://127.0.0.1:{port}"
        assert proc.stderr is not None
        while "replay: waiting for a viewer" not in (line := proc.stderr.readline()):
            assert line, "the replay did not wait for a viewer"
        client = subprocess.run(
            ["node", str(live_client), url], capture_output=True, text=True, timeout=300
        )
        _stdout, stderr = proc.communicate(timeout=300)
    finally:
        stop(proc)
    after = time.time_ns()
    assert proc.returncode == 0, stderr
    assert client.returncode == 0, client.stderr
    assert "801 messages replayed" in stderr  # no router: only the 800 records and 1 event
    lines = [json.loads(line) for line in client.stdout.splitlines()]
    assert {c["topic"] for c in lines[0]["advertised"]} == set(TOPICS)
    assert all(c["schemaName"] == TOPICS[c["topic"]] for c in lines[0]["advertised"])
    got: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for m in lines[1:]:
        got[m["topic"]].append(m)

    s = run.scenario
    records = {r.tick: r for _ns, r in run.ticks}
    tick_at = {int(m["timestamp"]): m["message"]["tick"] for m in got[FORMATION_ERROR_TOPIC]}
    compared = 0
    for m in got[AGENTS]:
        tick = tick_at.get(int(m["timestamp"]))
        if tick is None:
            continue
        seen = _positions(m["message"])
        logged = np.round(np.array(records[tick].positions), 4)
        assert np.array_equal(np.array([seen[i][:2] for i in sorted(seen)]), logged), tick
        compared += 1
    assert compared >= 20, compared  # 2.8 s of replay, drawn at up to 30 frames a second

    # Records 3.5 ms apart (285 a second): the metrics are decimated to PLOT_RATE a second
    # as a fast run's are (every tick would need -r 0.2, 28 s of replay).
    exported = _exported(run)
    for topic in METRICS:
        ticks = _assert_plotted(got[topic], exported[topic], s.steps)
        assert ticks[0] < 100, (topic, ticks[:3])
    for m in got[FILTER]:
        flags = records[m["message"]["tick"]].filtered
        assert [a["value"] for a in m["message"]["agents"]] == [int(f) for f in flags]
    assert sum(sum(r.filtered) for r in records.values()) > 50
    assert any(m["message"]["value"] for m in got[FILTER])  # of the ticks plotted live too

    # Stamped by the replay's wall clock (not the log's, months earlier), at the log's pace
    # over 2: 2.8 s from the first tick to the last (at rate 1 it would be 5.6 s, at 4 1.4 s).
    stamps = sorted(tick_at)
    first, last = tick_at[stamps[0]], tick_at[stamps[-1]]
    assert before < stamps[0] < stamps[-1] < after and last == s.steps - 1
    due = (last - first) * LOG_STEP / 2  # ns: LOG_STEP apart in the log, played at rate 2
    assert 0.9 * due <= stamps[-1] - stamps[0] <= due + 2e9, (stamps[-1] - stamps[0], due)
    logs = [m["message"]["message"] for m in got["/shoal/log"]]
    assert logs[-1] == "tick 800: run finished; 0 bad messages dropped"


def _exported_metrics(path: Path) -> dict[str, dict[int, dict[str, Any]]]:
    out: dict[str, dict[int, dict[str, Any]]] = defaultdict(dict)
    with path.open("rb") as f:
        for _s, channel, message in make_reader(f).iter_messages(topics=list(METRICS)):
            body = json.loads(message.data)
            out[channel.topic][body["tick"]] = body
    return out


def test_a_taken_port_is_refused_in_one_line(tmp_path: Path) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = tmp_path / "x.mcap"
        proc = run_cli(["run", "crossing", "--live", "--live-port", str(port), "--out", str(out)])
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [
        f"Error: --live: 127.0.0.1:{port} is in use; pick another port with --live-port"
    ]
    assert not out.exists()  # refused before any process was started


def test_live_wait_without_live_is_a_usage_error(tmp_path: Path) -> None:
    out = tmp_path / "x.mcap"
    proc = run_cli(["run", "crossing", "--live-wait", "--out", str(out)])
    assert proc.returncode == 2
    assert "--live-wait waits for a viewer of --live: give --live too" in proc.stderr
    assert not out.exists()


def test_live_without_the_sdk_says_how_to_install_it(tmp_path: Path) -> None:
    out = tmp_path / "x.mcap"
    code = (
        "import sys; sys.modules['foxglove'] = None\n"  # as if foxglove-sdk were not installed
        "from shoal.tools.cli import main\n"
        f"main(['run', 'crossing', '--live', '--out', {str(out)!r}])\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 1
    [line] = proc.stderr.strip().splitlines()
    assert line.startswith("Error: --live needs the live extra ("), line
    assert line.endswith("): pip install 'shoal[live]'"), line
    assert not out.exists()


def test_records_before_a_late_summary_still_reach_the_live_view() -> None:
    """A world that exits right after its summary is seen by the monitor's process check first;
    the records and events still queued before the summary (the "run finished" event among them)
    go to the live view all the same, in order, and what follows the summary does not."""
    from shoal.bus.keys import Keys
    from shoal.bus.runtime import Arrival, ArrivalKind, Inbox
    from shoal.tools.procs.launch import _late_summary

    keys, inbox = Keys("late"), Inbox()
    summary = codec.encode_document("summary", {"collisions": 0})
    for kind, key, payload in [
        (ArrivalKind.DATA, keys.tick, b"tick 49"),
        (ArrivalKind.DOWN, keys.alive_world, b""),
        (ArrivalKind.DATA, keys.event, b"run finished"),
        (ArrivalKind.DATA, keys.summary, summary),
        (ArrivalKind.DATA, keys.event, b"after"),
    ]:
        inbox.put(Arrival(kind, key, payload, time_ns=len(payload)))
    handed: list[tuple[str, int, bytes]] = []

    class Sink:
        def tick(self, ns: int, payload: bytes) -> None:
            handed.append(("tick", ns, payload))

        def event(self, ns: int, payload: bytes) -> None:
            handed.append(("event", ns, payload))

    assert _late_summary(inbox, keys, within=0.0, sink=Sink()) == {"collisions": 0}
    assert handed == [("tick", 7, b"tick 49"), ("event", 12, b"run finished")]


def test_an_event_that_trails_the_summary_still_reaches_the_live_view() -> None:
    """The event and the summary come through two subscribers, which deliver apart: under load
    "run finished" was seen after the summary that followed it, and the live view lost it (a CI
    failure of test_a_secured_run_serves_the_worlds_events). The summary counts the world's
    events; the monitor hands over those still missing, then stops at once, or gives up after
    its bound when the count is never reached."""
    from shoal.bus.keys import Keys
    from shoal.bus.runtime import Arrival, ArrivalKind, Inbox
    from shoal.tools.procs.launch import _Counted, _trailing_events

    keys = Keys("trail")
    handed: list[bytes] = []

    class Sink:
        def tick(self, ns: int, payload: bytes) -> None:
            handed.append(b"tick")

        def event(self, ns: int, payload: bytes) -> None:
            handed.append(payload)

    inbox, sink = Inbox(), _Counted(Sink(), events=1)  # one event already handed
    for key, payload in [(keys.tick, b""), (keys.event, b"run finished"), (keys.event, b"x")]:
        inbox.put(Arrival(ArrivalKind.DATA, key, payload))
    _trailing_events(inbox, keys, sink, 2, within=60.0)  # returns at the count, not the bound
    assert handed == [b"run finished"] and sink.events == 2
    assert inbox.get(timeout=0) == Arrival(ArrivalKind.DATA, keys.event, b"x")  # left alone

    started = time.monotonic()
    _trailing_events(Inbox(), keys, sink, 3, within=0.2)  # never comes: bounded
    assert 0.2 <= time.monotonic() - started < 30
    _trailing_events(Inbox(), keys, sink, None, within=60.0)  # an older world: no count
    assert sink.events == 2


@pytest.mark.parametrize("verbose", [False, True])
def test_the_servers_client_log_is_quiet_unless_verbose(
    verbose: bool, capfd: pytest.CaptureFixture[str]
) -> None:
    """A browser opened on the ws:// URL fails the handshake, and the SDK logged that into the
    run's own output. It logs through Python's logger `foxglove.websocket.server`
    (pyo3-log, which asks the logger whether the level is enabled first): quiet by default,
    `shoal -v` shows it, named."""
    import logging

    from shoal.tools.cli import quiet_libraries

    sdk = logging.getLogger("foxglove.websocket.server")
    quiet_libraries(verbose)
    try:
        assert sdk.isEnabledFor(logging.ERROR) is verbose
        sdk.error("Dropping client 127.0.0.1:4000: handshake failed")
        said = capfd.readouterr().err
    finally:
        quiet_libraries(False)
    if verbose:
        assert said == "foxglove: Dropping client 127.0.0.1:4000: handshake failed\n"
    else:
        assert said == ""


def _request(port: int, head: bytes) -> bytes:
    """What the live view's port answers to ``head`` (a request head), up to its close or 2 s
    after its first bytes."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(head)
        got = s.recv(65_536)
        s.settimeout(2.0)
        try:
            while more := s.recv(65_536):
                got += more
        except TimeoutError:
            pass
    return got


def test_a_browser_on_the_port_is_told_what_it_is_and_foxglove_still_connects() -> None:
    """A browser opened on the live view's URL used to get an empty reply. It gets one line
    of what the port is and how to open it; a WebSocket upgrade (Foxglove's subprotocol)
    reaches the SDK's server through the same port and is accepted."""
    run = reference_log(TINY)
    with LiveView(run.scenario, "unit", port=0) as view:
        page = _request(view.port, b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
        upgrade = (
            b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
            b"Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
        )
        answer = _request(view.port, upgrade)
        url, app = view.url, view.app_url
    head, _, body = page.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 200 OK") and b"text/plain" in head
    text = body.decode()
    assert f"shoal's live view: a Foxglove WebSocket server at {url}" in text
    assert "Open connection" in text and app is not None and app in text
    assert f"ws%3A%2F%2F127.0.0.1%3A{view.port}" in app  # the front's port, not the SDK's
    assert answer.startswith(b"HTTP/1.1 101"), answer[:200]
    assert b"s3pPLMBiTxaQ9kYGzzhZRbK+xOo=" in answer  # RFC 6455's accept for that key
