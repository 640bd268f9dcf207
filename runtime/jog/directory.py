"""The device manager as the jog service sees it: added devices (status, who controls them)
and every robot's one link, over the link socket; lease checks cached until the lease
changes hands; one Jogger per robot in use."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from typing import Any

from runtime.device_manager.client import check_lease, require_token
from runtime.interfaces.robot import RobotInfo
from runtime.jog.jogger import Jogger
from runtime.kit.client import ServiceClient
from runtime.kit.errors import DeviceError, OpenPendantError, Unavailable
from runtime.links.hub import LinkHub
from runtime.links.robot import InputLink, input_link, robot_link
from runtime.robotics.kinematics import Kinematics
from runtime.robotics.velocity import Constraint

log = logging.getLogger(__name__)

# A successful check renews the lease to a known expiry, and any hand-over shows in the device
# manager's events (which clear the cache), so a check is trusted until shortly before that
# expiry; past half its life it is renewed in the background, never holding up a press.
LEASE_MARGIN = 1.0  # s


class Directory:
    def __init__(
        self,
        device_manager_url: str,
        hub: LinkHub,
        avoidance: Callable[[str], Constraint] | None = None,
    ) -> None:
        self.http = ServiceClient(device_manager_url, timeout=3.0, name="device manager")
        self.hub = hub
        self.avoidance = avoidance  # a robot's collision constraints for Cartesian jog
        self.devices: dict[str, dict[str, Any]] = {}
        self.joggers: dict[str, Jogger] = {}
        self._leases: dict[tuple[str, str], tuple[float, float]] = {}  # -> (renew, trust) times
        self._renewing: set[asyncio.Task[None]] = set()
        self._kinematics: dict[str, Kinematics] = {}
        self._lock = asyncio.Lock()
        hub.on_devices.append(self._update)

    async def close(self) -> None:
        for jogger in self.joggers.values():
            await jogger.close()
        await self.http.aclose()

    def _update(self, devices: dict[str, dict[str, Any]]) -> None:
        previous = self.devices
        self.devices = dict(devices)
        for name, device in previous.items():
            now = self.devices.get(name)
            if now is None or now.get("controlled_by") != device.get("controlled_by"):
                self._leases = {k: v for k, v in self._leases.items() if k[0] != name}

    async def input_feed(self, name: str) -> InputLink:
        """The live state of an added input device (a 3D mouse)."""
        await self.device(name, kind="input")
        return await input_link(self.hub, name)

    async def device(self, name: str, kind: str = "robot") -> dict[str, Any]:
        with contextlib.suppress(OpenPendantError):
            await self.hub.wait_connected()
        device = self.devices.get(name)
        if device is None or device["status"] != "connected":
            # The live view can trail the device manager by a moment (a device added just
            # now): ask it directly before saying no.
            device = await self.http.get(f"/devices/{name}")
        if device["kind"] != kind:
            raise DeviceError(f"{name} is a {device['kind']}, not a {kind}", code=f"not_a_{kind}")
        if device["status"] != "connected":
            code = "link_stale" if device["status"] == "stale" else "device_disconnected"
            raise Unavailable(f"{name} is {device['status']}", code=code)
        return device

    async def check_lease(self, name: str, token: str | None) -> None:
        token = require_token(name, token)
        renew, trust = self._leases.get((name, token), (0.0, 0.0))
        now = time.time()
        if now < trust:
            if now > renew:
                self._leases[(name, token)] = (trust, trust)  # one renewal at a time
                task = asyncio.create_task(self._check(name, token))
                self._renewing.add(task)
                task.add_done_callback(self._renewing.discard)
            return
        await self._check(name, token, quiet=False)

    async def _check(self, name: str, token: str, quiet: bool = True) -> None:
        try:
            granted = await check_lease(self.http, name, token)
        except OpenPendantError:
            self._leases.pop((name, token), None)
            if quiet:
                return
            raise
        expires = float(granted["expires"])
        now = time.time()
        self._leases[(name, token)] = (now + (expires - now) / 2, expires - LEASE_MARGIN)

    async def jogger(self, name: str) -> Jogger:
        await self.device(name)
        async with self._lock:
            link = await robot_link(self.hub, name)
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
            await self.hub.halt(name, "halt")

    def kinematics(self, info: RobotInfo) -> Kinematics:
        key = info.model_dump_json()
        if key not in self._kinematics:
            self._kinematics[key] = Kinematics(info)
        return self._kinematics[key]
