"""A world kept in step in the background, for control loops that cannot wait for a sync:
the added robots, their bases and the scene's objects are refreshed every REFRESH seconds,
and every robot's joints come from its live state stream. Jogging and reactive moves build
their collision-avoidance constraints on it."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from openpendant.runtime.cell.bases import base_in_world
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.device_manager.client import AddedDevice, DeviceManagerClient
from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.robotics.avoidance import AvoidanceConstraint
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_body import RobotBody
from openpendant.runtime.robotics.world import Contact, World, build_obstacles
from openpendant.runtime.variable_storage.client import StorageClient

log = logging.getLogger(__name__)

REFRESH = 0.5  # s: how late a scene edit or a moved base may reach the constraints
LOOKAHEAD = 0.02  # s: another robot is placed this far ahead of its reported state ...
MAX_AGE = 0.2  # s: ... plus the report's age up to this (older means the feed is stuck)


async def connected_robots(manager: DeviceManagerClient) -> dict[str, AddedDevice]:
    """The device manager's connected robots by local name."""
    added = await manager.devices()
    return {d.local_name: d for d in added if d.kind == "robot" and d.status == "connected"}


async def scene_objects(storage: StorageClient) -> dict[str, SceneObject]:
    objects = await storage.query(type_name="scene_object")
    return {v.name: SceneObject.model_validate(v.value) for v in objects}


async def robot_bases(storage: StorageClient, robots: Iterable[str]) -> dict[str, pin.SE3]:
    """Each robot's base as the stored frame `frames.<robot>` places it (identity without
    one), the same frame the jog service uses for world-frame waypoints."""
    names = list(robots)
    bases = await asyncio.gather(*(base_in_world(storage, name) for name in names))
    return dict(zip(names, bases, strict=True))


@dataclass
class CellReading:
    """The connected robots, the scene and the bases, read at once (one round of requests,
    not one after another: this is on the way to every move)."""

    robots: dict[str, AddedDevice]
    scene: dict[str, SceneObject]
    bases: dict[str, pin.SE3]

    @classmethod
    async def read(
        cls, manager: DeviceManagerClient, storage: StorageClient, known: Iterable[str]
    ) -> CellReading:
        robots, scene, bases = await asyncio.gather(
            connected_robots(manager), scene_objects(storage), robot_bases(storage, known)
        )
        return cls(robots, scene, bases)

    async def place_bases(self, world: World, storage: StorageClient) -> None:
        """Every robot of the world on its base (reading those of robots new to it)."""
        new = [name for name in world.robots if name not in self.bases]
        self.bases.update(await robot_bases(storage, new))
        for name, body in world.robots.items():
            if not body.world_base.isApprox(self.bases[name]):
                body.set_base(self.bases[name])


class CellWorld:
    """A world kept in step with the cell on request (`sync`): the connected robots, each with
    its link, on their bases, and the scene's objects. Robot bodies and obstacle shapes are
    built off the event loop and swapped in on it: a control cycle never sees half a scene."""

    def __init__(self, devices: Devices, storage: StorageClient) -> None:
        self.devices = devices
        self.storage = storage
        self.world = World()
        self.links: dict[str, RobotClient] = {}

    async def sync(self, *, leave_out_failing: bool = False) -> World:
        """Bring the world up to date; a robot whose link cannot be had is an error, or with
        `leave_out_failing` left out until the next sync."""
        cell = await CellReading.read(self.devices.manager, self.storage, self.world.robots)
        for name in [n for n in self.links if n not in cell.robots]:
            del self.links[name]
            self.world.remove_robot(name)
        for name in cell.robots:
            try:
                await self._ensure(name)
            except OpenPendantError as exc:
                if not leave_out_failing:
                    raise
                log.info("%s left out of the world for now: %s", name, exc.message)
        await cell.place_bases(self.world, self.storage)
        if cell.scene != self.world.objects:
            obstacles = await asyncio.to_thread(build_obstacles, cell.scene)
            self.world.set_objects(cell.scene, obstacles)
        return self.world

    async def _ensure(self, name: str) -> None:
        link = self.links.get(name)
        if link is None:
            # Listed as a connected robot by the reading this sync began with: asking the
            # device manager again, robot by robot, every sync, would load it most when its
            # links are under strain.
            link = self.links[name] = await self.devices.robot(name, listed=True)
        info = link.info
        known = self.world.robots.get(name)
        if known is None or known.kinematics.info != info:
            body = await asyncio.to_thread(RobotBody, name, Kinematics(info))
            self.world.insert_robot(body)


class WorldMirror(CellWorld):
    """The cell's world refreshed every REFRESH s in the background, for control loops that
    cannot wait for a sync; every robot's joints come from its live state stream."""

    def __init__(self, devices: Devices, storage: StorageClient) -> None:
        super().__init__(devices, storage)
        self.refreshed = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        self._task = asyncio.create_task(self._follow(), name="world mirror")

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    async def _follow(self) -> None:
        while True:
            try:
                await self.sync(leave_out_failing=True)
                self.refreshed.set()
            except (OpenPendantError, OSError, ValueError) as exc:
                log.info("world mirror not refreshed: %s", exc)
            await asyncio.sleep(REFRESH)

    def place_others(self, robot: str, lookahead: float = LOOKAHEAD) -> None:
        """Every other robot where it will be a cycle from now: its latest reported joints
        carried on at its velocity for the report's age and a little more, so a robot that
        is coming closer is met early, not late."""
        now = time.time()
        for name, body in self.world.robots.items():
            if name == robot:
                continue
            link = self.links.get(name)
            state = link.latest() if link is not None else None
            if state is not None:
                ahead = min(max(now - state.ts, 0.0), MAX_AGE) + lookahead
                q = np.array(state.joint_position) + ahead * np.array(state.joint_velocity)
                body.place(np.clip(q, body.kinematics.lower, body.kinematics.upper))

    def constraint(self, robot: str) -> MirrorConstraint:
        return MirrorConstraint(self, robot)


class MirrorConstraint:
    """The velocity QP's collision constraints for one robot against everything else in the
    mirrored world; none while the robot is not in it yet."""

    def __init__(self, mirror: WorldMirror, robot: str) -> None:
        self.mirror = mirror
        self.robot = robot
        self.avoidance = AvoidanceConstraint(mirror.world, robot)
        # How long the command being computed will last: a loop running late sets it longer.
        self.horizon = LOOKAHEAD

    @property
    def nearest(self) -> Contact | None:
        return self.avoidance.nearest

    def __call__(self, q: FloatArray, jacobian: FloatArray) -> tuple[FloatArray, FloatArray] | None:
        if self.robot not in self.mirror.world.robots:
            return None
        self.mirror.place_others(self.robot, self.horizon)
        return self.avoidance(q, jacobian)
