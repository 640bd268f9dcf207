"""The simulated robot as a driver process, over its HTTP and WebSocket API."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import httpx
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

from openpendant.runtime.bench.harness.processes import STILL, SimRobotProc, wait_for
from openpendant.runtime.kit.device_auth import HEADER as DEVICE_AUTH
from openpendant.runtime.kit.device_auth import DeviceAuth, proof, sign
from openpendant.runtime.robotics.robot_info import load_robot_info

INFO = load_robot_info("ur5")
LOWER = np.array([j.lower for j in INFO.joints])
UPPER = np.array([j.upper for j in INFO.joints])
VMAX = np.array([j.max_velocity for j in INFO.joints])
AMAX = np.array([j.max_acceleration for j in INFO.joints])


class Robot:
    """The driver as the runtime it is paired with talks to it (every command signed)."""

    def __init__(self, sim: SimRobotProc) -> None:
        self.sim = sim
        self.http = sim.client()
        self.ws_url = sim.url.replace("http://", "ws://")

    def command_socket(self) -> Any:
        return connect(
            f"{self.ws_url}/command/ws", additional_headers=self.sim.signed("/command/ws")
        )

    def call(self, method: str, path: str, body: Any = None, expect: int = 200) -> Any:
        response = self.http.request(method, path, json=body)
        assert response.status_code == expect, response.text
        return response.json() if response.content else None

    def state(self) -> dict[str, Any]:
        return self.call("GET", "/state")  # type: ignore[no-any-return]

    def setpoints(self, after: int) -> dict[str, Any]:
        return self.call("GET", f"/sim/setpoints?after={after}")  # type: ignore[no-any-return]

    def jog(self, velocity: list[float], seconds: float, timeout: float = 0.1) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.call("POST", "/jog_joint", {"velocity": velocity, "timeout": timeout}, 204)
            time.sleep(0.02)

    def stopped(self) -> bool:
        return bool(np.allclose(self.state()["joint_velocity"], 0.0))

    def recover(self) -> None:
        self.call("POST", "/sim/estop", {"engaged": False})
        self.call("POST", "/reset_errors")
        self.call("POST", "/enable")
        self.call("PUT", "/command_mode", {"mode": "halt"})


@pytest.fixture
def robot(sim: SimRobotProc) -> Iterator[Robot]:
    r = Robot(sim)
    r.recover()
    wait_for(r.stopped, 5, what="robot at rest")
    yield r
    r.http.close()


def assert_setpoints_within_limits(samples: dict[str, Any]) -> None:
    q, v, a = (np.array(samples[k]) for k in ("position", "velocity", "acceleration"))
    assert len(q) > 0
    assert np.all(q >= LOWER - 1e-9)
    assert np.all(q <= UPPER + 1e-9)
    assert np.all(np.abs(v) <= VMAX * (1 + 1e-6))
    assert np.all(np.abs(a) <= AMAX * (1 + 1e-6))
    # The cycle-to-cycle steps agree with the reported velocities: nothing jumps.
    assert np.all(np.abs(np.diff(q, axis=0)) <= VMAX * 0.002 * (1 + 1e-6))


def test_identity_info_and_health(sim: SimRobotProc, robot: Robot) -> None:
    described = robot.call("GET", "/info")
    assert described["identity"]["uuid"] == sim.uuid
    assert described["identity"]["kind"] == "robot"
    assert described["info"]["joints"][0]["name"] == "shoulder_pan_joint"
    assert robot.call("GET", "/health")["status"] == "ok"


def test_joint_jog_moves_then_stops_on_command_timeout(robot: Robot) -> None:
    robot.call("PUT", "/command_mode", {"mode": "jog"})
    start = robot.state()
    # Each command lives 300 ms, so a test process that the host stalls between two commands
    # does not make the driver time out early; the jog goes on until J6 has turned 0.3 rad.
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        robot.call("POST", "/jog_joint", {"velocity": [0, 0, 0, 0, 0, 0.6], "timeout": 0.3}, 204)
        moving = robot.state()
        if moving["joint_position"][5] - start["joint_position"][5] > 0.3:
            break
        time.sleep(0.02)
    assert moving["joint_velocity"][5] > 0.5
    timeouts_before = robot.call("GET", "/sim/loop_stats")["command_timeouts"]
    # No more commands: the driver halts by itself once the command timeout lapses.
    wait_for(robot.stopped, 2, what="halt after command timeout")
    stats = robot.call("GET", "/sim/loop_stats")
    assert stats["command_timeouts"] == timeouts_before + 1
    end = robot.state()
    moved = np.array(end["joint_position"]) - np.array(start["joint_position"])
    assert moved[5] > 0.3
    assert np.allclose(moved[:5], 0.0)
    assert_setpoints_within_limits(robot.setpoints(start["seqno"]))


def test_limits_hold_through_jogs_streams_and_trajectories(robot: Robot) -> None:
    first = robot.state()["seqno"]
    robot.call("PUT", "/command_mode", {"mode": "jog"})
    robot.jog((VMAX * [1, -1, 1, 1, -1, 1]).tolist(), seconds=0.4)  # every joint at full speed
    robot.call("PUT", "/command_mode", {"mode": "position_command"})  # passes through halt
    here = np.array(robot.state()["joint_position"])
    for k in range(40):
        target = here + 0.3 * np.sin(k / 6.0)
        robot.call("POST", "/position_command", {"position": target.tolist()}, 204)
        time.sleep(0.01)
    robot.call("PUT", "/command_mode", {"mode": "trajectory"})
    wait_for(robot.stopped, 3, what="stop before trajectory")
    start = np.array(robot.state()["joint_position"])
    goal = np.clip(start + np.array([0.5, -0.3, 0.4, 0.2, 0.2, -0.5]), LOWER, UPPER)
    accepted = robot.call(
        "POST",
        "/trajectory",
        {
            "waypoints": [
                {"time_from_start": 0.8, "position": ((start + goal) / 2).tolist()},
                {"time_from_start": 1.6, "position": goal.tolist()},
            ]
        },
    )
    status = wait_for(
        lambda: (
            (s := robot.call("GET", f"/trajectory/{accepted['id']}"))["state"] == "finished" and s
        ),
        10,
        what="trajectory finished",
    )
    assert status["progress"] == 1.0
    assert np.allclose(robot.state()["joint_position"], goal, atol=1e-6)
    samples = robot.setpoints(first)
    assert samples["seqno"][0] == first + 1  # the whole run is in the buffer
    assert_setpoints_within_limits(samples)


def test_estop_halts_and_blocks_motion_until_released(robot: Robot) -> None:
    robot.call("PUT", "/command_mode", {"mode": "jog"})
    robot.jog([0.0, 1.5, 0.0, 0.0, 0.0, 0.0], seconds=0.4, timeout=1.0)
    state = robot.call("POST", "/sim/estop", {"engaged": True})
    assert state["flags"]["estop"]
    assert not state["flags"]["enabled"]
    assert state["command_mode"] == "halt"
    wait_for(robot.stopped, 1, what="stop after E-stop")
    refused = robot.http.post("/jog_joint", json={"velocity": [0.1] * 6, "timeout": 0.1})
    assert refused.status_code == 409
    assert refused.json()["error"]["code"] == "estop"
    assert robot.http.post("/enable").json()["error"]["code"] == "estop"
    robot.call("POST", "/sim/estop", {"engaged": False})
    robot.call("POST", "/enable")
    robot.call("PUT", "/command_mode", {"mode": "jog"})


def test_fault_needs_a_reset(robot: Robot) -> None:
    state = robot.call("POST", "/sim/fault", {"message": "simulated protective stop"})
    assert state["flags"]["error"]
    assert state["error_message"] == "simulated protective stop"
    refused = robot.http.put("/command_mode", json={"mode": "jog"})
    assert refused.json()["error"]["code"] == "robot_fault"
    robot.call("POST", "/reset_errors")
    robot.call("PUT", "/command_mode", {"mode": "jog"})


@pytest.mark.parametrize(
    ("path", "raw", "status", "code"),
    [
        (
            "/jog_joint",
            '{"velocity": [NaN, 0, 0, 0, 0, 0], "timeout": 0.1}',
            422,
            "invalid_request",
        ),
        (
            "/jog_joint",
            '{"velocity": [0, 0, 0, 0, 0, Infinity], "timeout": 0.1}',
            422,
            "invalid_request",
        ),
        ("/jog_joint", '{"velocity": [0, 0, 0], "timeout": 0.1}', 409, "wrong_length"),
        ("/jog_joint", '{"velocity": [9, 0, 0, 0, 0, 0], "timeout": 0.1}', 409, "velocity_limit"),
        ("/jog_joint", '{"velocity": [0, 0, 0, 0, 0, 0], "timeout": 5}', 422, "invalid_request"),
        ("/jog_joint", '{"velocity": "fast"}', 422, "invalid_request"),
        ("/jog_joint", "not json", 422, "invalid_request"),
    ],
)
def test_bad_jog_commands_are_refused_and_nothing_moves(
    robot: Robot, path: str, raw: str, status: int, code: str
) -> None:
    robot.call("PUT", "/command_mode", {"mode": "jog"})
    before = robot.state()["joint_position"]
    response = robot.http.post(path, content=raw, headers={"content-type": "application/json"})
    assert response.status_code == status
    assert response.json()["error"]["code"] == code
    time.sleep(0.1)
    assert robot.state()["joint_position"] == before


def test_out_of_limit_targets_are_refused_before_anything_moves(robot: Robot) -> None:
    robot.call("PUT", "/command_mode", {"mode": "position_command"})
    before = robot.state()["joint_position"]
    bad = list(before)
    bad[2] = 3.5  # elbow limit is ±π
    response = robot.http.post("/position_command", json={"position": bad})
    assert response.json()["error"]["code"] == "position_limit"
    robot.call("PUT", "/command_mode", {"mode": "trajectory"})
    too_fast = robot.http.post(
        "/trajectory",
        json={
            "waypoints": [
                {
                    "time_from_start": 0.1,
                    "position": [b - 1.0 if b > 0 else b + 1.0 for b in before],
                }
            ]
        },
    )
    assert too_fast.json()["error"]["code"] == "velocity_limit"
    time.sleep(0.1)
    assert robot.state()["joint_position"] == before


def test_commands_in_the_wrong_mode_are_refused(robot: Robot) -> None:
    response = robot.http.post("/jog_joint", json={"velocity": [0.1] * 6})
    assert response.status_code == 409
    assert response.json()["error"]["code"] == "wrong_mode"


def test_state_streams_over_websocket(robot: Robot) -> None:
    with connect(f"{robot.ws_url}/state/ws") as ws:
        seqnos = [json.loads(ws.recv(timeout=2))["seqno"] for _ in range(30)]
    assert seqnos == sorted(seqnos)
    # The state a subscriber gets on connecting can come again on the first tick when the
    # host stalled the control loop meanwhile; after that every message is a new state.
    assert len(set(seqnos[1:])) == 29


def test_a_dropped_command_stream_halts_the_robot(robot: Robot) -> None:
    robot.call("PUT", "/command_mode", {"mode": "jog"})
    timeouts_before = robot.call("GET", "/sim/loop_stats")["command_timeouts"]
    with robot.command_socket() as ws:
        ws.send(json.dumps({"type": "jog_joint", "velocity": [0.5, 0, 0, 0, 0, 0], "timeout": 1.0}))
        ws.send(json.dumps({"type": "jog_joint", "velocity": ["NaN"]}))
        error = json.loads(ws.recv(timeout=2))
        assert error["type"] == "error"
        assert error["error"]["code"] == "invalid_request"
        time.sleep(0.3)
        assert robot.state()["joint_velocity"][0] > 0.4
    # The socket closed long before the 1 s command timeout: the robot halts at once, and
    # not because the command ran out.
    wait_for(robot.stopped, 3, what="halt on dropped stream")
    assert robot.state()["command_mode"] == "halt"
    assert robot.call("GET", "/sim/loop_stats")["command_timeouts"] == timeouts_before


def test_a_silent_session_halts_the_robot_and_is_closed(robot: Robot) -> None:
    """The runtime's session: a trajectory (sent over HTTP) halts when the session's
    keepalives stop, and the session is closed, so commands held back by a lost network
    never move the robot when it returns."""
    robot.call("PUT", "/command_mode", {"mode": "trajectory"})
    q = robot.state()["joint_position"]
    goal = [q[0] + 0.8, *q[1:]]
    with robot.command_socket() as ws:
        ws.send(json.dumps({"type": "session", "timeout": 0.3}))
        ws.send(json.dumps({"type": "keepalive"}))
        path = {"waypoints": [{"time_from_start": 4.0, "position": goal}]}
        robot.call("POST", "/trajectory", path)
        wait_for(lambda: robot.state()["joint_velocity"][0] > 0.05, 3, what="trajectory moving")
        silent_from = time.monotonic()  # nothing more is sent on the session
        wait_for(robot.stopped, 3, what="halt on a silent session")
        assert robot.state()["command_mode"] == "halt"
        assert time.monotonic() - silent_from < 1.5
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=2)
        assert closed.value.rcvd is not None and closed.value.rcvd.code == 4000
    log = robot.call("GET", "/command_log")
    assert log[-1]["type"] == "halt" and log[-1]["tag"] == "session silent"


def test_a_session_that_closes_halts_a_trajectory(robot: Robot) -> None:
    robot.call("PUT", "/command_mode", {"mode": "trajectory"})
    q = robot.state()["joint_position"]
    goal = [q[0] + 0.8, *q[1:]]
    with robot.command_socket() as ws:
        ws.send(json.dumps({"type": "session", "timeout": 5.0}))
        robot.call(
            "POST", "/trajectory", {"waypoints": [{"time_from_start": 4.0, "position": goal}]}
        )
        wait_for(lambda: robot.state()["joint_velocity"][0] > 0.05, 3, what="trajectory moving")
    wait_for(robot.stopped, 3, what="halt on a closed session")
    assert robot.call("GET", "/command_log")[-1]["tag"] == "command stream closed"


def test_refusals_on_the_command_stream_name_their_command(robot: Robot) -> None:
    with robot.command_socket() as ws:
        ws.send(json.dumps({"type": "jog_joint", "id": 17, "velocity": [0.1] * 6}))
        error = json.loads(ws.recv(timeout=2))
    assert error["id"] == 17
    assert error["error"]["code"] == "wrong_mode"


def test_the_driver_obeys_only_the_runtime_it_is_paired_with(
    sim: SimRobotProc, robot: Robot
) -> None:
    """Issue 15: PUT /command_mode then POST /jog_joint, straight to the robot's port, moved a
    joint 20 degrees."""
    before = np.array(robot.state()["joint_position"])
    strangers = (
        httpx.Client(base_url=sim.url, timeout=5),
        httpx.Client(base_url=sim.url, timeout=5, auth=DeviceAuth("not-the-secret-at-all")),
    )
    for stranger in strangers:
        for method, path, body in (
            ("POST", "/enable", None),
            ("PUT", "/command_mode", {"mode": "jog"}),
            ("POST", "/jog_joint", {"velocity": [0.3, 0, 0, 0, 0, 0], "timeout": 0.5}),
        ):
            refused = stranger.request(method, path, json=body)
            assert refused.status_code == 401, (method, path)
            assert refused.json()["error"]["code"] == "device_auth"
        stranger.close()
    with pytest.raises(InvalidStatus):
        connect(f"{robot.ws_url}/command/ws", open_timeout=5)
    # A signature is good once: replayed, it is refused.
    header = {DEVICE_AUTH: sign(sim.secret, "POST", "/enable", boot=sim.boot())}
    assert httpx.post(f"{sim.url}/enable", headers=header).status_code == 200
    assert httpx.post(f"{sim.url}/enable", headers=header).status_code == 401
    # A signature covers its body: another body under it is refused.
    signed = sign(sim.secret, "PUT", "/command_mode", boot=sim.boot(), body=b'{"mode":"jog"}')
    other = httpx.put(
        f"{sim.url}/command_mode",
        headers={DEVICE_AUTH: signed, "content-type": "application/json"},
        content=b'{"mode":"halt"}',
    )
    assert other.status_code == 401
    # What it is and how it is stay readable; the proof answers a challenge, not the secret,
    # and covers the address the challenge reached it at.
    assert httpx.get(f"{sim.url}/state").status_code == 200
    with connect(f"{robot.ws_url}/state/ws") as ws:
        assert json.loads(ws.recv(timeout=5))["joint_position"]
    nonce = "n" * 32
    answer = httpx.get(f"{sim.url}/pair/proof", params={"nonce": nonce}).json()
    address = sim.url.removeprefix("http://")
    assert answer == {"proof": proof(sim.secret, nonce, address), "address": address}
    assert sim.secret not in str(answer)
    assert np.abs(np.array(robot.state()["joint_position"]) - before).max() < STILL


def test_a_command_captured_before_a_restart_is_refused_after_it(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """A `POST /disable` replayed to the restarted driver answered 200, and a replayed
    command socket's handshake opened it: what a driver has used was remembered only in its
    memory. A signature is for one process of the driver (its boot id) now."""
    home = tmp_path_factory.mktemp("replayed")
    first = SimRobotProc(home, name="replayed")
    first.wait_ready()
    try:
        url, ws_url = first.url, first.url.replace("http://", "ws://")
        boot = first.boot()
        disable = {DEVICE_AUTH: sign(first.secret, "POST", "/disable", boot=boot)}
        handshake = first.signed("/command/ws")
        assert httpx.post(f"{url}/disable", headers=disable).status_code == 200
        with connect(f"{ws_url}/command/ws", additional_headers=handshake, open_timeout=5):
            pass
    finally:
        first.stop()
    again = SimRobotProc(home, name="replayed", port=int(url.rsplit(":", 1)[1]))
    again.wait_ready()
    try:
        assert again.url == url and again.boot() != boot
        replayed = httpx.post(f"{url}/disable", headers=disable)
        assert replayed.status_code == 401
        assert replayed.json()["error"]["code"] == "device_auth"
        with pytest.raises(InvalidStatus):
            connect(f"{ws_url}/command/ws", additional_headers=handshake, open_timeout=5)
        # Its paired runtime's own commands, signed for the new process, are obeyed.
        with again.client() as paired:
            assert paired.post("/disable").status_code == 200
    finally:
        again.stop()
