"""The robots the motion service sees: every added robot (so each can avoid the others),
each with a live link, and the world kept in step with them and with the stored scene."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import numpy as np
import pinocchio as pin

from openpendant.runtime.cell.mirror import CellWorld
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.kit.errors import NotFound
from openpendant.runtime.robotics.world import World
from openpendant.runtime.variable_storage.client import StorageClient


class Robots:
    def __init__(self, devices: Devices, storage: StorageClient) -> None:
        self.devices = devices
        self.cell = CellWorld(devices, storage)
        self._lock = asyncio.Lock()

    @property
    def links(self) -> dict[str, RobotClient]:
        return self.cell.links

    @contextlib.asynccontextmanager
    async def world(self) -> AsyncIterator[World]:
        """The world brought up to date, for the holder alone (planning runs on it), every
        robot where it is now."""
        async with self._lock:
            world = await self.cell.sync()
            for name, link in self.links.items():
                state = link.latest()
                if state is not None:
                    world.robot(name).place(np.array(state.joint_position))
            yield world

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


def world_pose(base: pin.SE3) -> Pose:
    quat = pin.Quaternion(base.rotation).coeffs()
    return Pose(position=[float(v) for v in base.translation], orientation=[float(v) for v in quat])
