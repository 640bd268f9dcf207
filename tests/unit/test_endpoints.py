"""An interface declared once with `@endpoint`: the driver's routes are generated from it, and
the typed client calls the same declarations over the device's link."""

from __future__ import annotations

import asyncio
import json
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from pydantic import BaseModel

from openpendant.runtime.clients.base import DeviceClient
from openpendant.runtime.clients.kinds import GripperClient, IOClient
from openpendant.runtime.clients.robot import STREAM_TYPES, RobotClient
from openpendant.runtime.drivers.command_log import CommandLog
from openpendant.runtime.drivers.routes import interface_router
from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.endpoints import endpoint, endpoints
from openpendant.runtime.interfaces.gripper import Gripper, GripperMotion
from openpendant.runtime.interfaces.io import IOBlock, SignalWrite
from openpendant.runtime.interfaces.robot import (
    CommandModeRequest,
    FreedriveCommand,
    JogJointCommand,
    PositionCommand,
    Robot,
    ToolCommand,
    VelocityCommand,
)
from openpendant.runtime.kit.app import install_error_handlers
from openpendant.runtime.kit.errors import NotFound, OpenPendantError, RobotError
from openpendant.runtime.links.hub import DeviceView, LinkHub


class Level(Strict):
    value: float
    tag: str | None = None


class Reading(BaseModel):
    name: str
    value: float


class Tank(ABC):
    @endpoint("PUT", "/levels/{name}", body=Level, returns=Reading, label=lambda n, b: f"fill:{n}")
    @abstractmethod
    async def fill(self, name: str, level: Level) -> Reading: ...

    @endpoint("GET", "/levels/{name}", returns=Reading)
    @abstractmethod
    async def read(self, name: str) -> Reading: ...

    @endpoint("POST", "/drain")
    @abstractmethod
    async def drain(self) -> None: ...


class FakeTank(Tank):
    def __init__(self) -> None:
        self.levels: dict[str, float] = {}

    async def fill(self, name: str, level: Level) -> Reading:
        if level.value > 10:
            raise RobotError("overflow", code="overflow")
        self.levels[name] = level.value
        return Reading(name=name, value=level.value)

    async def read(self, name: str) -> Reading:
        if name not in self.levels:
            raise NotFound(f"no level {name}")
        return Reading(name=name, value=self.levels[name])

    async def drain(self) -> None:
        self.levels.clear()


@pytest.fixture
def served() -> tuple[TestClient, FakeTank, CommandLog]:
    tank, log = FakeTank(), CommandLog()
    app = FastAPI()
    install_error_handlers(app)
    app.include_router(interface_router(tank, log))
    return TestClient(app), tank, log


def test_routes_are_generated_from_the_declarations(
    served: tuple[TestClient, FakeTank, CommandLog],
) -> None:
    http, tank, log = served
    answer = http.put("/levels/a", json={"value": 2.5, "tag": "t1"})
    assert answer.status_code == 200 and answer.json() == {"name": "a", "value": 2.5}
    assert http.get("/levels/a").json()["value"] == 2.5
    assert http.post("/drain").status_code == 204 and tank.levels == {}
    # Commands are logged with their label and tag; reads are not.
    assert [(c.type, c.tag) for c in log.since(0)] == [("fill:a", "t1"), ("drain", None)]


def test_bad_bodies_are_refused_before_the_driver_sees_them(
    served: tuple[TestClient, FakeTank, CommandLog],
) -> None:
    http, tank, log = served
    for body in ({"value": "NaN"}, {"value": 1, "extra": 2}, {}):
        response = http.put("/levels/b", json=body)
        assert response.status_code == 422, body
    assert (
        http.put(
            "/levels/b", content="1e999", headers={"content-type": "application/json"}
        ).status_code
        == 422
    )
    assert tank.levels == {} and log.since(0) == []
    refused = http.put("/levels/b", json={"value": 11})
    assert refused.status_code == 409 and refused.json()["error"]["code"] == "overflow"
    assert http.get("/levels/zz").status_code == 404


