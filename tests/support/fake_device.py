"""A misbehaving device for the discovery tests: a plain HTTP server on loopback, in a
thread of the test process, answering GET /info with whatever body the test sets."""

from __future__ import annotations

import contextlib
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


class FakeDevice:
    def __init__(self) -> None:
        self.info = b"{}"
        device = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                body = device.info if self.path == "/info" else b"{}"
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                with contextlib.suppress(OSError):  # the runtime stopped reading: the point
                    self.wfile.write(body)

            def log_message(self, *_: object) -> None:
                return

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        self._thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()
