"""The robots the jog service jogs: one Jogger per robot in use, on the robot's one link (the
service's `Devices`), with its kinematics and collision constraints."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.clients.input import InputClient
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.jog.jogger import Jogger
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.velocity import Constraint


class Directory:
    def __init__(
        self, devices: Devices, avoidance: Callable[[str], Constraint] | None = None
    ) -> None:
        self.devices = devices
        self.avoidance = avoidance  # a robot's collision constraints for Cartesian jog
        self.joggers: dict[str, Jogger] = {}
        self._kinematics: dict[str, Kinematics] = {}
        self._lock = asyncio.Lock()

    async def close(self) -> None:
        for jogger in self.joggers.values():
            await jogger.close()

    async def check_lease(self, name: str, token: str | None) -> None:
        await self.devices.check_lease(name, token)

    async def input_feed(self, name: str) -> InputClient:
        """The live state of an added input device (a 3D mouse)."""
        return await self.devices.input(name)

    async def jogger(self, name: str) -> Jogger:
        async with self._lock:
            link = await self.devices.robot(name)
            jogger = self.joggers.get(name)
            if jogger is not None and jogger.kinematics.info == link.info:
                return jogger
            if jogger is not None:  # the same name now stands for another robot
                del self.joggers[name]
                await jogger.close()
            constraints = [self.avoidance(name)] if self.avoidance is not None else []
            jogger = Jogger(link, self.kinematics(link.info), constraints)
            self.joggers[name] = jogger
            return jogger

    async def halt(self, name: str, reason: str) -> None:
        """Stop always wins: the robot's jog ends, and the halt goes over the robot's one link
        whether or not this service has jogged it (or can see it) yet."""
        jogger = self.joggers.get(name)
        if jogger is not None:
            await jogger.halt_all(reason)
        else:
            await self.devices.halt(name, "halt")

    def kinematics(self, info: RobotInfo) -> Kinematics:
        key = info.model_dump_json()
        if key not in self._kinematics:
            self._kinematics[key] = Kinematics(info)
        return self._kinematics[key]
