"""``python -m shoal.tools.procs.reaper DIR``: remove a run's folder once its supervisor and its
processes are gone, however the supervisor ended.

A :class:`~shoal.tools.procs.swarm.Swarm` keeps its children's logs (and, in the secured mode,
the run's private keys) in a temporary folder that it removes when it stops. A supervisor that
is SIGKILLed cannot: its children die with it (PR_SET_PDEATHSIG), but the folder stayed behind.
So the Swarm starts this process first, holding the write end of its stdin. When stdin ends —
the Swarm closing it after its own clean-up, or the kernel closing it with the dead supervisor
— the reaper waits until no process has a file open in the folder (each child's stderr log is
open there until it exits), at most :data:`WAIT_S`, removes the folder if it is still there, and
exits. It never takes part in the run and never dies with the supervisor: that is its job.

A child still holding a file there after :data:`WAIT_S` has outlived its own watchdog
(bus/runtime.py: SIGALRM ``EXIT_GRACE_S`` after SIGTERM). That watchdog is armed by a Python
signal handler, which runs only when the main thread gets back to the interpreter: a process
blocked in native code (a Zenoh call waiting on a lock, seen once in CI on a loaded machine as a
``python`` process in ``futex_do_wait``) never arms it. The reaper, a plain process outside the
run, SIGKILLs such a child: only processes with a file open in the run's own private folder.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
import time
from pathlib import Path

from shoal.bus.runtime import EXIT_GRACE_S

# s the reaper waits for the run's processes after its supervisor is gone: a child's clean-up
# may take EXIT_GRACE_S after the SIGTERM its supervisor's death sent, then its watchdog ends it.
WAIT_S = EXIT_GRACE_S + 5.0
POLL_S = 0.2  # s between two looks at /proc while waiting


def holders(folder: Path) -> list[int]:
    """Pids of the processes (other than this one) with a file open inside ``folder``."""
    inside = str(folder.resolve()) + os.sep
    me = os.getpid()
    found = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        try:
            fds = os.scandir(f"/proc/{entry.name}/fd")
        except OSError:
            continue
        with fds:
            for fd in fds:
                try:
                    target = os.readlink(fd.path)
                except OSError:
                    continue
                if target.startswith(inside):
                    found.append(int(entry.name))
                    break
    return found


KILL_WAIT_S = 5.0  # s for the kernel to take down what was SIGKILLed


def reap(folder: Path, wait_s: float = WAIT_S) -> list[int]:
    """Wait until nobody holds a file in ``folder`` (at most ``wait_s``), SIGKILL whoever still
    does, then remove it. Returns the pids killed."""
    deadline = time.monotonic() + wait_s
    while folder.exists() and holders(folder) and time.monotonic() < deadline:
        time.sleep(POLL_S)
    killed = holders(folder) if folder.exists() else []
    for pid in killed:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            continue  # gone in between
        print(f"reaper: SIGKILL to pid {pid}, still running {wait_s:g} s after its supervisor",
              file=sys.stderr, flush=True)  # fmt: skip
    deadline = time.monotonic() + KILL_WAIT_S
    while killed and holders(folder) and time.monotonic() < deadline:
        time.sleep(POLL_S / 10)
    shutil.rmtree(folder, ignore_errors=True)
    return killed


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python -m shoal.tools.procs.reaper DIR", file=sys.stderr)
        return 2
    folder = Path(argv[0])
    sys.stdin.buffer.read()  # until the supervisor closes it, or dies
    reap(folder)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
