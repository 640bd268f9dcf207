"""The foundation scenario: the whole runtime, a second simulated robot found by discovery,
added, streaming, surviving restarts of the runtime and of the robot (at a new address)."""

from __future__ import annotations

import json
import os
import time
from functools import partial
from pathlib import Path
from typing import Any

from websockets.sync.client import connect

from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, free_port, wait_for


def detected(runtime: Runtime, uuid: str) -> list[dict[str, Any]]:
    return [d for d in runtime.api("GET", "/devices/detected").json() if d["uuid"] == uuid]


def added(runtime: Runtime, name: str) -> dict[str, Any] | None:
    return next((d for d in runtime.api("GET", "/devices").json() if d["local_name"] == name), None)


def connected(runtime: Runtime, name: str) -> dict[str, Any] | None:
    device = added(runtime, name)
    return device if device and device["status"] == "connected" else None


def state_seqno(runtime: Runtime, name: str) -> int:
    response = runtime.api("GET", f"/devices/{name}/state")
    assert response.status_code == 200, response.text
    return int(response.json()["seqno"])


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}/status").read_text().find("State:\tZ") < 0


def move_a_little(runtime: Runtime, robot: str) -> str:
    """Take control, enable, and make a small planned joint move; its final state."""
    token = runtime.api("POST", f"/devices/{robot}/lease", json={"holder": "tests"}).json()
    headers = {"X-Lease-Token": token["token"]}
    enabled = runtime.api("POST", f"/jog/robots/{robot}/enable", headers=headers)
    assert enabled.status_code == 200, enabled.text
    q = runtime.api("GET", f"/devices/{robot}/state").json()["joint_position"]
    target = [q[0] + (0.1 if q[0] < 0 else -0.1), *q[1:]]
    request = {"kind": "joint", "target": {"joints": target}, "speed": 1.0}
    started = runtime.api(
        "POST", f"/motion/robots/{robot}/moves", json=request, headers=headers, params={"wait": 20}
    )
    assert started.status_code == 202, started.text
    runtime.api("DELETE", f"/devices/{robot}/lease", headers=headers)
    status = started.json()
    # The whole status when it did not finish: its code and message say why.
    return "finished" if status["state"] == "finished" else json.dumps(status)


def test_discover_add_stream_and_survive_restarts(home: Path) -> None:
    runtime = Runtime(home)
    second = SimRobotProc(home, name="second-ur5", model="ur5")
    try:
        runtime.wait_ready()
        second.wait_ready()
        # The driver is advertising; the device manager must list it. (How fast is a
        # benchmark figure, discovery_time; here a generous bound only catches a hang.)
        advertised = time.monotonic()
        found = wait_for(lambda: detected(runtime, second.uuid), 10, what="detected")
        print(f"detected {time.monotonic() - advertised:.3f} s after the driver was ready")
        assert found[0]["kind"] == "robot"
        assert found[0]["model"] == "ur5"
        assert found[0]["name"] == "second-ur5"
        assert found[0]["address"] == second.url.removeprefix("http://")

        response = runtime.api(
            "POST", "/devices", json={"uuid": second.uuid, "local_name": "robot2"}
        )
        assert response.status_code == 201, response.text
        wait_for(lambda: connected(runtime, "robot2"), 10, what="robot2 connected")

        # Its state streams: through REST (newer and newer) and through the live socket.
        first = state_seqno(runtime, "robot2")
        wait_for(lambda: state_seqno(runtime, "robot2") > first + 10, 5, what="state moving")
        ws_url = runtime.url.replace("http", "ws") + "/api/devices/ws"
        with connect(ws_url, additional_headers=runtime.auth("viewer")) as ws:
            kinds: set[str] = set()
            states: list[int] = []
            while len(states) < 20:
                message = json.loads(ws.recv(timeout=5))
                kinds.add(message["type"])
                if message["type"] == "state" and message["device"] == "robot2":
                    states.append(message["state"]["seqno"])
        assert {"detected", "devices", "state"} <= kinds
        assert states == sorted(states)

        # Stop the runtime: everything it started goes away.
        child_pids = [
            int(h["pid"])
            for h in runtime.api("GET", "/health").json()["services"].values()
            if "pid" in h
        ]
        assert runtime.stop() == 0
        assert not any(pid_alive(pid) for pid in child_pids)

        # Start it again on the same data: robot2 is still added and reconnects.
        runtime = Runtime(home, port=runtime.port)
        runtime.wait_ready()
        device = added(runtime, "robot2")
        assert device is not None
        assert device["uuid"] == second.uuid
        wait_for(lambda: connected(runtime, "robot2"), 10, what="robot2 reconnected")

        # Jog and motion have used robot2 before it moves (they hold its link)...
        assert move_a_little(runtime, "robot2") == "finished"
        # Restart the driver on another port: the same device is updated, not duplicated.
        old_url = second.url
        second.stop()
        wait_for(lambda: not connected(runtime, "robot2"), 10, what="robot2 seen gone")
        second = SimRobotProc(home, name="second-ur5", model="ur5", port=free_port())
        second.wait_ready()
        assert second.url != old_url
        moved = wait_for(
            lambda: (d := connected(runtime, "robot2")) and d["url"] == second.url and d,
            10,
            what="robot2 connected at its new address",
        )
        assert moved["uuid"] == second.uuid
        # ... and the first move after the move succeeds: every service uses the one link.
        assert move_a_little(runtime, "robot2") == "finished"
        devices = runtime.api("GET", "/devices").json()
        assert [d["local_name"] for d in devices if d["uuid"] == second.uuid] == ["robot2"]
        assert len(detected(runtime, second.uuid)) == 1
        # The new address was stored, so a restart goes straight to it.
        record = runtime.api("GET", "/variables/devices.robot2").json()
        assert record["value"]["url"] == second.url
    finally:
        second.stop()
        runtime.stop()
    assert runtime.service_errors() == []


