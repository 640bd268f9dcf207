"""`openpendant run`: supervision, clean stops, the /api routing and the served UI."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from websockets.sync.client import connect

from openpendant.runtime.bench.harness.processes import (
    Runtime,
    child_env,
    free_port,
    wait_for,
    whole_cell_env,
)


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    proc = Runtime(tmp_path_factory.mktemp("launcher"))
    proc.wait_ready()
    yield proc
    proc.stop()


def health(runtime: Runtime) -> dict[str, dict[str, Any]]:
    return runtime.api("GET", "/health").json()["services"]  # type: ignore[no-any-return]


def test_health_reports_every_service(runtime: Runtime) -> None:
    body = runtime.api("GET", "/health").json()
    assert body["status"] == "ok"
    assert set(body["services"]) == {
        "webui",
        "variable_storage",
        "device_manager",
        "jog",
        "motion",
        "program",
        "vision",
    }
    assert all(s["status"] == "ok" for s in body["services"].values())


def test_a_crashed_service_is_restarted_at_the_same_address(runtime: Runtime) -> None:
    before = health(runtime)["device_manager"]
    os.kill(int(before["pid"]), signal.SIGKILL)
    after = wait_for(
        lambda: (
            (h := health(runtime)["device_manager"])["status"] == "ok"
            and h["pid"] != before["pid"]
            and h
        ),
        30,
        what="device manager restarted",
    )
    assert after["url"] == before["url"]
    log = (runtime.home / "logs" / f"runtime-{runtime.port}.log").read_text()
    assert "device_manager exited" in log


def test_a_frozen_service_shows_as_down(runtime: Runtime) -> None:
    pid = int(health(runtime)["variable_storage"]["pid"])
    os.kill(pid, signal.SIGSTOP)
    try:
        body = runtime.api("GET", "/health").json()
        assert body["status"] == "degraded"
        assert body["services"]["variable_storage"]["status"] == "down"
        assert body["services"]["device_manager"]["status"] == "ok"
    finally:
        os.kill(pid, signal.SIGCONT)
    wait_for(
        lambda: runtime.api("GET", "/health").json()["status"] == "ok", 10, what="healthy again"
    )


def test_a_write_the_gateway_gave_up_on_is_never_applied_later(runtime: Runtime) -> None:
    """The storage hangs (stopped, as while it restarts): the gateway answers each write 504
    after its 10 s, and when the storage wakes up with the requests still waiting in its
    socket, it refuses them instead of applying them over newer writes."""
    assert runtime.api("PUT", "/variables/late", json={"type": "number", "value": 1}).is_success
    pid = int(health(runtime)["variable_storage"]["pid"])
    answers: list[int] = []

    def write(value: int) -> None:
        body = {"type": "number", "value": value}
        answers.append(runtime.api("PUT", "/variables/late", json=body, timeout=30).status_code)

    os.kill(pid, signal.SIGSTOP)
    try:
        writers = [threading.Thread(target=write, args=(v,)) for v in range(2, 7)]
        for writer in writers:
            writer.start()
            time.sleep(0.2)
        for writer in writers:
            writer.join()
        assert answers == [504] * 5
    finally:
        os.kill(pid, signal.SIGCONT)
    wait_for(
        lambda: runtime.api("GET", "/health").json()["status"] == "ok", 10, what="healthy again"
    )
    time.sleep(1.0)  # the waiting requests have been read and refused by now
    assert runtime.api("GET", "/variables/late").json()["value"] == 1
    assert runtime.api("PUT", "/variables/late", json={"type": "number", "value": 9}).is_success
    assert runtime.api("GET", "/variables/late").json()["value"] == 9


def test_the_jog_socket_has_a_port_of_its_own_that_serves_nothing_else(
    runtime: Runtime,
) -> None:
    """Hold-to-run bypasses the gateway (no HTTP load can hold a heartbeat back); the port
    answers only the jog socket. Through the gateway the socket still works for scripts."""
    port = runtime.api("GET", "/jog/settings").json()["socket_port"]
    assert port and port != runtime.port
    for path in ("/jog/settings", "/health", "/jog/robots/robot/halt", "/docs"):
        assert httpx.get(f"http://127.0.0.1:{port}{path}").status_code == 404, path
    ticket = runtime.api("POST", "/auth/ticket", role="operator").json()["ticket"]
    for url, headers in (
        (f"ws://127.0.0.1:{port}/jog/ws?ticket={ticket}", {}),
        (runtime.ws_url("/jog/ws"), runtime.auth("operator")),
    ):
        with connect(url, additional_headers=headers) as ws:
            ws.send(json.dumps({"type": "nonsense"}))
            assert json.loads(ws.recv(timeout=5))["error"]["code"] == "bad_message"


def test_unknown_api_prefix_is_a_json_404(runtime: Runtime) -> None:
    response = runtime.api("GET", "/nonsense/thing")
    assert response.status_code == 404
    assert response.json()["error"]["code"] == "not_found"
    with connect(runtime.ws_url("/nonsense/ws"), additional_headers=runtime.auth()) as ws:
        message = json.loads(ws.recv(timeout=5))
    assert message["error"]["code"] == "not_found"


def test_the_ui_is_served_from_the_same_origin(runtime: Runtime) -> None:
    page = httpx.get(f"{runtime.url}/")
    assert page.status_code == 200
    assert "<op-app>" in page.text
    script = page.text.split('src="', 1)[1].split('"', 1)[0]
    assert httpx.get(f"{runtime.url}{script}").status_code == 200


def test_what_the_runtime_keeps_is_readable_by_its_owner_only(runtime: Runtime) -> None:
    """The variables (programs, waypoints, calibrations) and the logs were world-readable."""
    stored = runtime.api("PUT", "/variables/kept", json={"type": "number", "value": 2.5})
    assert stored.status_code == 200
    assert (runtime.data_dir / "logs").is_dir() and list((runtime.data_dir / "logs").iterdir())
    opened = {
        str(path.relative_to(runtime.data_dir)): oct(path.stat().st_mode & 0o777)
        for path in [runtime.data_dir, *runtime.data_dir.rglob("*")]
        if not path.is_symlink() and path.stat().st_mode & 0o077
    }
    assert opened == {}


def test_a_port_in_use_is_a_clear_error(home: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "openpendant.runtime.cli",
                "run",
                "--port",
                str(port),
                "--data-dir",
                str(home / "d"),
            ],
            env=child_env(home),
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert result.returncode == 1
    assert f"cannot listen on 127.0.0.1:{port}" in result.stderr
    assert "--port" in result.stderr


def test_ctrl_c_stops_everything(home: Path) -> None:
    runtime = Runtime(home, port=free_port())
    runtime.wait_ready()
    pids = [
        int(s["pid"])
        for s in runtime.api("GET", "/health").json()["services"].values()
        if "pid" in s
    ]
    runtime.popen.send_signal(signal.SIGINT)
    assert runtime.popen.wait(20) == 0
    for pid in pids:
        assert (
            not Path(f"/proc/{pid}").exists()
            or "State:\tZ" in Path(f"/proc/{pid}/status").read_text()
        )
    runtime.stop()


class Systemd:
    """systemd's side of the notification protocol: a datagram socket, every message heard."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(str(path))
        self.sock.settimeout(0.2)
        self.messages: list[str] = []
        self.closed = threading.Event()
        self.thread = threading.Thread(target=self._listen, daemon=True)
        self.thread.start()

    def _listen(self) -> None:
        while not self.closed.is_set():
            try:
                self.messages.append(self.sock.recv(4096).decode())
            except TimeoutError:
                continue

    def heard(self, field: str) -> int:
        return sum(field in message.split("\n") for message in list(self.messages))

    def close(self) -> None:
        self.closed.set()
        self.thread.join()
        self.sock.close()


