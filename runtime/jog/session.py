"""One client's jog socket. Hold-to-run: every press needs a heartbeat at least every
deadman window; when heartbeats stop, or the socket closes, the robot is halted, and a
halted press never resumes (the operator must press again)."""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from pydantic import ValidationError

from openpendant.runtime.interfaces.limits import FloatArray, JointLimitChecker
from openpendant.runtime.jog.actions import (
    Action,
    FreedriveHold,
    JointVelocityJog,
    MouseJog,
    PlannedMoveAction,
    TwistJog,
    override,
    scaled_cap,
)
from openpendant.runtime.jog.clearance import PathCheck
from openpendant.runtime.jog.directory import Directory
from openpendant.runtime.jog.jogger import Ended, Jogger
from openpendant.runtime.jog.models import (
    CARTESIAN_AXES,
    FreedrivePress,
    HaltRequest,
    Heartbeat,
    JogPress,
    MouseBinding,
    MoveToPress,
    Release,
    TeachRequest,
)
from openpendant.runtime.jog.waypoints import joint_goal, teach
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.errors import InvalidValue, OpenPendantError, RobotError
from openpendant.runtime.kit.metrics import DEADMAN_HALTS
from openpendant.runtime.kit.settings import MotionSettings
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.kit.words import Words, words
from openpendant.runtime.robotics.joint_move import plan_joint_move
from openpendant.runtime.robotics.path_monitor import PathMonitor
from openpendant.runtime.variable_storage.client import StorageClient

log = logging.getLogger(__name__)

JOINT_SPEED = math.radians(45)  # rad/s at 100 %
LINEAR_SPEED = 0.25  # m/s at 100 %
ANGULAR_SPEED = math.radians(45)  # rad/s at 100 %
MONITOR_SAMPLE = 0.008  # s: a planned jog move's path, sampled for its monitor

MESSAGES: dict[str, type[Any]] = {
    "jog": JogPress,
    "move_to": MoveToPress,
    "freedrive": FreedrivePress,
    "heartbeat": Heartbeat,
    "release": Release,
    "halt": HaltRequest,
    "mouse": MouseBinding,
}


@dataclass
class Held:
    robot: str
    timer: asyncio.TimerHandle | None  # None: a bounded step, which completes once started
    last_beat: float = 0.0


def mouse_speeds(binding: MouseBinding) -> FloatArray:
    """Full deflection on each axis at 100 %: m/s and rad/s (Cartesian), rad/s (joints)."""
    linear, angular = (
        (LINEAR_SPEED, ANGULAR_SPEED) if binding.mode == "cartesian" else (JOINT_SPEED, JOINT_SPEED)
    )
    return np.array([linear] * 3 + [angular] * 3)


