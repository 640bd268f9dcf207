"""The launcher's side of systemd's notification protocol, read from the environment."""

from __future__ import annotations

import os
import socket
import threading
import uuid
from pathlib import Path

import httpx

from openpendant.runtime.launcher.notify import PINGS_PER_PERIOD, Notifier, Watchdog
from openpendant.runtime.launcher.supervisor import Forked, fork_child


def test_the_variables_are_taken_out_and_the_watchdog_is_ours_only_if_it_names_us() -> None:
    environ = {"NOTIFY_SOCKET": "/run/x", "WATCHDOG_USEC": "3000000", "KEEP": "1"}
    notifier = Notifier(environ)
    assert environ == {"KEEP": "1"}  # no child inherits them
    assert notifier.watchdog == 3.0 / PINGS_PER_PERIOD
    other = Notifier({"NOTIFY_SOCKET": "/run/x", "WATCHDOG_USEC": "3000000", "WATCHDOG_PID": "1"})
    assert other.watchdog is None
    assert Notifier({"WATCHDOG_USEC": "junk"}).watchdog is None
    assert Notifier({}).send("READY=1") is False  # not started by systemd: nothing sent


def test_an_abstract_socket_is_written_with_a_leading_at() -> None:
    name = f"openpendant-test-{uuid.uuid4().hex}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as systemd:
        systemd.bind("\0" + name)
        systemd.settimeout(5)
        notifier = Notifier({"NOTIFY_SOCKET": f"@{name}", "WATCHDOG_PID": str(os.getpid())})
        assert notifier.send("READY=1", "STATUS=up")
        assert systemd.recv(100) == b"READY=1\nSTATUS=up"


def test_no_child_is_forked_while_the_watchdog_probes(tmp_path: Path) -> None:
    """A child forked while the watchdog's thread held its HTTP client's or OpenSSL's locks
    would inherit them held, with no thread to release them."""
    probing, release = threading.Event(), threading.Event()

    def healthy(urls: dict[str, str], client: httpx.Client) -> bool:
        probing.set()
        release.wait(10)
        return True

    name = f"openpendant-test-{uuid.uuid4().hex}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as systemd:
        systemd.bind("\0" + name)
        environ = {"NOTIFY_SOCKET": f"@{name}", "WATCHDOG_USEC": "30000"}
        watchdog = Watchdog(Notifier(environ), {}, healthy=healthy)
        watchdog.start()
        try:
            assert probing.wait(10)
            forked: list[Forked] = []
            ended: list[int] = []

            def fork_and_wait() -> None:
                # Waited for by the thread that forked it: a child's parent-death signal
                # follows that thread, which must outlive it (it ended first, under load,
                # and the child was killed: -15).
                forked.append(
                    fork_child("child", lambda argv: 0, [], {}, tmp_path / "child.log", ())
                )
                ended.append(forked[0].wait(10))

            forking = threading.Thread(target=fork_and_wait)
            forking.start()
            forking.join(0.5)
            assert forking.is_alive() and not forked, "forked in the middle of a probe"
            release.set()
            forking.join(20)
            assert forked and ended == [0]
        finally:
            release.set()
            watchdog.stop()
