"""The robots the motion service sees: every added robot (so each can avoid the others),
each with a live link, and the world kept in step with them and with the stored scene."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import numpy as np
import pinocchio as pin

from runtime.cell.mirror import CellReading
from runtime.clients.devices import Devices
from runtime.clients.robot import RobotClient
from runtime.interfaces.common import Pose
from runtime.kit.errors import NotFound
from runtime.robotics.world import World
from runtime.variable_storage.client import StorageClient


class Robots:
    def __init__(self, devices: Devices, storage: StorageClient) -> None:
        self.devices = devices
        self.storage = storage
        self.links: dict[str, RobotClient] = {}
        self._world = World()
        self._lock = asyncio.Lock()

    @contextlib.asynccontextmanager
    async def world(self) -> AsyncIterator[World]:
        """The world brought up to date, for the holder alone (planning runs on it)."""
        async with self._lock:
            yield await self._sync()

    async def link(self, name: str) -> RobotClient:
        """The robot's link; the world is refreshed only for a robot not known yet."""
        if name not in self.links:
            async with self.world():
                pass
        return self.known_link(name)

    def known_link(self, name: str) -> RobotClient:
        link = self.links.get(name)
        if link is None:
            raise NotFound(f"no connected robot {name!r}", code="unknown_device")
        return link

    async def check_lease(self, name: str, token: str | None) -> None:
        await self.devices.check_lease(name, token)

    async def _sync(self) -> World:
        """Bring the world up to date: robots, their bases and joints, the scene objects."""
        cell = await CellReading.read(self.devices.manager, self.storage, self._world.robots)
        for name in [n for n in self.links if n not in cell.robots]:
            del self.links[name]
            self._world.remove_robot(name)
        for name in cell.robots:
            await self._ensure(name)
        await cell.place_bases(self._world, self.storage)
        if cell.scene != self._world.objects:
            self._world.set_objects(cell.scene)
        for name, link in self.links.items():
            state = link.latest()
            if state is not None:
                self._world.robot(name).place(np.array(state.joint_position))
        return self._world

    async def _ensure(self, name: str) -> None:
        link = self.links.get(name)
        if link is None:
            link = self.links[name] = await self.devices.robot(name)
        known = self._world.robots.get(name)
        if known is None or known.kinematics.info != link.info:
            self._world.add_robot(name, link.info)


def world_pose(base: pin.SE3) -> Pose:
    quat = pin.Quaternion(base.rotation).coeffs()
    return Pose(position=[float(v) for v in base.translation], orientation=[float(v) for v in quat])
