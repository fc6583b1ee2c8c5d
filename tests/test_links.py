"""bus/links.py and bus/seam.py leave the interpreter nothing to wait for at exit: samples are
pumped by daemon threads, liveliness changes and queries answered on Zenoh's own thread. A real
router and a real process."""

from __future__ import annotations

import subprocess
import sys

_FORGETS_TO_UNDECLARE = """
import sys, threading
from collections import deque
import zenoh
from shoal.bus.keys import Keys
from shoal.bus.links import collect, publisher, subscribe, watch_presence
from shoal.bus.runtime import Inbox
from shoal.bus.seam import Answer, ZenohBus
from shoal.bus.zconfig import zenoh_config

keys = Keys("links-test")
session = zenoh.open(zenoh_config(mode="client", connect=[sys.argv[1]]))
def held_open():
    return sum(1 for t in threading.enumerate() if not t.daemon)
before = held_open()
inbox, sink = Inbox(), deque()
held = [
    subscribe(session, keys.sensing(1), inbox),
    watch_presence(session, keys.alive_agent(1), inbox),
    collect(session, keys.everything, sink),
    ZenohBus(session).serve(keys.report(1), lambda key: Answer(key, b"figures")),
]
token = session.liveliness().declare_token(keys.alive_agent(1))
assert inbox.get(timeout=30).kind == "up"
publisher(session, keys.sensing(1)).put(b"hello")
arrival = inbox.get(timeout=30)
assert arrival is not None and arrival.payload == b"hello", arrival
answers = ZenohBus(session).ask([keys.report(1)], timeout=30)
assert [a.payload for a in answers] == [b"figures"], answers
print("threads started", held_open() - before, "collected", len(sink), flush=True)
# and exit without undeclaring anything or closing the session
"""


def test_no_declaration_holds_the_interpreter_open_when_a_process_never_undeclares(
    router: str,
) -> None:
    # With Zenoh's default (a Python thread per callback, not a daemon) the interpreter waits at
    # exit for threads that wait for their entity's undeclaration: the process never ends.
    proc = subprocess.run(
        [sys.executable, "-c", _FORGETS_TO_UNDECLARE, router],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    words = proc.stdout.split()
    assert words[:3] == ["threads", "started", "0"], proc.stdout
    assert int(words[4]) >= 1  # the recorder's callback saw the sample too