class JogSession:
    def __init__(
        self,
        directory: Directory,
        storage: StorageClient,
        deadman: float,
        paths: PathCheck,
        path_tolerances: MotionSettings,
    ) -> None:
        self.directory = directory
        self.path_tolerances = path_tolerances  # the path monitor's, for planned jog moves
        self.storage = storage
        self.deadman = deadman
        self.paths = paths
        self.out = Fanout()
        self.held: dict[str, Held] = {}
        self.ended: deque[str] = deque(maxlen=1000)
        self.touched: set[str] = set()
        self._tasks: set[asyncio.Task[None]] = set()

    def send(self, message: dict[str, Any]) -> None:
        self.out.publish_json(message)

    async def handle(self, message: Any) -> None:
        kind = message.get("type") if isinstance(message, dict) else None
        model = MESSAGES.get(str(kind))
        if model is None:
            raise OpenPendantError(f"unknown message type {kind!r}", code="bad_message")
        try:
            request = model.model_validate(message)
        except ValidationError as exc:
            text, _ = describe_validation_errors(exc.errors())
            raise OpenPendantError(text, code="invalid_request", status=422) from exc
        if isinstance(request, JogPress | MoveToPress | FreedrivePress):
            await self._press(request)
        elif isinstance(request, Heartbeat):
            self._heartbeat(request.press)
        elif isinstance(request, Release):
            await self._release(request.press)
        elif isinstance(request, MouseBinding):
            await self._mouse(request)
        else:
            await self._halt(request.robot)

    async def _mouse(self, request: MouseBinding) -> None:
        press = f"mouse:{request.device}"
        if not request.enabled:
            held = self.held.get(press)
            if held is not None:
                await self._stop(held.robot, press, "3D mouse disabled", halt=True)
            return
        try:
            if await self._rebind(press, request):
                return
            await self.directory.check_lease(request.robot, request.token)
            jogger = await self.directory.jogger(request.robot)
            feed = await self.directory.input_feed(request.device)
            if any(j >= jogger.link.info.dof or j < 0 for j in request.joints):
                raise InvalidValue(f"the robot has joints 0 to {jogger.link.info.dof - 1}")
            speeds = mouse_speeds(request)
            action = MouseJog(
                press,
                jogger.controller,
                jogger.kinematics,
                feed,
                cartesian=request.mode == "cartesian",
                frame=request.frame,
                joints=request.joints,
                speeds=speeds,
                tcp_cap=jogger.tcp_cap(),
                window=self.deadman,
                on_button=lambda b: self._mouse_button(request, b),
                speed=request.speed,
            )
            action.recheck = self._lease_check(request)
            self.ended = deque((p for p in self.ended if p != press), maxlen=1000)
            self.touched.add(request.robot)
            self.held[press] = Held(request.robot, None, time.monotonic())
            await jogger.start(action, self._ended, self._held_back)
        except OpenPendantError as exc:
            self._forget(press)
            self.send(
                {
                    "type": "status",
                    "press": press,
                    "robot": request.robot,
                    "state": "refused",
                    "reason": exc.code,
                    "message": exc.message,
                    "words": exc.words.body() if exc.words else None,
                }
            )
            return
        if press in self.held:
            self._mouse_status(press, request.robot, action)

    def _mouse_status(self, press: str, robot: str, action: MouseJog) -> None:
        """Bound: moving, or held while the mouse is away or its cap not yet let go (its
        first cycle may have said so already; this must not say "moving" after it)."""
        reason, why = action.held()
        state = {"state": "held", "reason": reason, "message": why} if why else {"state": "moving"}
        self.send({"type": "status", "press": press, "robot": robot, **state})

    def _lease_check(self, request: MouseBinding) -> Callable[[], Awaitable[None]]:
        """The binding's control, checked again when its mouse comes back and is pushed."""
        return lambda: self.directory.check_lease(request.robot, request.token)

    async def _rebind(self, press: str, request: MouseBinding) -> bool:
        """A binding sent again while the mouse drives a robot: the same robot takes the new
        mode, frame, speed and joints at once (the page's frame buttons drive the mouse too);
        another robot: the first one halts and the mouse is bound afresh. True when done."""
        held = self.held.get(press)
        if held is None:
            return False
        jogger = self.directory.joggers.get(held.robot)
        action = jogger.action if jogger is not None else None
        if jogger is None or held.robot != request.robot or not isinstance(action, MouseJog):
            await self._stop(held.robot, press, "3D mouse bound to another robot", halt=True)
            return False
        try:
            await self.directory.check_lease(request.robot, request.token)
            if any(j >= jogger.link.info.dof or j < 0 for j in request.joints):
                raise InvalidValue(f"the robot has joints 0 to {jogger.link.info.dof - 1}")
        except OpenPendantError:
            await self._stop(held.robot, press, "3D mouse binding refused", halt=True)
            raise
        action.cartesian = request.mode == "cartesian"
        action.frame = request.frame
        action.joints = request.joints
        action.speeds = mouse_speeds(request)
        action.speed = request.speed
        action.recheck = self._lease_check(request)
        self.send(
            {
                "type": "mouse_frame",
                "device": request.device,
                "frame": action.frame,
                "mode": request.mode,
            }
        )
        self._mouse_status(press, request.robot, action)
        return True

    def _mouse_button(self, request: MouseBinding, button: int) -> None:
        action = request.buttons.get(str(button))
        if action == "toggle_frame":
            jogger = self.directory.joggers.get(request.robot)
            current = jogger.action if jogger is not None else None
            if isinstance(current, MouseJog):
                current.frame = "tool" if current.frame == "base" else "base"
                mode = "cartesian" if current.cartesian else "joint"
                self.send(
                    {
                        "type": "mouse_frame",
                        "device": request.device,
                        "frame": current.frame,
                        "mode": mode,
                    }
                )
        elif action == "teach":
            self._spawn(self._teach_from_mouse(request.robot))

    async def _teach_from_mouse(self, robot: str) -> None:
        jogger = await self.directory.jogger(robot)
        for number in range(1, 1000):
            name = f"mouse_wp_{number:03d}"
            try:
                await teach(
                    self.storage,
                    robot,
                    jogger.link.current(),
                    jogger.kinematics,
                    TeachRequest(name=name, tags=["3d-mouse"]),
                )
            except OpenPendantError as exc:
                if exc.code == "exists":
                    continue
                self.send({"type": "error", "error": exc.body()["error"]})
                return
            self.send({"type": "taught", "robot": robot, "name": name})
            return

    async def _press(self, request: JogPress | MoveToPress | FreedrivePress) -> None:
        if request.press in self.held:
            self._heartbeat(request.press)  # a repeated press is its own heartbeat
            return
        if request.press in self.ended:
            return  # a press that ended never resumes
        try:
            await self.directory.check_lease(request.robot, request.token)
            jogger = await self.directory.jogger(request.robot)
            action = await self._action(request, jogger)
            self.touched.add(request.robot)
            timer = None
            if not (isinstance(request, JogPress) and request.step is not None):
                loop = asyncio.get_running_loop()
                timer = loop.call_later(self.deadman, self._deadman_lapsed, request.press)
            self.held[request.press] = Held(request.robot, timer, time.monotonic())
            await jogger.start(action, self._ended, self._held_back)
        except OpenPendantError as exc:
            self._forget(request.press)
            self.send(
                {
                    "type": "status",
                    "press": request.press,
                    "robot": request.robot,
                    "state": "refused",
                    "reason": exc.code,
                    "message": exc.message,
                    "words": exc.words.body() if exc.words else None,
                }
            )
            return
        if request.press in self.held:
            self.send(
                {
                    "type": "status",
                    "press": request.press,
                    "robot": request.robot,
                    "state": "moving",
                }
            )

    async def _action(
        self, request: JogPress | MoveToPress | FreedrivePress, jogger: Jogger
    ) -> Action:
        state = jogger.link.current()
        cap = jogger.tcp_cap()
        q = np.array(state.joint_position_command)
        info = jogger.link.info
        if isinstance(request, FreedrivePress):
            if "freedrive" not in info.capabilities:
                raise RobotError(
                    f"{request.robot} cannot be moved by hand (no freedrive)", code="no_freedrive"
                )
            return FreedriveHold(request.press)
        if isinstance(request, MoveToPress):
            goal = await joint_goal(
                self.storage,
                request.robot,
                request.waypoint,
                jogger.kinematics,
                JointLimitChecker(info),
                q,
            )
            await self.paths.joint_line(request.robot, goal)
            return self._plan(request.press, jogger, q, goal, override(request.speed, state), cap)
        if request.step is not None:
            goal = self._step_goal(request, jogger, q)
            await self.paths.joint_line(request.robot, goal)
            return self._plan(request.press, jogger, q, goal, override(request.speed, state), cap)
        if request.kind == "joint":
            assert isinstance(request.axis, int)
            if not 0 <= request.axis < info.dof:
                raise InvalidValue(f"the robot has joints 0 to {info.dof - 1}")
            velocity = np.zeros(info.dof)
            velocity[request.axis] = request.direction * JOINT_SPEED
            return JointVelocityJog(request.press, jogger.controller, velocity, cap, request.speed)
        twist = np.zeros(6)
        index = CARTESIAN_AXES.index(str(request.axis))
        twist[index] = request.direction * (LINEAR_SPEED if index < 3 else ANGULAR_SPEED)
        return TwistJog(
            request.press,
            jogger.controller,
            jogger.kinematics,
            twist,
            request.frame,
            cap,
            request.speed,
        )

    @staticmethod
    def _step_goal(request: JogPress, jogger: Jogger, q: FloatArray) -> FloatArray:
        checker = JointLimitChecker(jogger.link.info)
        step = float(request.step or 0.0) * request.direction
        if request.kind == "joint":
            assert isinstance(request.axis, int)
            goal = q.copy()
            goal[request.axis] += step
            return checker.positions(goal.tolist(), "step target")
        index = CARTESIAN_AXES.index(str(request.axis))
        axis = np.eye(3)[index % 3]
        tcp = jogger.kinematics.tcp(q)
        if index < 3:
            delta = pin.SE3(np.eye(3), axis * step)
        else:
            delta = pin.SE3(pin.exp3(axis * step), np.zeros(3))
        if request.frame == "tool":
            target = tcp * delta
        else:  # base-frame axes, about the TCP point
            target = pin.SE3(delta.rotation @ tcp.rotation, tcp.translation + delta.translation)
        return checker.positions(jogger.kinematics.inverse(target, q).tolist(), "step target")

    def _plan(
        self,
        press: str,
        jogger: Jogger,
        q: FloatArray,
        goal: FloatArray,
        speed: float,
        cap: float | None,
    ) -> PlannedMoveAction:
        move = plan_joint_move(
            jogger.kinematics, jogger.link.info, q, goal, speed, scaled_cap(cap, speed)
        )
        # The path checked (the straight joint line) as it is streamed, every 8 ms.
        times = np.append(np.arange(0.0, move.duration, MONITOR_SAMPLE), move.duration)
        planned = np.array([move.sample(float(t))[0] for t in times])
        tolerances = self.path_tolerances
        monitor = PathMonitor(
            jogger.kinematics, planned, tolerances.path_tolerance, tolerances.joint_path_tolerance
        )
        return PlannedMoveAction(press, move, monitor, speed)

    def _heartbeat(self, press: str) -> None:
        held = self.held.get(press)
        if held is None or held.timer is None:
            return
        held.timer.cancel()
        held.last_beat = time.monotonic()
        held.timer = asyncio.get_running_loop().call_later(
            self.deadman, self._deadman_lapsed, press
        )

    def _deadman_lapsed(self, press: str) -> None:
        held = self.held.get(press)
        if held is not None:
            window = round(self.deadman * 1000)
            silent = (time.monotonic() - held.last_beat) * 1000
            log.warning(
                "deadman: halting %s (press %s): no heartbeat for %.0f ms",
                held.robot,
                press,
                silent,
                extra={"press": press, "silent_ms": silent},
            )
            said = words("jog.deadman", ms=window)
            reason = f"no heartbeat for {window} ms"
            DEADMAN_HALTS.labels(held.robot).inc()
            self._spawn(self._stop(held.robot, press, reason, halt=True, said=said))

    async def _release(self, press: str) -> None:
        held = self.held.get(press)
        if held is not None and held.timer is not None:
            await self._stop(held.robot, press, "released", halt=False)

    async def _stop(
        self, robot: str, press: str, reason: str, *, halt: bool, said: Words | None = None
    ) -> None:
        jogger = self.directory.joggers.get(robot)
        if jogger is not None:
            await jogger.stop(press, reason, halt=halt, said=said)
        self._forget(press)

    async def _halt(self, robot: str | None) -> None:
        robots = set(self.touched) | ({robot} if robot else set())
        for name in robots:
            await self.directory.halt(name, "stop requested")
        for press in list(self.held):
            self._forget(press)

    def _held_back(
        self, press: str, why: str, said: Words | None, reason: str = "held_back"
    ) -> None:
        held = self.held.get(press)
        if held is None:
            return
        status = {"type": "status", "press": press, "robot": held.robot}
        if why:
            shown = {"state": "held", "reason": reason, "message": why}
            self.send({**status, **shown, "words": said.body() if said else None})
        else:
            self.send({**status, "state": "moving"})

    def _ended(self, ended: Ended) -> None:
        held = self.held.get(ended.press)
        robot = held.robot if held is not None else None
        self._forget(ended.press)
        self.send(
            {
                "type": "status",
                "press": ended.press,
                "robot": robot,
                "state": ended.state,
                "reason": ended.reason,
                "message": ended.message,
                "words": ended.words.body() if ended.words else None,
            }
        )

    def _forget(self, press: str) -> None:
        held = self.held.pop(press, None)
        if held is not None and held.timer is not None:
            held.timer.cancel()
        if press not in self.ended:
            self.ended.append(press)

    def _spawn(self, job: Any) -> None:
        task = asyncio.ensure_future(job)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def close(self) -> None:
        """The socket closed: whatever this client was moving is halted."""
        for press, held in list(self.held.items()):
            try:
                await self._stop(held.robot, press, "connection closed", halt=True)
            except OpenPendantError:
                continue
