"""Network namespaces as stand-in hosts, for tests of runs spread over several machines.

Each "host" is a network namespace with its own loopback and one veth interface (``eth0``) whose
other end is a port of a Linux bridge. The bridge lives in a namespace of its own too, so nothing
at all is added to the machine's root namespace: test traffic cannot leave through the real
network, and concurrent test sessions cannot clash (names carry a random tag, and every set of
hosts gets a random private 10.x.y.0/24). Cutting a host off is ``ip link set <port> down`` on its
bridge port: packets are silently lost, as when a cable is pulled, and no TCP reset tells either
side. Needs root and iproute2; no iptables.

Names are ``shoal-<pid>-<tag>-<host>``, with the pid of the process that made them: a test
process killed before its teardown ran (SIGKILL, or SIGTERM, which Python does not turn into an
exception) leaves its namespaces behind, and the next :func:`network` deletes them.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import signal
import subprocess
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

IP = shutil.which("ip") or "/usr/sbin/ip"  # /usr/sbin is not always on a test runner's PATH
PREFIX = "shoal-"  # every namespace this module makes starts with it
_OWNED = re.compile(rf"^{PREFIX}(\d+)-[0-9a-f]+-")  # shoal-<pid>-<tag>-…
RUN_NETNS = Path("/run/netns")  # where `ip netns add` bind-mounts a namespace


def ip(*args: str) -> None:
    """Run one ``ip`` command; raise with its stderr if it fails."""
    proc = subprocess.run([IP, *args], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {proc.stderr.strip()}")


def unavailable() -> str | None:
    """Why namespace hosts cannot be made here (not root, no iproute2, no netns support), or
    None. Tries the real thing: adds and deletes one namespace."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    if not Path(IP).exists():
        return f"iproute2's ip not found ({IP})"
    probe = f"{PREFIX}{os.getpid()}-{secrets.token_hex(3)}-probe"
    try:
        ip("netns", "add", probe)
    except (RuntimeError, OSError) as exc:
        return f"cannot create a network namespace: {exc}"
    ip("netns", "del", probe)
    return None


def _all_netns() -> list[str]:
    return sorted(p.name for p in RUN_NETNS.iterdir()) if RUN_NETNS.is_dir() else []


def existing(tag: str) -> list[str]:
    """Namespaces of the set ``tag`` that still exist (empty after a clean teardown)."""
    return [n for n in _all_netns() if n.startswith(f"{PREFIX}{tag}-")]


def sweep() -> list[str]:
    """Delete the namespaces of sets whose maker process is gone; returns their names. Sets of
    a live process (another test session building or using its own) are left alone."""
    orphans = [
        n for n in _all_netns() if (m := _OWNED.match(n)) and not Path(f"/proc/{m[1]}").exists()
    ]
    _teardown(orphans)
    return orphans


@dataclass(frozen=True)
class Host:
    """One namespace host: ``address`` on the bridge, reached through ``port`` (the veth end on
    the bridge, in the bridge's namespace)."""

    role: str
    netns: str
    address: str
    port: str

    @property
    def exec(self) -> list[str]:
        """The argv prefix that runs a command on this host. ``ip netns exec`` execs the command
        in place, so the pid the caller gets is the command's."""
        return [IP, "netns", "exec", self.netns]

    def holds(self, pid: int) -> bool:
        """Whether process ``pid`` is in this host's network namespace right now."""
        mine = os.stat(RUN_NETNS / self.netns)
        theirs = os.stat(f"/proc/{pid}/ns/net")
        return (mine.st_dev, mine.st_ino) == (theirs.st_dev, theirs.st_ino)


@dataclass
class Network:
    """Hosts on one bridge; made and torn down by :func:`network`."""

    tag: str
    bridge_ns: str
    hosts: dict[str, Host] = field(default_factory=dict)

    def __getitem__(self, role: str) -> Host:
        return self.hosts[role]

    def popen(self, role: str, argv: Sequence[str], **kwargs: Any) -> subprocess.Popen[Any]:
        """Start ``argv`` on host ``role``."""
        return subprocess.Popen([*self[role].exec, *argv], **kwargs)

    def run(self, role: str, argv: Sequence[str], timeout: float = 30.0) -> int:
        """Run ``argv`` on host ``role`` to its end; returns its exit code."""
        return subprocess.run(
            [*self[role].exec, *argv], capture_output=True, timeout=timeout
        ).returncode

    def cut(self, role: str) -> None:
        """Partition host ``role`` from every other host (its bridge port goes down)."""
        ip("-n", self.bridge_ns, "link", "set", self[role].port, "down")

    def heal(self, role: str) -> None:
        """Undo :meth:`cut`."""
        ip("-n", self.bridge_ns, "link", "set", self[role].port, "up")

    @contextlib.contextmanager
    def partitioned(self, role: str) -> Iterator[None]:
        """Host ``role`` cut off for the duration of the block."""
        self.cut(role)
        try:
            yield
        finally:
            self.heal(role)


@contextlib.contextmanager
def network(roles: Sequence[str]) -> Iterator[Network]:
    """Hosts named ``roles`` on one bridge, all in fresh namespaces. Every namespace is deleted
    on the way out, even after a failure half-way through building; processes still running in
    them (only ever ones the caller started there) are killed first, so none lingers in a
    namespace that no longer has a name."""
    sweep()
    tag = f"{os.getpid()}-{secrets.token_hex(3)}"
    subnet = f"10.{secrets.randbelow(256)}.{secrets.randbelow(256)}"
    made: list[str] = []
    try:
        net = Network(tag, _add_netns(tag, "br", made))
        ip("-n", net.bridge_ns, "link", "set", "lo", "up")
        ip("-n", net.bridge_ns, "link", "add", "br0", "type", "bridge")
        ip("-n", net.bridge_ns, "link", "set", "br0", "up")
        for index, role in enumerate(roles):
            net.hosts[role] = _add_host(net, role, index, subnet, made)
        yield net
    finally:
        _teardown(made)


def _add_netns(tag: str, suffix: str, made: list[str]) -> str:
    name = f"{PREFIX}{tag}-{suffix}"
    ip("netns", "add", name)
    made.append(name)
    return name


def _add_host(net: Network, role: str, index: int, subnet: str, made: list[str]) -> Host:
    """A namespace with loopback up and ``eth0`` at ``subnet``.(index+2)/24 on the bridge.
    The veth pair is created inside the bridge's namespace and its host end moved straight to
    the host's, so it never appears in the root namespace. Interface names are per namespace
    (and at most 15 characters), so ``eth0`` and ``p<index>`` never clash."""
    netns = _add_netns(net.tag, str(index), made)
    port = f"p{index}"
    address = f"{subnet}.{index + 2}"
    ip("-n", net.bridge_ns, "link", "add", port, "type", "veth", "peer", "name", "eth0",
       "netns", netns)  # fmt: skip
    ip("-n", net.bridge_ns, "link", "set", port, "master", "br0", "up")
    ip("-n", netns, "addr", "add", f"{address}/24", "dev", "eth0")
    ip("-n", netns, "link", "set", "eth0", "up")
    ip("-n", netns, "link", "set", "lo", "up")
    return Host(role, netns, address, port)


def _teardown(names: list[str]) -> None:
    """Kill what still runs in each namespace, then delete it (its veth ends go with it)."""
    for name in reversed(names):
        pids = subprocess.run(
            [IP, "netns", "pids", name], capture_output=True, text=True
        ).stdout.split()
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.kill(int(pid), signal.SIGKILL)
        subprocess.run([IP, "netns", "del", name], capture_output=True)
