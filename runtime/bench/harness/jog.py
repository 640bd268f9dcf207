"""A jog-socket client for tests and benchmarks, as the UI uses the socket."""

from __future__ import annotations

import itertools
import json
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import httpx
import numpy as np
from websockets.sync.client import ClientConnection, connect

from openpendant.runtime.bench.harness.processes import Runtime, wait_for
from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.device_auth import DeviceAuth, known_secret

_presses = itertools.count(1)


class JogClient:
    """The jog socket where the UI opens it: the jog service's own port (or, with
    `via_gateway`, through the webui at /api/jog/ws). `auth`: the sign-in's headers (a
    session's cookie and CSRF token, or a bearer token); by default the tests' operator."""

    def __init__(
        self,
        runtime: Runtime,
        robot: str = "robot",
        token: str | None = None,
        via_gateway: bool = False,
        auth: dict[str, str] | None = None,
    ) -> None:
        self.runtime = runtime
        self.robot = robot
        self.token = token
        url = runtime.ws_url("/jog/ws")
        headers = auth if auth is not None else runtime.auth("operator")
        port = runtime.api("GET", "/jog/settings").json()["socket_port"]
        if port and not via_gateway:
            # Straight to the jog service's port, with a ticket, as the UI opens it.
            ticket = runtime.api("POST", "/auth/ticket", role=None, headers=headers).json()[
                "ticket"
            ]
            url = f"ws://127.0.0.1:{port}/jog/ws?ticket={ticket}"
            headers = {}
        self._socket = connect(url, additional_headers=headers)
        self.ws: ClientConnection = self._socket.__enter__()
        self.messages: list[dict[str, Any]] = []

    def close(self) -> None:
        self._socket.__exit__(None, None, None)

    def send(self, message: dict[str, Any]) -> None:
        self.ws.send(json.dumps(message))

    def press(self, **fields: Any) -> str:
        press = f"t{next(_presses)}"
        message = {"type": "jog", "press": press, "robot": self.robot, "token": self.token}
        message.update(fields)
        self.send(message)
        return press

    def drain(self, timeout: float = 0.0) -> list[dict[str, Any]]:
        deadline = time.monotonic() + timeout
        while True:
            try:
                self.messages.append(
                    json.loads(self.ws.recv(timeout=max(0.0, deadline - time.monotonic())))
                )
            except TimeoutError:
                return self.messages

    def status(self, press: str, states: tuple[str, ...], timeout: float = 5.0) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for m in self.messages:
                if m.get("press") == press and m.get("state") in states:
                    return m
            self.drain(0.02)
        raise TimeoutError(f"press {press} never reached {states}: {self.messages[-5:]}")

    def hold(self, seconds: float, period: float = 0.03, **fields: Any) -> str:
        """Press and hold with heartbeats, then release."""
        press = self.press(**fields)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.send({"type": "heartbeat", "press": press})
            self.drain(period)
        self.send({"type": "release", "press": press})
        return press

    @contextmanager
    def held(self, press: str, period: float = 0.02) -> Iterator[None]:
        """Heartbeats for `press` from a thread of their own while the caller does other
        things (asks the robot, cuts a wire): a finger that stays on the glass, however
        long this test's own steps take."""
        done = threading.Event()

        def beat() -> None:
            while not done.wait(period):
                self.send({"type": "heartbeat", "press": press})

        thread = threading.Thread(target=beat, name=f"heartbeat {press}", daemon=True)
        thread.start()
        try:
            yield
        finally:
            done.set()
            thread.join()

    def move_to(self, waypoint: str, speed: float = 1.0, timeout: float = 20.0) -> dict[str, Any]:
        press = f"t{next(_presses)}"
        self.send(
            {
                "type": "move_to",
                "press": press,
                "robot": self.robot,
                "token": self.token,
                "waypoint": waypoint,
                "speed": speed,
            }
        )
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.send({"type": "heartbeat", "press": press})
            self.drain(0.03)
            for m in self.messages:
                if m.get("press") == press and m.get("state") not in (None, "moving"):
                    return m
        raise TimeoutError(f"move to {waypoint} did not finish")