def test_the_standard_interfaces_declare_their_wire() -> None:
    robot = endpoints(Robot)
    assert robot["set_digital_output"].path == "/digital_outputs/{index}"
    assert robot["jog_joint"].stream == "jog_joint"
    assert {
        CommandModeRequest: "command_mode",
        JogJointCommand: "jog_joint",
        VelocityCommand: "velocity_command",
        PositionCommand: "position_command",
        FreedriveCommand: "freedrive",
    } == STREAM_TYPES
    assert set(endpoints(Gripper)) == {"activate", "open", "close", "move", "stop"}
    assert endpoints(IOBlock)["write"].params == ["name"]


class FakeHub(LinkHub):
    """Answers calls as a driver would, and keeps what was sent."""

    def __init__(self, answers: dict[tuple[str, str], tuple[int, Any]]) -> None:
        super().__init__("http://127.0.0.1:9", "test", 0.2)
        self.answers = answers
        self.calls: list[tuple[str, int, str, str, Any]] = []
        self.sent: list[tuple[str, int, dict[str, Any]]] = []

    async def call(
        self,
        name: str,
        generation: int,
        method: str,
        path: str,
        body: Any = None,
        claim: str | None = None,
        body_text: str | None = None,
    ) -> tuple[int, Any]:
        sent = json.loads(body_text) if body_text is not None else body
        self.calls.append((name, generation, method, path, sent))
        return self.answers[(method, path)]

    async def send(
        self, name: str, generation: int, command: dict[str, Any], claim: str | None = None
    ) -> None:
        self.sent.append((name, generation, command))


def client_of(kind: type[DeviceClient[Any]], hub: FakeHub) -> Any:
    view = DeviceView("dev", generation=7)
    return kind(hub, view)


GRIPPED: dict[str, Any] = {"seqno": 1, "ts": 0.0, "connected": True, "activated": True}


def test_a_typed_client_calls_the_declared_endpoint_over_the_link() -> None:
    hub = FakeHub(
        {
            ("POST", "/close"): (200, {**GRIPPED, "object_detected": True}),
            ("PUT", "/signals/do1"): (200, {"name": "do1", "value": True, "ts": 1.0}),
            ("PUT", "/signals/do9"): (
                404,
                {"error": {"code": "unknown_signal", "message": "no do9"}},
            ),
        }
    )
    gripper: GripperClient = client_of(GripperClient, hub)
    state = asyncio.run(gripper.close(GripperMotion(force=20.0)))
    assert state.object_detected is True
    assert hub.calls[-1] == (
        "dev",
        7,
        "POST",
        "/close",
        {"position": None, "speed": None, "force": 20.0},
    )
    io: IOClient = client_of(IOClient, hub)
    assert asyncio.run(io.write("do1", SignalWrite(value=True))).value is True
    with pytest.raises(NotFound, match="no do9"):
        asyncio.run(io.write("do9", SignalWrite(value=True)))
    # A signal name is one path segment, whatever it holds: it reaches no other route.
    write = endpoints(IOBlock)["write"]
    assert write.url("a/../b") == "/signals/a%2F..%2Fb"
    with pytest.raises(ValueError, match=r"'\.\.'"):
        write.url("..")


def test_a_robot_client_streams_commands_in_order_and_refusals_are_typed() -> None:
    hub = FakeHub({("POST", "/tool"): (409, {"error": {"code": "estop", "message": "E-stop"}})})
    robot: RobotClient = client_of(RobotClient, hub)
    asyncio.run(robot.stream(VelocityCommand(velocity=[0.1] * 6, timeout=0.2, tag="p#1"), 7))
    asyncio.run(robot.jog_joint(JogJointCommand(velocity=[0.0] * 6)))
    assert [m for _, _, m in hub.sent] == [
        {"type": "velocity_command", "velocity": [0.1] * 6, "timeout": 0.2, "tag": "p#1"},
        {"type": "jog_joint", "velocity": [0.0] * 6, "timeout": 0.2},
    ]
    with pytest.raises(RobotError) as refused:
        asyncio.run(robot.set_tool(ToolCommand(open=True)))
    assert refused.value.code == "estop"
    assert isinstance(refused.value, OpenPendantError)


class Probe(DeviceClient[Reading]):
    kind: ClassVar[str] = "probe"
    state_model = Reading


def test_a_clients_state_is_parsed_once_per_state() -> None:
    hub = FakeHub({})
    probe: Probe = client_of(Probe, hub)
    assert probe.latest() is None  # nothing yet, and the link is down: no state to trust
