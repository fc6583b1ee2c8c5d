"""The run folder's reaper (tools/procs/reaper.py): it removes the folder once the run's
processes are gone, and takes down one that outlived its own watchdog."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from shoal.tools.procs.reaper import holders, reap

# A child that holds a file in the folder and ignores SIGTERM, as a process blocked in native
# code does (its Python handler, and so its watchdog, never runs); it says when it holds it.
STUCK = """
import signal, sys, threading
signal.signal(signal.SIGTERM, signal.SIG_IGN)
held = open(sys.argv[1], "w")
print("holding", flush=True)
threading.Event().wait()
"""


def test_the_reaper_kills_a_process_that_outlives_its_grace_and_removes_the_folder(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    command = [sys.executable, "-c", STUCK, str(folder / "child.log")]
    with subprocess.Popen(command, stdout=subprocess.PIPE) as stuck:
        assert stuck.stdout is not None and stuck.stdout.readline() == b"holding\n"
        assert holders(folder) == [stuck.pid]
        killed = reap(folder, wait_s=0.2)
        assert killed == [stuck.pid]
        assert stuck.wait(timeout=10) == -9
        assert not folder.exists()
        stuck.kill()  # only if an assertion failed first


def test_the_reaper_leaves_processes_alone_once_they_let_go(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "child.log").write_text("done")
    with subprocess.Popen([sys.executable, "-c", "input()"], stdin=subprocess.PIPE) as bystander:
        assert reap(folder, wait_s=5.0) == []  # nobody holds a file there: no wait, no kill
        assert bystander.poll() is None
        assert not folder.exists()
        bystander.kill()
