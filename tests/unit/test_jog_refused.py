"""A jog press that ends refused after it may have moved the robot halts it (issue 31): a
refusal coming back from the robot, a cycle of the press failing, and a press failing at its
first command while another one was moving. After the halt nothing streams until a new press.

The real jogger, robot client and link hub, against the device manager's link socket
(`/devices/_links`) served in this process: it streams a ready robot's state at 100 Hz,
refuses a command when the test says so, and records everything the service sends."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import AsyncIterator, Callable
from typing import Any, cast

import numpy as np
import pytest
import websockets
from websockets.asyncio.server import ServerConnection

from openpendant.runtime.clients.input import InputClient
from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.input import InputState
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    OperationalMode,
    RobotDescription,
    RobotFlags,
    RobotState,
)
from openpendant.runtime.jog.actions import JointVelocityJog, MouseJog
from openpendant.runtime.jog.jogger import Ended, Jogger
from openpendant.runtime.kit.errors import Conflict, RobotError
from openpendant.runtime.links.hub import LinkHub
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info

ROBOT = "arm"
GENERATION = 7
INFO = load_robot_info("ur5e")
DESCRIPTION = RobotDescription(
    identity=DeviceIdentity(uuid="ur-1", kind="robot", model=INFO.model, name=ROBOT), info=INFO
).model_dump(mode="json")
KINEMATICS = Kinematics(INFO)
AFTER = 20  # states the link sends after a halt while the test looks for stray commands
FAULT = {"code": "robot_fault", "message": "the robot has an error: protective stop"}


class LinkSocket:
    """The device manager's side of the link socket, for one ready robot."""

    def __init__(self) -> None:
        self.ops: list[dict[str, Any]] = []
        self.seqno = 0
        self.mode = CommandMode.halt
        self.url = ""
        self._ws: ServerConnection | None = None

    def state(self) -> str:
        q = np.array(INFO.home)
        return RobotState(
            seqno=self.seqno,
            ts=time.time(),
            command_mode=self.mode,
            operational_mode=OperationalMode.manual_reduced_speed,
            flags=RobotFlags(enabled=True, ready=True, homed=True),
            joint_position=q.tolist(),
            joint_velocity=[0.0] * len(q),
            joint_position_command=q.tolist(),
            tcp_pose=KINEMATICS.tcp_pose(q),
            speed_ratio=1.0,
        ).model_dump_json()

    async def serve(self, ws: ServerConnection) -> None:
        self._ws = ws
        link = {
            "type": "link",
            "device": ROBOT,
            "kind": "robot",
            "status": "connected",
            "gen": GENERATION,
            "url": "http://127.0.0.1:9",
            "error": "",
            "info": DESCRIPTION,
        }
        listed = {"type": "devices", "devices": [{"local_name": ROBOT, "kind": "robot"}]}
        await ws.send(f"{json.dumps(link)}\n{json.dumps(listed)}")
        streaming = asyncio.create_task(self._stream(ws))
        try:
            async for text in ws:  # ends when the hub closes its side
                message = json.loads(text)
                self.ops.append(message)
                command = message.get("command") or {}
                if command.get("type") == "command_mode":
                    self.mode = CommandMode(command["mode"])
                elif message.get("op") == "halt":
                    self.mode = CommandMode.halt
        except websockets.ConnectionClosed:
            pass  # a test that failed left without a close handshake
        finally:
            streaming.cancel()

    async def _stream(self, ws: ServerConnection) -> None:
        with contextlib.suppress(websockets.ConnectionClosed):
            while True:
                self.seqno += 1
                await ws.send(f"S {ROBOT} {GENERATION} {self.state()}")
                await asyncio.sleep(0.01)

    async def refuse(self, error: dict[str, str]) -> None:
        """The driver's refusal of a streamed command, as the device manager passes it on."""
        assert self._ws is not None
        refused = {"type": "refused", "device": ROBOT, "gen": GENERATION, "error": error}
        await self._ws.send(json.dumps(refused))

    def sent(self, press: str) -> list[int]:
        """Where the commands of `press` are among the ops (tagged `press#n`)."""
        return [
            i
            for i, op in enumerate(self.ops)
            if op.get("op") == "send"
            and str((op.get("command") or {}).get("tag", "")).startswith(f"{press}#")
        ]

    def halts(self, tag: str) -> list[int]:
        return [i for i, op in enumerate(self.ops) if op.get("op") == "halt" and op["tag"] == tag]


