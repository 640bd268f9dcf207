"""The device manager as the jog service sees it: added devices (address, status, who
controls them) followed live over its event socket, lease checks cached until the lease
changes hands, and one Jogger per robot in use."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections.abc import Callable
from typing import Any

import websockets

from runtime.device_manager.client import check_lease, open_robot_link, require_token
from runtime.interfaces.input import InputState
from runtime.interfaces.robot import RobotInfo
from runtime.jog.jogger import Jogger
from runtime.jog.velocity import Constraint
from runtime.kinematics import Kinematics
from runtime.kit.client import ServiceClient
from runtime.kit.errors import DeviceError, OpenPendantError, Unavailable
from runtime.state_feed import StateFeed

log = logging.getLogger(__name__)

# A successful check renews the lease to a known expiry, and any hand-over shows in the device
# manager's events (which clear the cache), so a check is trusted until shortly before that
# expiry; past half its life it is renewed in the background, never holding up a press.
LEASE_MARGIN = 1.0  # s


class Directory:
    def __init__(
        self, device_manager_url: str, avoidance: Callable[[str], Constraint] | None = None
    ) -> None:
        self.http = ServiceClient(device_manager_url, timeout=3.0, name="device manager")
        self.avoidance = avoidance  # a robot's collision constraints for Cartesian jog
        self._ws_url = device_manager_url.replace("http://", "ws://", 1)
        self.devices: dict[str, dict[str, Any]] = {}
        self.joggers: dict[str, Jogger] = {}
        self._leases: dict[tuple[str, str], tuple[float, float]] = {}  # -> (renew, trust) times
        self._renewing: set[asyncio.Task[None]] = set()
        self._kinematics: dict[str, Kinematics] = {}
        self.inputs: dict[str, StateFeed[InputState]] = {}
        self._ready = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._lock = asyncio.Lock()

    async def start(self) -> None:
        self._task = asyncio.create_task(self._follow())

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        for jogger in self.joggers.values():
            await jogger.close()
        for feed in self.inputs.values():
            await feed.close()
        await self.http.aclose()

    async def _follow(self) -> None:
        while True:
            try:
                async with websockets.connect(
                    f"{self._ws_url}/devices/ws?states=false", open_timeout=2.0, close_timeout=1.0
                ) as ws:
                    self._leases.clear()  # a hand-over may have happened while away
                    async for message in ws:
                        body = json.loads(message)
                        if body.get("type") == "devices":
                            self._update(body["devices"])
            except (OSError, websockets.WebSocketException, TimeoutError, ValueError) as exc:
                log.info("device manager events dropped: %s", exc)
            self._ready.clear()
            await asyncio.sleep(0.2)

    def _update(self, devices: list[dict[str, Any]]) -> None:
        previous = self.devices
        self.devices = {d["local_name"]: d for d in devices}
        for name, device in previous.items():
            now = self.devices.get(name)
            if now is None or now.get("controlled_by") != device.get("controlled_by"):
                self._leases = {k: v for k, v in self._leases.items() if k[0] != name}
        self._ready.set()

    async def input_feed(self, name: str) -> StateFeed[InputState]:
        """The live state of an added input device (a 3D mouse)."""
        device = await self.device(name, kind="input")
        feed = self.inputs.get(name)
        if feed is not None and feed.url.startswith(device["url"].replace("http", "ws", 1)):
            return feed
        if feed is not None:
            await feed.close()
        feed = StateFeed(device["url"], InputState, name)
        await feed.start()
        if not feed.alive:
            await feed.close()
            raise Unavailable(f"no state from {name}", code="device_disconnected")
        self.inputs[name] = feed
        return feed

    async def device(self, name: str, kind: str = "robot") -> dict[str, Any]:
        if not self._ready.is_set():
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._ready.wait(), 3.0)
        device = self.devices.get(name)
        if device is None or device["status"] != "connected":
            # The live view can trail the device manager by a moment (a device added just
            # now): ask it directly before saying no.
            device = await self.http.get(f"/devices/{name}")
        if device["kind"] != kind:
            raise DeviceError(f"{name} is a {device['kind']}, not a {kind}", code=f"not_a_{kind}")
        if device["status"] != "connected":
            raise Unavailable(f"{name} is {device['status']}", code="device_disconnected")
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
        device = await self.device(name)
        async with self._lock:
            jogger = self.joggers.get(name)
            if jogger is not None and jogger.link.url == device["url"] and jogger.link.alive:
                return jogger
            if jogger is not None:
                del self.joggers[name]
                await jogger.close()
            link = await open_robot_link(self.http, name, device["url"])
            constraints = [self.avoidance(name)] if self.avoidance is not None else []
            jogger = Jogger(link, self.kinematics(link.info), constraints)
            self.joggers[name] = jogger
            return jogger

    def kinematics(self, info: RobotInfo) -> Kinematics:
        key = info.model_dump_json()
        if key not in self._kinematics:
            self._kinematics[key] = Kinematics(info)
        return self._kinematics[key]
