"""A WebSocket server whose opening handshake waits for the test: a socket a page opens to
it stays connecting until `answer()`, then is open. What the page does with a socket still
connecting (closing it, leaving the panel) is then seen from the server's side. It listens
in a thread of its own: Playwright's synchronous API answers a page's routed requests only
while the test is inside a Playwright call, so the test waits there, not on this server."""

from __future__ import annotations

import base64
import hashlib
import socket
import threading

GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"  # RFC 6455, section 1.3
CLOSE = 0x8  # a close frame's opcode


class HeldHandshake:
    def __init__(self) -> None:
        self._server = socket.create_server(("127.0.0.1", 0))
        self.port: int = self._server.getsockname()[1]
        self._conn: socket.socket | None = None
        self._asked = threading.Event()  # a page's handshake request is in
        self.request = b""
        threading.Thread(target=self._listen, daemon=True).start()

    def _listen(self) -> None:
        with_timeout = 20.0
        try:
            conn, _ = self._server.accept()
        except OSError:
            return  # closed before any page came
        conn.settimeout(with_timeout)
        while b"\r\n\r\n" not in self.request:
            chunk = conn.recv(4096)
            if not chunk:
                return
            self.request += chunk
        self._conn = conn
        self._asked.set()

    def wait_asked(self, timeout: float) -> None:
        if not self._asked.wait(timeout):
            raise TimeoutError("no page asked to open a socket")

    def answer(self) -> bool:
        """Completes the handshake; False if the page had dropped the socket by then."""
        assert self._conn is not None
        key = next(
            line.split(b":", 1)[1].strip()
            for line in self.request.split(b"\r\n")
            if line.lower().startswith(b"sec-websocket-key:")
        )
        accept = base64.b64encode(hashlib.sha1(key + GUID.encode()).digest())
        try:
            self._conn.sendall(
                b"HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\n"
                b"Connection: Upgrade\r\nSec-WebSocket-Accept: " + accept + b"\r\n\r\n"
            )
        except OSError:
            return False
        return True

    def first_frame_opcode(self) -> int | None:
        """The opcode of the first frame the page sends once open (None: it hung up)."""
        assert self._conn is not None
        try:
            header = self._conn.recv(1)
        except OSError:
            return None
        return header[0] & 0x0F if header else None

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
        self._server.close()
