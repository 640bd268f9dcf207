"""The motion service: plan (preview) and run joint, linear, path and relative moves, each a
cancellable operation with status; the scene and the nearest obstacle for the UI."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
from collections import OrderedDict
from collections.abc import AsyncIterator, Awaitable
from typing import Annotated

import numpy as np
from fastapi import APIRouter, FastAPI, Header

from openpendant.runtime.cell.mirror import WorldMirror
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.interfaces.limits import JointLimitChecker
from openpendant.runtime.interfaces.robot import CommandMode, CommandModeRequest, OperationalMode
from openpendant.runtime.interfaces.variables import JointWaypoint, PoseWaypoint
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.errors import Conflict, NotFound, OpenPendantError
from openpendant.runtime.kit.settings import MotionSettings, RuntimeSettings
from openpendant.runtime.kit.words import words
from openpendant.runtime.motion.executor import Execution
from openpendant.runtime.motion.models import (
    Clearance,
    MoveKind,
    MoveRequest,
    MoveState,
    MoveStatus,
    PlanReport,
    Scene,
    SceneRobot,
    Target,
)
from openpendant.runtime.motion.moves import MovePlanner, Plan, Refused, resolve
from openpendant.runtime.motion.reactive import PERIOD as REACTIVE_PERIOD
from openpendant.runtime.motion.reactive import ReactiveExecution
from openpendant.runtime.motion.robots import Robots, world_pose
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.path_monitor import PathMonitor
from openpendant.runtime.robotics.velocity import MANUAL_TCP_SPEED, VelocityController
from openpendant.runtime.variable_storage.client import StorageClient

LeaseToken = Annotated[str | None, Header(alias="X-Lease-Token", max_length=64)]
# Who asks for a move (a program run): a stop naming it refuses its later moves too, so a
# move request still on its way when the stop arrives never runs.
Caller = Annotated[str | None, Header(alias="X-Caller", max_length=64)]
# The claim a move is made under (a program run's, made on its own link to the device
# manager): the move's commands reach the robot only while that claim lives.
Claim = Annotated[str | None, Header(alias="X-Claim", max_length=64)]
KEEP_FINISHED = 100
KEEP_STOPPED_CALLERS = 1000


class Moves:
    def __init__(
        self,
        robots: Robots,
        storage: StorageClient,
        mirror: WorldMirror,
        settings: MotionSettings | None = None,
    ) -> None:
        self.robots = robots
        self.settings = settings or MotionSettings()
        self.storage = storage
        self.status: dict[str, MoveStatus] = {}
        self.mirror = mirror
        # Per robot: the move running on it, its execution and the task watching it.
        self.running: dict[str, tuple[str, Execution | ReactiveExecution, asyncio.Task[None]]] = {}
        self._ids = itertools.count(1)
        self.stopped_callers: OrderedDict[str, None] = OrderedDict()

    async def plan(self, robot: str, request: MoveRequest) -> Plan:
        targets = [
            await self._lookup(t, robot)
            for t in ([request.target] if request.target else request.waypoints)
        ]
        async with self.robots.world() as world:
            link = self.robots.known_link(robot)
            state = link.current()
            start = np.array(state.joint_position)
            body = world.robot(robot)
            body.place(start)
            limits = JointLimitChecker(link.info)
            points = [resolve(t, body.world_base, limits) for t in targets]
            manual = state.operational_mode is OperationalMode.manual_reduced_speed
            planner = MovePlanner(world, robot, MANUAL_TCP_SPEED if manual else None)
            # Planning is CPU work (IK along lines, distance queries, search): off the loop,
            # with the world held so nothing moves it meanwhile.
            return await asyncio.to_thread(planner.plan, request, start, points)

    async def _lookup(self, target: Target, robot: str) -> Target:
        if target.waypoint is None:
            return target
        stored = await self.storage.get(target.waypoint)
        if stored.type == "joint_waypoint":
            joints = JointWaypoint.model_validate(stored.value)
            if joints.robot != robot:
                raise Refused(f"waypoint {stored.name} was taught on {joints.robot}, not {robot}")
            return Target(joints=joints.joints, blend=target.blend)
        if stored.type == "pose_waypoint":
            pose = PoseWaypoint.model_validate(stored.value)
            if pose.frame not in ("base", "world"):
                raise Refused(f"waypoint {stored.name} is in frame {pose.frame!r}")
            return Target(pose=pose.pose, frame=pose.frame, blend=target.blend)
        raise Refused(f"{stored.name} is a {stored.type}, not a waypoint")

    async def start(
        self,
        robot: str,
        request: MoveRequest,
        authorised: Awaitable[object],
        caller: str | None = None,
        claim: str | None = None,
    ) -> MoveStatus:
        """Plans while `authorised` (the lease check) is answered; launches only once it is."""
        lease = asyncio.ensure_future(authorised)
        try:
            self._check_caller(caller)
            self._check_free(robot)
        except BaseException:
            lease.cancel()
            raise
        move_id = f"move-{next(self._ids)}"
        status = MoveStatus(id=move_id, robot=robot, state=MoveState.planning, caller=caller)
        self.status[move_id] = status
        try:
            if request.kind is MoveKind.reactive:
                execution: Execution | ReactiveExecution = await self._reactive(
                    robot, request, claim
                )
                await lease
                return self._launch(status, execution)
            switched = asyncio.ensure_future(self._switch_to_trajectory(robot, lease, claim))
            try:
                plan = await self.plan(robot, request)
                await lease
            except BaseException:
                switched.cancel()
                raise
            mode_ready = await switched
        except BaseException:
            lease.cancel()
            del self.status[move_id]  # nobody was given its id
            raise
        status.plan = plan.report
        if not plan.report.ok or plan.timed is None:
            status.state, status.message = MoveState.failed, plan.report.message
            status.words = plan.report.words
            raise Refused(
                plan.report.message,
                code=plan.report.code,
                details=plan.report.model_dump(),
                words=plan.report.words,
            )
        link = self.robots.known_link(robot)
        # The planned TCP path for the monitor: a few ms of forward kinematics, off the loop.
        monitor = await asyncio.to_thread(
            PathMonitor,
            Kinematics(link.info),
            plan.timed.positions,
            self.settings.path_tolerance,
            self.settings.joint_path_tolerance,
        )
        execution = Execution(link, plan.timed, mode_ready=mode_ready, monitor=monitor, claim=claim)
        return self._launch(status, execution)

    async def _switch_to_trajectory(
        self, robot: str, lease: asyncio.Future[object], claim: str | None
    ) -> bool:
        """The driver put in trajectory mode while the move is planned, once the lease is
        confirmed, so the upload is the only round trip after planning. False when it was
        not: the execution switches then, or fails with the driver's reason."""
        link = self.robots.links.get(robot)
        if link is None:  # the first move since the robot was added
            return False
        try:
            await lease
        except Exception:
            return False  # refused: that is raised where the move awaits the lease
        try:
            if link.current().command_mode is CommandMode.trajectory:
                return True
            await link.set_command_mode(
                CommandModeRequest(mode=CommandMode.trajectory), claim=claim
            )
        except OpenPendantError:
            return False
        return True

    def _check_caller(self, caller: str | None) -> None:
        if caller is not None and caller in self.stopped_callers:
            raise Conflict(f"{caller} was stopped; it moves nothing more", code="stopped")

    def _check_free(self, robot: str) -> None:
        if robot in self.running:
            raise Conflict(
                f"{robot} is already moving; cancel that move first",
                code="busy",
                words=words("motion.busy", robot=robot),
            )

    def _launch(self, status: MoveStatus, execution: Execution | ReactiveExecution) -> MoveStatus:
        if status.state is not MoveState.planning:  # stopped or cancelled while planned
            raise Conflict(status.message, code=status.code or "cancelled")
        self._check_caller(status.caller)
        if status.robot in self.running:  # another move started while this one was planned
            status.state, status.message = MoveState.failed, "another move started first"
            self._check_free(status.robot)
        execution.paused = status.paused  # paused while it was planned: it starts paused
        task = asyncio.create_task(self._run(status, execution))
        self.running[status.robot] = (status.id, execution, task)
        status.state = MoveState.paused if status.paused else MoveState.running
        self._forget_old()
        return status

    async def _reactive(
        self, robot: str, request: MoveRequest, claim: str | None
    ) -> ReactiveExecution:
        assert request.target is not None  # the request's validation made sure
        target = await self._lookup(request.target, robot)
        link = await self.robots.link(robot)
        if robot not in self.mirror.world.robots:
            await self.mirror.sync(leave_out_failing=True)  # a robot added a moment ago
        body = self.mirror.world.robot(robot)
        point = resolve(target, body.world_base, JointLimitChecker(link.info))
        kinematics = body.kinematics
        if point.pose is not None:
            goal = point.pose
        else:
            assert point.joints is not None
            goal = kinematics.tcp(point.joints)
        joints = link.info.joints
        controller = VelocityController(
            kinematics,
            np.array([j.max_velocity for j in joints]) * request.speed,
            np.array([j.max_acceleration for j in joints]) * request.acceleration,
            REACTIVE_PERIOD,
        )
        avoidance = self.mirror.constraint(robot)
        controller.constraints.append(avoidance)
        manual = link.current().operational_mode is OperationalMode.manual_reduced_speed
        cap = MANUAL_TCP_SPEED if manual else None
        return ReactiveExecution(link, controller, avoidance, goal, request.speed, cap, claim)

    async def _run(self, status: MoveStatus, execution: Execution | ReactiveExecution) -> None:
        try:
            await execution.run()
            status.state, status.progress = MoveState.finished, 1.0
        except OpenPendantError as exc:
            cancelled = exc.code == "cancelled"
            status.state = MoveState.cancelled if cancelled else MoveState.failed
            status.code, status.message, status.words = exc.code, exc.message, exc.words
        except Exception as exc:  # a move must always end with a status
            status.state, status.message = MoveState.failed, f"internal error: {exc}"
            raise
        finally:
            status.progress = max(status.progress, execution.progress)
            self.running.pop(status.robot, None)

    def get(self, move_id: str) -> MoveStatus:
        status = self.status.get(move_id)
        if status is None:
            raise NotFound(f"no move {move_id!r}")
        entry = self.running.get(status.robot)
        if entry is not None and entry[0] == move_id:
            status.progress = entry[1].progress
        return status

    async def cancel(self, move_id: str) -> MoveStatus:
        status = self.get(move_id)
        if status.state is MoveState.planning:
            self._drop_planned(status, "cancelled", "cancelled while it was planned")
        entry = self.running.get(status.robot)
        if entry is not None and entry[0] == move_id:
            _, execution, task = entry
            execution.cancel()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(asyncio.shield(task), 2.0)
        return status

    async def stop(self, robot: str, caller: str | None = None) -> None:
        """Stop wins: halt the robot at once, whatever is running; a move still being
        planned never starts, nor does any later move of `caller`."""
        if caller is not None:
            self.stopped_callers[caller] = None
            while len(self.stopped_callers) > KEEP_STOPPED_CALLERS:
                self.stopped_callers.popitem(last=False)
        for status in list(self.status.values()):
            if status.robot == robot and status.state is MoveState.planning:
                self._drop_planned(status, "stopped", "stopped while it was planned")
        entry = self.running.get(robot)
        if entry is not None:
            entry[1].cancel()
        await self.robots.devices.halt(robot, "motion: stop")

    async def pause(self, robot: str, paused: bool, caller: str | None = None) -> MoveStatus:
        """Pause (a controlled stop along its path) or resume the move on `robot`: the one
        running, or the one being planned (it then starts paused). With `caller`, only that
        caller's move."""
        entry = self.running.get(robot)
        if entry is not None:
            move_id, execution, _ = entry
            status = self.status[move_id]
        else:
            planned = [
                s
                for s in self.status.values()
                if s.robot == robot and s.state is MoveState.planning
            ]
            if not planned:
                raise NotFound(f"no move is running on {robot}", code="not_running")
            status, execution = planned[-1], None
        if caller is not None and status.caller != caller:
            raise Conflict(f"the move on {robot} is not {caller}'s", code="not_yours")
        status.paused = paused
        if execution is not None:
            await execution.pause(paused)
            status.state = MoveState.paused if paused else MoveState.running
        return status

    @staticmethod
    def _drop_planned(status: MoveStatus, code: str, message: str) -> None:
        status.state, status.code, status.message = MoveState.cancelled, code, message

    async def wait(self, move_id: str, timeout: float) -> MoveStatus:
        status = self.get(move_id)
        entry = self.running.get(status.robot)
        if entry is not None and entry[0] == move_id:
            with contextlib.suppress(TimeoutError, Exception):
                await asyncio.wait_for(asyncio.shield(entry[2]), timeout)
        return self.get(move_id)

    def _forget_old(self) -> None:
        ended = [
            k
            for k, s in self.status.items()
            if s.state not in (MoveState.planning, MoveState.running, MoveState.paused)
        ]
        for key in ended[: max(0, len(ended) - KEEP_FINISHED)]:
            del self.status[key]


