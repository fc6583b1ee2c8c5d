"""Making a secured mode directory: a local CA, one certificate and password per identity, the
users' dictionary and the router's ACL for one run (layout: bus/secure.py).

Certificates come from the ``openssl`` command (ECDSA P-256, what rustls in Zenoh accepts), so
no Python crypto dependency is needed. Re-running on an existing directory keeps the CA and
every identity already there and only adds the missing ones, then rewrites the dictionary and
the ACL for the given run: one CA can serve successive runs, and agents' keys stay put.
Private keys and passwords are written owner-only (0600) in owner-only folders (0700).
"""

from __future__ import annotations

import ipaddress
import json
import os
import secrets
import shutil
import subprocess
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from shoal.bus.acl import LOGGER, MONITOR, ROUTER, WORLD, access_control, agent_name
from shoal.bus.keys import Keys
from shoal.bus.secure import Material

# Names a client may use to reach the router: loopback, and "router" (a compose service name).
DEFAULT_HOSTS = ("localhost", "127.0.0.1", "::1", "router")


class CertError(RuntimeError):
    """Making the material failed (no openssl, or openssl refused)."""


def make_material(
    root: Path,
    *,
    run: str,
    agents: int,
    hosts: Sequence[str] = DEFAULT_HOSTS,
    days: int = 365,
) -> Material:
    """Create (or complete) the secured mode directory ``root`` for run ``run`` with agents
    1..``agents``. ``hosts`` are the DNS names or IP addresses the router's certificate is valid
    for: a client checks the name it connects to against them."""
    Keys(run)  # refuse a bad run id before writing anything
    if agents < 1:
        raise CertError(f"agents: {agents}; a run has at least one agent")
    m = Material(root)
    _private_dir(root)
    if not m.ca.exists():
        _make_ca(m, days)
    names = [WORLD, LOGGER, MONITOR, *(agent_name(i) for i in range(1, agents + 1))]
    with ThreadPoolExecutor(max_workers=8) as pool:  # openssl's start-up dominates: overlap it
        done = [pool.submit(issue, m, ROUTER, hosts=hosts, days=days)]
        done += [pool.submit(issue, m, name, days=days) for name in names]
        for future in done:
            future.result()
    # Every identity with a password may log in (also ones issued by hand, e.g. a test's
    # outsider); what each may do is the ACL's business. The router never logs in anywhere.
    names = sorted(p.parent.name for p in root.glob("*/password") if p.parent.name != ROUTER)
    _write_private(m.users, "".join(f"{n}:{m.password(n).read_text().strip()}\n" for n in names))
    m.acl.write_text(json.dumps(access_control(run, agents), indent=1) + "\n")
    m.manifest.write_text(json.dumps({"run": run, "agents": agents}) + "\n")
    return m


def issue(m: Material, name: str, *, hosts: Sequence[str] = (), days: int = 365) -> None:
    """A key, a CA-signed certificate with common name ``name`` and a password, unless ``name``
    has them already. Any name can be issued (a test's outsider, say); only the names in
    the ACL get any permission."""
    folder = m.root / name
    if m.cert(name).exists() and m.key(name).exists() and m.password(name).exists():
        return
    _private_dir(folder)
    sans = ",".join(f"{'IP' if _is_ip(h) else 'DNS'}:{h}" for h in hosts)
    _openssl("req", "-x509", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256",
             "-nodes", "-keyout", m.key(name), "-out", m.cert(name), "-subj", f"/CN={name}",
             "-CA", m.ca, "-CAkey", m.ca_key, "-days", str(days),
             "-set_serial", f"0x{secrets.token_hex(16)}",
             "-addext", "basicConstraints=critical,CA:FALSE",
             "-addext", "keyUsage=critical,digitalSignature",
             "-addext", "extendedKeyUsage=serverAuth,clientAuth",
             *(("-addext", f"subjectAltName={sans}") if sans else ()))  # fmt: skip
    os.chmod(m.key(name), 0o600)
    _write_private(m.password(name), secrets.token_urlsafe(24) + "\n")


def _make_ca(m: Material, days: int) -> None:
    _openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes",
             "-keyout", m.ca_key, "-out", m.ca, "-days", str(days), "-subj", "/CN=shoal run CA",
             "-addext", "basicConstraints=critical,CA:TRUE",
             "-addext", "keyUsage=critical,keyCertSign,cRLSign")  # fmt: skip
    os.chmod(m.ca_key, 0o600)


def _openssl(*args: str | Path) -> None:
    exe = shutil.which("openssl")
    if exe is None:
        raise CertError("making certificates needs the openssl command (apt-get install openssl)")
    proc = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise CertError(f"openssl {args[0]} failed: {proc.stderr.strip()[-400:]}")


def _private_dir(path: Path) -> None:
    path.mkdir(parents=True, exist_ok=True)
    os.chmod(path, 0o700)


def _write_private(path: Path, text: str) -> None:
    _private_dir(path.parent)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(text)


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True
