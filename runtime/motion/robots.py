"""The robots the motion service sees: every added robot (so each can avoid the others),
each with a live link, and the world kept in step with them and with the stored scene."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import numpy as np
import pinocchio as pin

from runtime.cell.mirror import CellReading
from runtime.device_manager.client import check_lease, require_token
from runtime.interfaces.common import Pose
from runtime.kit.client import ServiceClient
from runtime.kit.errors import NotFound
from runtime.links.hub import LinkHub
from runtime.links.robot import RobotLink, robot_link
from runtime.robotics.world import World
from runtime.variable_storage.client import StorageClient


class Robots:
    def __init__(self, device_manager_url: str, storage: StorageClient, hub: LinkHub) -> None:
        self.devices = ServiceClient(device_manager_url, timeout=3.0, name="device manager")
        self.storage = storage
        self.hub = hub
        self.links: dict[str, RobotLink] = {}
        self._world = World()
        self._lock = asyncio.Lock()

    async def close(self) -> None:
        await self.devices.aclose()

    @contextlib.asynccontextmanager
    async def world(self) -> AsyncIterator[World]:
        """The world brought up to date, for the holder alone (planning runs on it)."""
        async with self._lock:
            yield await self._sync()

    async def link(self, name: str) -> RobotLink:
        """The robot's link; the world is refreshed only for a robot not known yet."""
        if name not in self.links:
            async with self.world():
                pass
        return self.known_link(name)

    def known_link(self, name: str) -> RobotLink:
        link = self.links.get(name)
        if link is None:
            raise NotFound(f"no connected robot {name!r}", code="unknown_device")
        return link

    async def check_lease(self, name: str, token: str | None) -> None:
        await check_lease(self.devices, name, require_token(name, token))

    async def _sync(self) -> World:
        """Bring the world up to date: robots, their bases and joints, the scene objects."""
        cell = await CellReading.read(self.devices, self.storage, self._world.robots)
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
            link = self.links[name] = await robot_link(self.hub, name)
        known = self._world.robots.get(name)
        if known is None or known.kinematics.info != link.info:
            self._world.add_robot(name, link.info)


def world_pose(base: pin.SE3) -> Pose:
    quat = pin.Quaternion(base.rotation).coeffs()
    return Pose(position=[float(v) for v in base.translation], orientation=[float(v) for v in quat])