def motion_router(moves: Moves, robots: Robots) -> APIRouter:
    router = APIRouter(prefix="/motion")

    @router.get("/scene")
    async def scene() -> Scene:
        async with robots.world() as world:
            return Scene(
                robots={
                    name: SceneRobot(base=world_pose(body.world_base), joints=body.q.tolist())
                    for name, body in world.robots.items()
                },
                objects=dict(world.objects),
            )

    @router.post("/robots/{robot}/plan")
    async def plan(robot: str, body: MoveRequest) -> PlanReport:
        """Plan and check a move without running it (the scene panel's preview)."""
        return (await moves.plan(robot, body)).report

    @router.post("/robots/{robot}/moves", status_code=202)
    async def start(
        robot: str,
        body: MoveRequest,
        token: LeaseToken = None,
        caller: Caller = None,
        claim: Claim = None,
        wait: float = 0.0,
    ) -> MoveStatus:
        status = await moves.start(robot, body, robots.check_lease(robot, token), caller, claim)
        if wait > 0:
            return await moves.wait(status.id, min(wait, 600.0))
        return status

    @router.post("/robots/{robot}/stop")
    async def stop(robot: str, caller: Caller = None) -> dict[str, str]:
        await moves.stop(robot, caller)
        return {"robot": robot, "state": "halted"}

    @router.post("/robots/{robot}/pause")
    async def pause(robot: str, caller: Caller = None) -> MoveStatus:
        """A controlled stop of the robot's move along its path (anyone may slow a robot)."""
        return await moves.pause(robot, True, caller)

    @router.post("/robots/{robot}/resume")
    async def resume(robot: str, token: LeaseToken = None, caller: Caller = None) -> MoveStatus:
        await robots.check_lease(robot, token)
        return await moves.pause(robot, False, caller)

    @router.get("/robots/{robot}/clearance")
    async def clearance(robot: str) -> Clearance:
        """The nearest pair of this robot's moving parts and anything else, now."""
        async with robots.world() as world:
            contact = world.nearest(robot)
        if contact is None:
            return Clearance(robot=robot, distance=None)
        p = contact.proximity
        return Clearance(
            robot=robot,
            distance=p.distance,
            robot_part=p.body,
            other=p.other,
            points=[p.point.tolist(), p.other_point.tolist()],
        )

    @router.get("/moves/{move_id}")
    async def move(move_id: str, wait: float = 0.0) -> MoveStatus:
        if wait > 0:
            return await moves.wait(move_id, min(wait, 600.0))
        return moves.get(move_id)

    @router.post("/moves/{move_id}/cancel")
    async def cancel(move_id: str) -> MoveStatus:
        return await moves.cancel(move_id)

    return router


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    storage = StorageClient(urls["variable_storage"])
    devices = Devices(urls["device_manager"], "motion", settings.link.stale_after)
    robots = Robots(devices, storage)
    mirror = WorldMirror(devices, storage)
    moves = Moves(robots, storage, mirror, settings.motion)

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await devices.start()
        await mirror.start()
        try:
            yield
        finally:
            await mirror.close()
            for robot in list(moves.running):
                with contextlib.suppress(Exception):
                    await moves.stop(robot)
            await devices.close()
            await storage.aclose()

    app = create_app("motion", lifespan=lifespan)
    app.include_router(motion_router(moves, robots))
    return app
