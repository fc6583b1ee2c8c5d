"""The live view's port, as a person meets it: a browser pointed at it gets one line
saying what the port is and how to open it, where the Foxglove SDK's server answers a plain
HTTP request with an empty reply; a WebSocket upgrade goes through to that server.

foxglove-sdk has no hook for requests that are not WebSocket upgrades (its server is Rust, behind
``start_server``), so the port is this front's: it reads a connection's request head; an upgrade
is passed, head and all, to the SDK's server listening on loopback only, and from then on bytes
are copied both ways until either side closes; anything else gets ``200 text/plain`` with
:func:`hint` and is closed. No HTTP or WebSocket library is used because nothing here parses
more than a header line: the SDK's server does the protocol.
"""

from __future__ import annotations

import contextlib
import socket
import threading
from collections.abc import Callable

HEAD_LIMIT = 16_384  # bytes of a request head read before giving up on it
HEAD_TIMEOUT_S = 5.0  # for a client to send its request head
CHUNK = 65_536


def hint(url: str, app_url: str | None) -> str:
    """What a person who opened the port in a browser is told."""
    lines = [
        f"This is shoal's live view: a Foxglove WebSocket server at {url}.",
        "Open it in Foxglove (app or desktop): Open connection → Foxglove WebSocket → this URL.",
    ]
    if app_url:
        lines.append(f"Or open {app_url}")
    return "\n".join(lines) + "\n"


def is_upgrade(head: bytes) -> bool:
    """Whether a request head asks for a WebSocket (an ``Upgrade: websocket`` header)."""
    for line in head.split(b"\r\n")[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"upgrade" and b"websocket" in value.lower():
            return True
    return False


class Front:
    """Listens on ``host``:``port`` (0: any free one) for connections to the server on
    127.0.0.1:``inner``. ``text()`` is the plain-HTTP reply. A context manager."""

    def __init__(self, host: str, port: int, inner: int, text: Callable[[], str]) -> None:
        self.inner = inner
        self._text = text
        self._listener = socket.create_server((host, port), reuse_port=False)
        self.port: int = self._listener.getsockname()[1]
        self._closed = threading.Event()
        self._open: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._accept, name="live front", daemon=True)

    def __enter__(self) -> Front:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    def close(self) -> None:
        self._closed.set()
        for s in [self._listener, *self._taken()]:
            with contextlib.suppress(OSError):
                s.shutdown(socket.SHUT_RDWR)
            s.close()
        if self._thread.is_alive():
            self._thread.join(1.0)

    def _taken(self) -> list[socket.socket]:
        with self._lock:
            return list(self._open)

    def _track(self, s: socket.socket, on: bool) -> None:
        with self._lock:
            (self._open.add if on else self._open.discard)(s)

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                conn, _ = self._listener.accept()
            except OSError:
                return  # closed
            self._track(conn, True)
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn: socket.socket) -> None:
        try:
            head = self._head(conn)
            if head is None:
                return
            if not is_upgrade(head):
                body = self._text().encode()
                conn.sendall(
                    b"HTTP/1.1 200 OK\r\nContent-Type: text/plain; charset=utf-8\r\n"
                    b"Content-Length: %d\r\nConnection: close\r\n\r\n%s" % (len(body), body)
                )
                return
            inner = socket.create_connection(("127.0.0.1", self.inner), timeout=HEAD_TIMEOUT_S)
            inner.settimeout(None)
            self._track(inner, True)
            try:
                inner.sendall(head)
                back = threading.Thread(target=_copy, args=(inner, conn), daemon=True)
                back.start()
                _copy(conn, inner)
                back.join()
            finally:
                self._track(inner, False)
                inner.close()
        except OSError:
            pass  # the client or the server went away: nothing to keep
        finally:
            self._track(conn, False)
            conn.close()

    @staticmethod
    def _head(conn: socket.socket) -> bytes | None:
        """The request head and whatever came with it, or None if the client sent none."""
        conn.settimeout(HEAD_TIMEOUT_S)
        data = b""
        while b"\r\n\r\n" not in data and len(data) < HEAD_LIMIT:
            got = conn.recv(4096)
            if not got:
                return None
            data += got
        conn.settimeout(None)
        return data


def _copy(src: socket.socket, dst: socket.socket) -> None:
    """Bytes from ``src`` to ``dst`` until ``src`` ends; then ``dst``'s sending half ends."""
    try:
        while chunk := src.recv(CHUNK):
            dst.sendall(chunk)
    except OSError:
        pass
    with contextlib.suppress(OSError):
        dst.shutdown(socket.SHUT_WR)
