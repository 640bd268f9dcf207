"""A service's devices: the added devices as the device manager lists them, a typed client
for each over its one link, and control-lease checks. Every service that commands devices
holds one of these, so the link and lease plumbing exists once."""

from __future__ import annotations

import asyncio
import contextlib
import time
from typing import Any, TypeVar

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.clients.base import DeviceClient
from openpendant.runtime.clients.input import InputClient
from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.device_manager.client import DeviceManagerClient, require_token
from openpendant.runtime.kit.errors import DeviceError, NotFound, OpenPendantError, Unavailable
from openpendant.runtime.links.hub import LinkHub

C = TypeVar("C", bound=DeviceClient[Any])

# A successful check renews the lease to a known expiry, and any hand-over shows in the device
# manager's list (which clears the cache), so a check is trusted until shortly before that
# expiry; past half its life it is renewed in the background, never holding up a command.
LEASE_MARGIN = 1.0  # s


class Devices:
    def __init__(self, device_manager_url: str, service: str, stale_after: float) -> None:
        self.manager = DeviceManagerClient(device_manager_url)
        self.hub = LinkHub(device_manager_url, service, stale_after)
        self.added: dict[str, dict[str, Any]] = {}  # the device manager's list, by local name
        self._leases: dict[tuple[str, str], tuple[float, float]] = {}  # -> (renew, trust)
        self._renewing: set[asyncio.Task[None]] = set()
        self.hub.on_devices.append(self._update)

    async def start(self) -> None:
        await self.hub.start()

    async def close(self) -> None:
        for task in list(self._renewing):
            task.cancel()
        await asyncio.gather(*self._renewing, return_exceptions=True)
        await self.hub.close()
        await self.manager.aclose()

    def _update(self, devices: dict[str, dict[str, Any]]) -> None:
        previous = self.added
        self.added = dict(devices)
        for name, device in previous.items():
            now = self.added.get(name)
            if now is None or now.get("controlled_by") != device.get("controlled_by"):
                self._leases = {k: v for k, v in self._leases.items() if k[0] != name}

    # Devices ---------------------------------------------------------------------------------

    async def entry(self, name: str, kind: str | None = None) -> dict[str, Any]:
        """An added device that is connected (of `kind`, if given), or why not."""
        with contextlib.suppress(OpenPendantError):
            await self.hub.wait_connected()
        device = self.added.get(name)
        if device is None or device["status"] != "connected":
            # The live list can trail the device manager by a moment (a device added just
            # now): ask it directly before saying no.
            device = (await self.manager.device(name)).model_dump()
        if kind is not None and device["kind"] != kind:
            raise DeviceError(f"{name} is a {device['kind']}, not a {kind}", code=f"not_a_{kind}")
        if device["status"] != "connected":
            code = "link_stale" if device["status"] == "stale" else "device_disconnected"
            raise Unavailable(f"{name} is {device['status']}", code=code)
        return device

    async def robot(self, name: str, *, listed: bool = False) -> RobotClient:
        """An added robot's client, once its state is streaming. `listed`: the caller has
        just read it in the device manager's list as a connected robot (no need to ask)."""
        if not listed:
            await self.entry(name, "robot")
        return await self._client(name, RobotClient)

    async def input(self, name: str) -> InputClient:
        await self.entry(name, "input")
        return await self._client(name, InputClient)

    async def client(self, name: str, kind: str) -> DeviceClient[Any]:
        """The typed client of an added device of any kind a plugin declares."""
        await self.entry(name, kind)
        declared = registry().kinds.get(kind)
        if declared is None:
            raise NotFound(
                f"no installed plugin knows devices of kind {kind!r}", code="unknown_kind"
            )
        client_class = resolve(declared.client)
        return await self._client(name, client_class)

    async def _client(self, name: str, client_class: type[C]) -> C:
        view = await self.hub.watch(name)
        key = (client_class.kind, name)
        client = self.hub.handles.get(key)
        if not isinstance(client, client_class):
            client = self.hub.handles[key] = client_class(self.hub, view)
        await client.ready()
        return client

    async def halt(self, name: str, tag: str | None) -> None:
        """Stop always wins: over the device's link, whether or not this service uses it."""
        await self.hub.halt(name, tag)

    async def robot_names(self) -> list[str]:
        return [d.local_name for d in await self.manager.devices() if d.kind == "robot"]

    # Control leases --------------------------------------------------------------------------

    async def check_lease(self, name: str, token: str | None) -> None:
        """Raises unless `token` holds `name`'s control lease (checks are cached)."""
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
            granted = await self.manager.check_lease(name, token)
        except OpenPendantError:
            self._leases.pop((name, token), None)
            if quiet:
                return
            raise
        now = time.time()
        self._leases[(name, token)] = (
            now + (granted.expires - now) / 2,
            granted.expires - LEASE_MARGIN,
        )
