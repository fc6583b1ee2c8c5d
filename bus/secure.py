"""The secured mode's material on disk, and the Zenoh settings each process takes from it.

One directory per run (``shoal certs DIR`` makes it; ``shoal run --secure`` makes a throwaway
one)::

    DIR/ca.pem                  the run's certificate authority (public; every process)
    DIR/ca.key                  its private key (only for issuing more; keep it away from hosts)
    DIR/shoal-secure.json       {"run": RUN, "agents": N}: what the ACL was written for
    DIR/router/cert.pem,key.pem the router's TLS server certificate and key
    DIR/router/users.txt        user:password, one identity a line (Zenoh's usrpwd dictionary)
    DIR/router/acl.json         the router's access_control section (bus/acl.py)
    DIR/<name>/cert.pem,key.pem a client certificate whose common name is <name>
    DIR/<name>/password         that identity's usrpwd password

``<name>`` is ``world``, ``logger``, ``monitor`` or ``agent-<i>``. A host or container needs only
``ca.pem`` and its own ``<name>/`` folder. Why three mechanisms: TLS encrypts and, with mutual
authentication, admits only holders of a key the CA signed; usrpwd is a second, independent
secret; the ACL (keyed on certificate common name AND username) limits what an admitted
identity may do. Everything here only reads files: making them is ``tools/certs.py``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shoal.bus.acl import ROUTER
from shoal.bus.errors import WireError

MANIFEST = "shoal-secure.json"


@dataclass(frozen=True)
class Material:
    """Paths inside a secured mode directory (see the module docstring for the layout)."""

    root: Path

    @property
    def ca(self) -> Path:
        return self.root / "ca.pem"

    @property
    def ca_key(self) -> Path:
        return self.root / "ca.key"

    @property
    def manifest(self) -> Path:
        return self.root / MANIFEST

    @property
    def users(self) -> Path:
        return self.root / ROUTER / "users.txt"

    @property
    def acl(self) -> Path:
        return self.root / ROUTER / "acl.json"

    def cert(self, name: str) -> Path:
        return self.root / name / "cert.pem"

    def key(self, name: str) -> Path:
        return self.root / name / "key.pem"

    def password(self, name: str) -> Path:
        return self.root / name / "password"

    def scope(self) -> tuple[str, int]:
        """The run id and agent count the router's rules were written for."""
        doc = json.loads(_read(self.manifest))
        return str(doc["run"]), int(doc["agents"])


@dataclass(frozen=True)
class Identity:
    """Who a process is in the secured mode: its material and its name in the ACL."""

    material: Material
    name: str


def secure_settings(identity: Identity, mode: str) -> dict[str, Any]:
    """Zenoh config entries (key → JSON value) for ``identity``: TLS only, with mutual
    authentication and usrpwd; for the router also the users' dictionary and the ACL."""
    m = identity.material
    tls = "transport/link/tls"
    settings: dict[str, Any] = {
        "transport/link/protocols": ["tls"],  # no plain tcp link, even if one is configured
        f"{tls}/root_ca_certificate": _existing(m.ca),
        f"{tls}/enable_mtls": True,
    }
    if mode == "router":
        settings |= {
            f"{tls}/listen_certificate": _existing(m.cert(ROUTER)),
            f"{tls}/listen_private_key": _existing(m.key(ROUTER)),
            "transport/auth/usrpwd/dictionary_file": _existing(m.users),
            "access_control": json.loads(_read(m.acl)),
        }
    else:
        settings |= {
            f"{tls}/connect_certificate": _existing(m.cert(identity.name)),
            f"{tls}/connect_private_key": _existing(m.key(identity.name)),
            "transport/auth/usrpwd/user": identity.name,
            "transport/auth/usrpwd/password": _read(m.password(identity.name)).strip(),
        }
    return settings


def check_tls_endpoints(endpoints: Sequence[str]) -> None:
    """The secured mode speaks TLS only: refuse any other endpoint up front, with its name."""
    for endpoint in endpoints:
        if not endpoint.startswith("tls/"):
            raise WireError(f"secured mode: endpoint {endpoint!r} is not tls/<host>:<port>")


def _existing(path: Path) -> str:
    if not path.is_file():
        raise WireError(f"secured mode: {path} is missing (made by `shoal certs DIR`)")
    return str(path.resolve())


def _read(path: Path) -> str:
    try:
        return path.read_text()
    except OSError as exc:
        raise WireError(f"secured mode: cannot read {path}: {exc.strerror}") from None