def test_systemd_hears_ready_once_healthy_and_watchdog_pings_only_while_it_stays_so(
    home: Path,
) -> None:
    systemd = Systemd(home / "notify.sock")
    env = child_env(home, NOTIFY_SOCKET=str(systemd.path), WATCHDOG_USEC="1500000")
    runtime = Runtime(home, port=free_port(), env=env)
    try:
        runtime.wait_ready()
        wait_for(lambda: systemd.heard("READY=1"), 5, what="READY=1")
        ready = next(m for m in systemd.messages if "READY=1" in m.split("\n"))
        assert f"MAINPID={runtime.popen.pid}" in ready.split("\n")
        assert runtime.api("GET", "/health").json()["status"] == "ok"
        wait_for(lambda: systemd.heard("WATCHDOG=1") >= 2, 10, what="watchdog pings")
        # A service that hangs: alive, answering nothing. The pings stop...
        pid = int(health(runtime)["motion"]["pid"])
        os.kill(pid, signal.SIGSTOP)
        try:
            time.sleep(1.5)  # a check under way when it froze may still have passed
            pinged = systemd.heard("WATCHDOG=1")
            time.sleep(3.0)  # six of the watchdog's intervals
            assert systemd.heard("WATCHDOG=1") == pinged
        finally:
            os.kill(pid, signal.SIGCONT)
        # ... and start again once it answers.
        wait_for(lambda: systemd.heard("WATCHDOG=1") > pinged, 10, what="pings again")
        # No child of the launcher was given the socket to speak for it.
        assert all(
            b"NOTIFY_SOCKET" not in Path(f"/proc/{int(s['pid'])}/environ").read_bytes()
            for s in health(runtime).values()
            if "pid" in s
        )
        runtime.popen.send_signal(signal.SIGINT)
        assert runtime.popen.wait(20) == 0
        assert systemd.heard("STOPPING=1") == 1
    finally:
        runtime.stop()
        systemd.close()


def test_a_bad_config_file_stops_start_up_with_its_reason(home: Path) -> None:
    config = home / "bad.yaml"
    config.write_text("port: 8080\ndevices:\n  - {driver: sim-robot, nmae: typo}\n")
    result = subprocess.run(
        [sys.executable, "-m", "openpendant.runtime.cli", "run", "--config", str(config)],
        env=whole_cell_env(home),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode != 0
    assert "nmae" in result.stderr
