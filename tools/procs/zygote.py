"""A fork server for agent processes: import once, fork fifty times.

An agent spends about 0.35 s of CPU before it can do anything, almost all of it importing
(Python, click, numpy, zenoh); fifty of them on two cores take most of ten seconds just to start.
The zygote is one child of the supervisor that does those imports once, with no thread and no
Zenoh session, and then forks one process per agent on request. Each forked agent is still its
own OS process with its own Zenoh session; it runs exactly the ``shoal agent`` command line.

The supervision guarantees are those of tools/procs/swarm.py, one level down: the zygote dies with
the supervisor (PR_SET_PDEATHSIG) and every forked child with the zygote (SIGKILL: see _child), so
no SIGKILL anywhere leaves an orphan; each child is in its own session and writes stderr to its
own file.

The supervisor's side is tools/procs/forks.py; arguments on the zygote's own command line are only
labels (the run id, for ``pgrep``) and are ignored. Protocol, one line each way (stdin / stdout
of the zygote):
  → ``{"name": NAME, "args": [...], "log": PATH}``   fork ``shoal <args>``, stderr to PATH
  ← ``pid PID``                                      in answer, in request order, once the
                                                     child is set up (named, own session)
  ← ``error WHY``                                    instead, if it could not fork
  ← ``exit PID CODE CPU``                            when it ends (CODE < 0: killed by -CODE;
                                                     CPU: its user + system seconds)
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import select
import signal
import sys
import traceback
from typing import Any

from shoal.tools.procs.swarm import adopt_supervisor, die_with, name_process

if __name__ == "__main__":
    adopt_supervisor()  # before the slow imports: the server dies with the supervisor

# Each child runs a ``shoal`` command line: the CLI, named as swarm.py names it for the children it
# starts itself (``python -m shoal.tools``). procs sits under the CLI and its commands and imports
# neither; the zygote loads them by name, once, as each child would.
CLI = "shoal.tools.cli"
_cli: Any = importlib.import_module(CLI).main  # before numpy: the CLI starts no OpenBLAS threads

import click  # noqa: E402

import shoal.tools.procs.agent  # noqa: E402, F401  (all that an agent process imports)

_cli.get_command(click.Context(_cli), "agent")  # and the command that parses its options

# -- the zygote process --------------------------------------------------------------------------


def _exit_code(status: int) -> int:
    return -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)


def _child(request: dict[str, Any], zygote: int, inherited: tuple[int, ...], ready: int) -> None:
    """In the forked child: detach from the zygote's plumbing, say so on ``ready`` and run the
    command. Never returns."""
    code = 1
    try:
        signal.set_wakeup_fd(-1)
        for fd in inherited:
            os.close(fd)
        for sig in (signal.SIGCHLD, signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, signal.SIG_DFL)
        os.setsid()
        # SIGKILL, not SIGTERM: with the fork server gone nobody can stop or reap this agent,
        # and a process whose main thread is stuck in native code never runs the SIGTERM
        # handler that arms its watchdog (bus/runtime.py): seen once in CI, a forked process
        # 30 s in futex_do_wait after the server was killed. The server ends only after the
        # supervisor has stopped its agents, or when something has gone wrong.
        die_with(zygote, signal.SIGKILL)
        null = os.open(os.devnull, os.O_RDWR)
        log = os.open(request["log"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(null, 0)
        os.dup2(null, 1)
        os.dup2(log, 2)
        os.close(null)
        os.close(log)
        name_process(str(request["name"]))
        os.write(ready, b"!")  # set up: named, in its own session, dying with the zygote
        os.close(ready)
        _cli.main(args=[str(a) for a in request["args"]], prog_name="shoal")
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if isinstance(exc.code, str):
            print(exc.code, file=sys.stderr)
    except BaseException:
        traceback.print_exc()
    finally:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.flush()
        os._exit(code)


def serve() -> None:
    """The zygote's loop: fork on each request line, report each child's exit, and leave when
    stdin closes (the supervisor is done or gone); it dies with the supervisor in any case
    (adopt_supervisor)."""
    zygote = os.getpid()
    wake_r, wake_w = os.pipe()
    os.set_blocking(wake_w, False)
    signal.set_wakeup_fd(wake_w)
    signal.signal(signal.SIGCHLD, lambda *_: None)
    out = sys.stdout.buffer
    pending = b""

    def say(line: str) -> None:
        out.write(line.encode() + b"\n")
        out.flush()

    def reap() -> None:
        while True:
            try:
                pid, status, usage = os.wait4(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return
            say(f"exit {pid} {_exit_code(status)} {usage.ru_utime + usage.ru_stime!r}")

    while True:
        try:
            ready, _, _ = select.select([0, wake_r], [], [])
        except InterruptedError:
            continue
        if wake_r in ready:
            os.read(wake_r, 4096)
            reap()
        if 0 not in ready:
            continue
        chunk = os.read(0, 65536)
        if not chunk:
            return
        pending += chunk
        *lines, pending = pending.split(b"\n")
        for line in lines:
            try:
                pid = _fork(json.loads(line), zygote, (wake_r, wake_w))
            except (OSError, ValueError) as exc:  # EAGAIN, EMFILE, ENOMEM; a bad request line
                say(f"error {type(exc).__name__}: {' '.join(str(exc).split())}")
            else:
                say(f"pid {pid}")
        reap()


def _fork(request: dict[str, Any], zygote: int, wakeup: tuple[int, int]) -> int:
    """Fork one child for ``request``; returns its pid once it is set up (or has failed)."""
    sys.stderr.flush()
    set_up_r, set_up_w = os.pipe()
    try:
        pid = os.fork()
        if pid == 0:
            _child(request, zygote, (*wakeup, set_up_r), set_up_w)
        os.close(set_up_w)
        set_up_w = -1
        os.read(set_up_r, 1)  # b"" if it failed first: its exit is reported all the same
        return pid
    finally:
        for fd in (set_up_r, set_up_w):
            if fd >= 0:
                os.close(fd)


if __name__ == "__main__":
    serve()