class RobotView:
    """The robot as its driver sees it: state, every setpoint, the command log."""

    def __init__(self, runtime: Runtime, name: str = "robot") -> None:
        self.runtime = runtime
        self.name = name
        device = runtime.api("GET", f"/devices/{name}").json()
        self.url = device["url"]
        # Signed as the runtime signs (the device and the runtime keep its secret).
        secret = known_secret(runtime.data_dir, device["uuid"])
        auth = DeviceAuth(secret, follow_restarts=True) if secret else None
        self.http = httpx.Client(base_url=self.url, timeout=5, auth=auth, verify=CLIENT_TLS)

    def state(self) -> dict[str, Any]:
        return self.http.get("/state").json()  # type: ignore[no-any-return]

    @contextmanager
    def faster(self, scale: int = 5) -> Iterator[None]:
        """Within: the simulated robot plays its trajectories `scale` times faster than real
        time (for a test whose moves only need to end)."""
        self.http.put("/sim/time_scale", json={"scale": scale}).raise_for_status()
        try:
            yield
        finally:
            self.http.put("/sim/time_scale", json={"scale": 1}).raise_for_status()

    def q(self) -> np.ndarray[Any, Any]:
        return np.array(self.state()["joint_position"])

    def stopped(self) -> bool:
        return bool(np.allclose(self.state()["joint_velocity"], 0.0))

    def wait_stopped(self, timeout: float = 5.0) -> None:
        wait_for(self.stopped, timeout, what="robot at rest")

    def setpoints(self, after: int) -> dict[str, Any]:
        return self.http.get("/sim/setpoints", params={"after": after}).json()  # type: ignore[no-any-return]

    def commands(self, after: int = 0) -> list[dict[str, Any]]:
        return self.http.get("/command_log", params={"after": after}).json()  # type: ignore[no-any-return]

    def last_command_seq(self) -> int:
        log = self.commands()
        return int(log[-1]["seq"]) if log else 0


class Cell:
    def __init__(self, runtime: Runtime, uuid: str | None = None) -> None:
        """The runtime's own simulated robot (or the device `uuid`) added as "robot"."""
        self.runtime = runtime
        uuid = uuid or runtime.own_device()["uuid"]
        wait_for(lambda: runtime.is_detected(uuid), 10, what=f"{uuid} detected")
        runtime.api("POST", "/devices", json={"uuid": uuid, "local_name": "robot"})
        wait_for(lambda: runtime.api("GET", "/devices").json()[0]["status"] == "connected", 10)
        self.token = runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()[
            "token"
        ]
        self.robot = RobotView(runtime)

    def headers(self) -> dict[str, str]:
        return {"X-Lease-Token": self.token}

    def ready(self) -> None:
        """Enabled, no error, lease renewed."""
        self.robot.http.post("/sim/estop", json={"engaged": False})
        # Renewed, or taken afresh (with a new token) when it lapsed during a long test.
        self.token = self.runtime.api(
            "POST", "/devices/robot/lease", json={"holder": "tests"}, headers=self.headers()
        ).json()["token"]
        self.runtime.api("POST", "/jog/robots/robot/reset_errors", headers=self.headers())
        response = self.runtime.api("POST", "/jog/robots/robot/enable", headers=self.headers())
        assert response.status_code == 200, response.text

    def place(self, joints: list[float] | np.ndarray[Any, Any]) -> None:
        """The arm put there at once by its simulator (set-up, not the motion under test),
        then the runtime's view of it waited for."""
        self.robot.wait_stopped()
        response = self.robot.http.put("/sim/joints", json={"joints": list(map(float, joints))})
        assert response.status_code == 200, response.text
        target = np.array(joints, dtype=float)

        def seen() -> bool:
            state = self.runtime.api("GET", "/devices/robot/state").json()
            return bool(np.abs(np.array(state["joint_position"]) - target).max() < 1e-9)

        wait_for(seen, 5, what="the runtime seeing the robot placed")
