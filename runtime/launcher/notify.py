"""systemd's service notification protocol (sd_notify(3)), spoken by the launcher: `READY=1`
once every service answers its health check, `WATCHDOG=1` while they all still do, and
`STOPPING=1` on the way out. A datagram to the socket named by `NOTIFY_SOCKET` (a path, or
an abstract name written with a leading `@`); nothing when the runtime was not started by
systemd. The variables are taken out of the environment at once, so that no child of the
launcher speaks for it."""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import ssl
import threading
from collections.abc import Callable, MutableMapping

import httpx

from openpendant.runtime.launcher.supervisor import FORK_LOCK

log = logging.getLogger(__name__)

SOCKET_ENV = "NOTIFY_SOCKET"
WATCHDOG_USEC_ENV = "WATCHDOG_USEC"
WATCHDOG_PID_ENV = "WATCHDOG_PID"
# Pings per watchdog period: systemd's advice is at least two.
PINGS_PER_PERIOD = 3
HEALTH_TIMEOUT = 1.0  # s a service has to answer its health check


class Notifier:
    def __init__(self, environ: MutableMapping[str, str] = os.environ) -> None:
        address = environ.pop(SOCKET_ENV, "")
        usec = environ.pop(WATCHDOG_USEC_ENV, "")
        pid = environ.pop(WATCHDOG_PID_ENV, "")
        self.address = "\0" + address[1:] if address.startswith("@") else address
        self.watchdog: float | None = None  # s between pings, when systemd watches us
        if usec.isdigit() and int(usec) > 0 and (not pid or pid == str(os.getpid())):
            self.watchdog = int(usec) / 1e6 / PINGS_PER_PERIOD

    def send(self, *fields: str) -> bool:
        if not self.address:
            return False
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
            try:
                sock.sendto("\n".join(fields).encode(), self.address)
            except OSError as exc:
                log.warning("systemd's notification socket refused a message: %s", exc)
                return False
        return True


def all_healthy(urls: dict[str, str], client: httpx.Client) -> bool:
    for url in urls.values():
        try:
            if client.get(f"{url}/health").status_code != 200:
                return False
        except httpx.HTTPError:
            return False
    return True


class Watchdog:
    """Pings systemd's watchdog while every service answers its health check: a service
    that hangs (alive, but answering nothing) stops the pings, and systemd restarts the
    runtime. A thread of its own, so that the launcher's supervision never waits on it."""

    def __init__(
        self,
        notifier: Notifier,
        urls: dict[str, str],
        healthy: Callable[[dict[str, str], httpx.Client], bool] = all_healthy,
        verify: ssl.SSLContext | bool = True,
    ) -> None:
        self.notifier = notifier
        self.verify = verify
        self.urls = urls
        self.healthy = healthy
        self.stopped = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self) -> None:
        if self.notifier.watchdog is None:
            return
        self.thread = threading.Thread(target=self._run, name="watchdog", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        assert self.notifier.watchdog is not None
        with FORK_LOCK:
            client = httpx.Client(timeout=HEALTH_TIMEOUT, trust_env=False, verify=self.verify)
        try:
            while not self.stopped.wait(self.notifier.watchdog):
                with FORK_LOCK:  # no child is forked while this thread holds locks
                    healthy = self.healthy(self.urls, client)
                if healthy:
                    self.notifier.send("WATCHDOG=1")
        finally:
            with FORK_LOCK:
                client.close()

    def stop(self) -> None:
        self.stopped.set()
        if self.thread is not None:
            with contextlib.suppress(RuntimeError):
                self.thread.join(timeout=HEALTH_TIMEOUT * (len(self.urls) + 1))