def test_adding_mistakes_get_clear_errors_and_change_nothing(home: Path) -> None:
    runtime = Runtime(home)
    try:
        runtime.wait_ready()
        sim = wait_for(
            lambda: runtime.api("GET", "/devices/detected").json(),
            10,
            what="default simulated robot detected",
        )[0]
        cases = [
            ({"uuid": "no-such-device", "local_name": "robot"}, 404, "device_not_detected"),
            ({"uuid": sim["uuid"], "local_name": "Robot One"}, 422, "invalid_request"),
            (
                {"uuid": sim["uuid"], "local_name": "robot", "url": sim["url"]},
                422,
                "invalid_request",
            ),
            ({"local_name": "robot"}, 422, "invalid_request"),
            ({"url": "http://127.0.0.1:9", "local_name": "robot"}, 400, "device_unreachable"),
        ]
        for body, status, code in cases:
            response = runtime.api("POST", "/devices", json=body)
            assert response.status_code == status, (body, response.text)
            assert response.json()["error"]["code"] == code
            if body.get("local_name") == "Robot One":
                assert "starts with a lowercase letter" in response.json()["error"]["message"]
        assert runtime.api("GET", "/devices").json() == []
        assert (
            runtime.api(
                "POST", "/devices", json={"uuid": sim["uuid"], "local_name": "robot"}
            ).status_code
            == 201
        )
        again = runtime.api("POST", "/devices", json={"uuid": sim["uuid"], "local_name": "arm"})
        assert again.json()["error"]["code"] == "already_added"
        taken = runtime.api("POST", "/devices", json={"url": sim["url"], "local_name": "robot"})
        assert taken.json()["error"]["code"] == "name_taken"
        missing = runtime.api("GET", "/devices/nobody/state")
        assert missing.status_code == 404
        assert missing.json()["error"]["code"] == "device_not_found"
        assert [d["local_name"] for d in runtime.api("GET", "/devices").json()] == ["robot"]
        removed = runtime.api("DELETE", "/devices/robot")
        assert removed.status_code == 200
        assert runtime.api("GET", "/devices").json() == []
        assert runtime.api("GET", "/variables/devices.robot").status_code == 404
    finally:
        runtime.stop()


def test_add_by_url_and_a_vanished_device_reports_disconnected(home: Path) -> None:
    runtime = Runtime(home, extra=["--no-sim"])
    sim = SimRobotProc(home, name="by-url", model="panda")
    try:
        runtime.wait_ready()
        sim.wait_ready()
        response = runtime.api("POST", "/devices", json={"url": sim.url, "local_name": "panda"})
        assert response.status_code == 201, response.text
        assert response.json()["uuid"] == sim.uuid
        assert response.json()["model"] == "panda"
        wait_for(lambda: connected(runtime, "panda"), 10, what="panda connected")
        details = runtime.api("GET", "/devices/panda").json()
        assert len(details["info"]["info"]["joints"]) == 7
        sim.kill()  # no goodbye: the connection just drops
        gone = wait_for(
            lambda: (d := added(runtime, "panda")) and d["status"] != "connected" and d,
            10,
            what="panda disconnected",
        )
        assert gone["last_error"]
        state = runtime.api("GET", "/devices/panda/state")
        assert state.status_code == 503
        assert state.json()["error"]["code"] == "device_disconnected"
    finally:
        sim.stop()
        runtime.stop()


def test_two_runtimes_on_one_network_do_not_share_a_robot(tmp_path: Path) -> None:
    """Each runtime's default simulated UR5 is its own device (its uuid is the
    installation's, kept across restarts): both are listed, each runtime adds its own."""
    first = Runtime(tmp_path / "a")
    second = Runtime(tmp_path / "b")
    try:
        first.wait_ready()
        second.wait_ready()
        own = []
        for runtime in (first, second):
            # Each hears both announcements, in its own time.
            detected = wait_for(partial(both_seen, runtime), 10, what="both robots seen")
            port = runtime_sim_port(runtime)
            mine = next(d for d in detected if d["url"].endswith(f":{port}"))
            added = runtime.api("POST", "/devices", json={"uuid": mine["uuid"], "local_name": "r"})
            assert added.status_code == 201, added.text
            own.append(mine["uuid"])
        assert own[0] != own[1]
        first.stop()
        first = Runtime(tmp_path / "a", port=first.port)
        first.wait_ready()
        wait_for(lambda: connected(first, "r"), 10, what="the same robot after a restart")
        assert added_uuid(first, "r") == own[0]
    finally:
        first.stop()
        second.stop()


def both_seen(runtime: Runtime) -> list[dict[str, Any]] | None:
    detected: list[dict[str, Any]] = runtime.api("GET", "/devices/detected").json()
    return detected if len({d["uuid"] for d in detected}) == 2 else None


def runtime_sim_port(runtime: Runtime) -> int:
    """The port of the simulated robot this runtime started (from its launcher's log)."""
    log = (runtime.data_dir / "logs" / "sim-robot-sim-ur5.log").read_text()
    ready = next(line for line in log.splitlines() if line.startswith('{"event": "ready"'))
    return int(json.loads(ready)["url"].rsplit(":", 1)[1])


def added_uuid(runtime: Runtime, name: str) -> str:
    return str(runtime.api("GET", f"/devices/{name}").json()["uuid"])