async def until(check: Callable[[], object], what: str, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, f"{what}: not within {timeout} s"
        await asyncio.sleep(0.005)


@contextlib.asynccontextmanager
async def jogging() -> AsyncIterator[tuple[LinkSocket, Jogger]]:
    socket = LinkSocket()
    async with websockets.serve(socket.serve, "127.0.0.1", 0) as server:
        port = next(iter(server.sockets)).getsockname()[1]
        # Generous: the press must not end on a late state when the machine is busy.
        hub = LinkHub(f"http://127.0.0.1:{port}", "jog", stale_after=5.0)
        await hub.start()
        try:
            await hub.wait_connected()
            link = RobotClient(hub, await hub.watch(ROBOT))
            await link.ready()
            jogger = Jogger(link, KINEMATICS)
            try:
                yield socket, jogger
            finally:
                await jogger.close()
        finally:
            await hub.close()


def press(jogger: Jogger, name: str) -> JointVelocityJog:
    velocity = np.array([0.2, 0.0, 0.0, 0.0, 0.0, 0.0])
    return JointVelocityJog(name, jogger.controller, velocity, jogger.tcp_cap())


async def nothing_streams_after(socket: LinkSocket, halt: int, pressed: str) -> None:
    """The link sends AFTER more states (as many jog cycles): none brings a command of the
    press that ended."""
    seqno = socket.seqno
    await until(lambda: socket.seqno >= seqno + AFTER, "states after the halt")
    assert [i for i in socket.sent(pressed) if i > halt] == []


async def a_new_press_moves(socket: LinkSocket, jogger: Jogger, name: str) -> None:
    ended: list[Ended] = []
    await jogger.start(press(jogger, name), ended.append)
    await until(lambda: len(socket.sent(name)) >= 3, "the new press streaming")
    assert ended == []


def test_a_refusal_from_the_robot_halts_the_press_it_ended() -> None:
    """The robot refuses a command of a press that has been streaming velocities: the
    press ends refused and a halt naming it goes to the robot."""

    async def scenario() -> None:
        async with jogging() as (socket, jogger):
            ended: list[Ended] = []
            await jogger.start(press(jogger, "p1"), ended.append)
            await until(lambda: len(socket.sent("p1")) >= 5, "p1 streaming")
            await socket.refuse(FAULT)
            await until(lambda: ended, "p1 ended")
            assert [(e.press, e.state, e.reason, e.message) for e in ended] == [
                ("p1", "refused", "robot_fault", FAULT["message"])
            ]
            await until(lambda: socket.halts("p1:refused"), "p1 halted")
            assert jogger.action is None
            await nothing_streams_after(socket, socket.halts("p1:refused")[0], "p1")
            await a_new_press_moves(socket, jogger, "p2")

    asyncio.run(scenario())


class FailsOnItsThirdCycle(JointVelocityJog):
    """A jog whose cycle raises a refusal of its own after it has commanded velocities."""

    def tick(self, state: RobotState, now: float) -> Any:
        if self.ticks >= 3:
            raise RobotError("the jog cannot go on", code="jog_refused")
        return super().tick(state, now)


def test_a_cycle_refused_after_it_moved_the_robot_halts_it() -> None:
    async def scenario() -> None:
        async with jogging() as (socket, jogger):
            ended: list[Ended] = []
            velocity = np.array([0.2, 0.0, 0.0, 0.0, 0.0, 0.0])
            action = FailsOnItsThirdCycle("p1", jogger.controller, velocity, jogger.tcp_cap())
            await jogger.start(action, ended.append)
            await until(lambda: ended, "p1 ended")
            assert [(e.press, e.state, e.reason) for e in ended] == [
                ("p1", "refused", "jog_refused")
            ]
            await until(lambda: socket.halts("p1:refused"), "p1 halted")
            assert len(socket.sent("p1")) == 3  # all read by now: the halt came after them
            await nothing_streams_after(socket, socket.halts("p1:refused")[0], "p1")
            await a_new_press_moves(socket, jogger, "p2")

    asyncio.run(scenario())


class FailsAtOnce(JointVelocityJog):
    """A jog whose first cycle raises (the cycles after it would stream)."""

    def tick(self, state: RobotState, now: float) -> Any:
        if self.ticks == 0 and not getattr(self, "failed", False):
            self.failed = True
            raise RobotError("the jog cannot start", code="jog_refused")
        return super().tick(state, now)


def test_a_press_refused_at_its_first_cycle_halts_the_one_it_replaced_and_never_runs() -> None:
    """A press that replaces a moving one and fails at once: the session reports it refused
    (start raised), so the jogger must not go on with it, and the robot the replaced press
    set moving is halted."""

    async def scenario() -> None:
        async with jogging() as (socket, jogger):
            ended: list[Ended] = []
            await jogger.start(press(jogger, "p1"), ended.append)
            await until(lambda: len(socket.sent("p1")) >= 5, "p1 streaming")
            velocity = np.array([0.2, 0.0, 0.0, 0.0, 0.0, 0.0])
            failing = FailsAtOnce("p2", jogger.controller, velocity, jogger.tcp_cap())
            with pytest.raises(RobotError) as refused:
                await jogger.start(failing, ended.append)
            assert refused.value.code == "jog_refused"
            assert [(e.press, e.state) for e in ended] == [("p1", "stopped")]
            await until(lambda: socket.halts("p2:refused"), "the robot halted")
            assert jogger.action is None
            halt = socket.halts("p2:refused")[0]
            await nothing_streams_after(socket, halt, "p1")
            assert socket.sent("p2") == []
            await a_new_press_moves(socket, jogger, "p3")

    asyncio.run(scenario())


class MouseFeed:
    """A 3D mouse's newest state as the jog service reads it (None: its link is down)."""

    def __init__(self) -> None:
        self.state: InputState | None = None
        self.seqno = 0

    def report(self, axes: list[float] | None) -> None:
        self.seqno += 1
        if axes is None:
            self.state = None
        else:
            self.state = InputState(seqno=self.seqno, ts=0.0, axes=axes, connected=True)


def test_a_mouse_back_after_its_halt_is_checked_as_a_new_press() -> None:
    """Review of issue 32: a 3D mouse whose binding waited while it was away drove again on
    its next deflection without the checks a new press has; control lost meanwhile must end
    the binding, not move the robot."""

    async def scenario() -> None:
        async with jogging() as (socket, jogger):
            feed = MouseFeed()
            feed.report([0.0] * 6)
            mouse = MouseJog(
                "mouse:m",
                jogger.controller,
                KINEMATICS,
                cast(InputClient, feed),
                cartesian=False,
                frame="base",
                joints=[0, 1, 2, 3, 4, 5],
                speeds=np.full(6, 0.5),
                tcp_cap=jogger.tcp_cap(),
                window=5.0,
                on_button=lambda _: None,
            )
            lost = False

            async def recheck() -> None:
                if lost:
                    raise Conflict("another pendant has control of arm", code="lease_held")

            mouse.recheck = recheck
            ended: list[Ended] = []
            await jogger.start(mouse, ended.append)
            feed.report([0.5, 0, 0, 0, 0, 0])
            await until(lambda: len(socket.sent("mouse:m")) >= 3, "the mouse driving")
            feed.report(None)  # its driver restarts
            await until(lambda: socket.halts("mouse:m:halt"), "halted when it went")
            halt = socket.halts("mouse:m:halt")[0]
            lost = True  # control taken by another pendant meanwhile
            feed.report([0.0] * 6)  # back, at rest: nothing
            await until(lambda: mouse.armed, "the mouse seen at rest")
            feed.report([0.5, 0, 0, 0, 0, 0])  # pushed anew
            await until(lambda: ended, "the binding ended")
            assert [(e.state, e.reason) for e in ended] == [("refused", "lease_held")]
            assert [i for i in socket.sent("mouse:m") if i > halt] == []

    asyncio.run(scenario())
