"""Detected and added devices. Free of web framework code: the routes call into this."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import time
from collections.abc import Coroutine
from pathlib import Path
from typing import Any

import httpx

from openpendant.plugins.registry import registry
from openpendant.runtime.device_manager.announcements import MAX_ANNOUNCEMENTS, Announcements, mark
from openpendant.runtime.device_manager.connection import (
    DeviceConnection,
    declares,
    describe,
    fetch_info,
    short,
)
from openpendant.runtime.device_manager.leases import LeaseBook
from openpendant.runtime.device_manager.links import LinkServer
from openpendant.runtime.device_manager.models import (
    AddDeviceRequest,
    AddedDevice,
    AddressClaim,
    DetectedDevice,
    DeviceDetails,
    LeaseGranted,
    LeaseInfo,
)
from openpendant.runtime.device_manager.tools import stored_tool, tool_variable
from openpendant.runtime.interfaces.robot import RobotInfo, ToolSetup
from openpendant.runtime.interfaces.variables import DeviceRecord
from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.device_auth import (
    disproof,
    keep_secret,
    key_id,
    known_secret,
    runtime_tag,
)
from openpendant.runtime.kit.discovery import Detected, checked_uuid, clean_text
from openpendant.runtime.kit.errors import (
    Conflict,
    DeviceError,
    InvalidValue,
    NotFound,
    OpenPendantError,
    Unavailable,
)
from openpendant.runtime.kit.settings import LinkSettings
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.kit.words import link_words
from openpendant.runtime.variable_storage.client import StorageClient

log = logging.getLogger(__name__)

RECORD_PREFIX = "devices."


class DeviceRegistry:
    def __init__(
        self,
        storage: StorageClient,
        fanout: Fanout,
        lease_seconds: float = 15.0,
        timing: LinkSettings | None = None,
        lease_file: Path | None = None,
        data_dir: Path | None = None,
    ) -> None:
        self.data_dir = data_dir  # where the devices' pairing secrets are kept
        self.storage = storage
        self.fanout = fanout  # everything, device states included
        self.events = Fanout()  # lists and leases only, for services
        self.links = LinkServer(self)
        self.timing = timing or LinkSettings()
        self.announced = Announcements(self._added_urls, self.key_of)
        # Per uuid, the id of the pairing key kept for it (None: none), read once: the list
        # asks for every announcement each time it changes. A device this runtime starts
        # keeps its key before it announces itself; add() forgets what it changes.
        self._key_ids: dict[str, str | None] = {}
        self._runtime_tag: str | None = None
        self._unknown_kinds: set[str] = set()
        self.connections: dict[str, DeviceConnection] = {}
        self.claims: dict[str, AddressClaim] = {}  # local name -> another address it was seen at
        self.loaded = False
        self.leases = LeaseBook(lease_seconds, lease_file)
        self._lock = asyncio.Lock()
        self._tasks: set[asyncio.Task[None]] = set()

    # Discovery ------------------------------------------------------------------------------

    def on_found(self, device: Detected) -> None:
        if device.kind not in registry().kinds:
            if device.kind not in self._unknown_kinds:  # once per kind, not per announcement
                self._unknown_kinds.add(device.kind)
                log.warning(
                    "ignoring devices of kind %r (first: %s): no installed plugin knows them",
                    device.kind,
                    device.uuid,
                )
            return
        if not self.announced.found(device):
            return
        self._publish_detected()
        for conn in self.connections.values():
            if conn.record.uuid == device.uuid and conn.record.url != device.url:
                self._seen_elsewhere(conn, device)

    def _seen_elsewhere(self, conn: DeviceConnection, device: Detected) -> None:
        """An added device announced at another address. While its link is live the device
        answers where it is: the announcement is a second device with its identity (or a
        stale one), shown to the user and not followed. A device whose link is down may have
        moved (a restart on a new port): the link follows if it proves who it is there."""
        claim = AddressClaim(url=device.url, name=device.name, seen=time.time())
        if conn.status == "connected":  # shown at once; whether it is proven, shortly
            self.claims[conn.name] = claim
            self._publish_devices()
        self._background(self._follow_if_proven(conn, device.url, claim))

    def secret_of(self, uuid: str) -> str | None:
        return known_secret(self.data_dir, uuid) if self.data_dir is not None else None

    def key_of(self, uuid: str) -> str | None:
        if uuid not in self._key_ids:
            if len(self._key_ids) >= 4 * MAX_ANNOUNCEMENTS:  # made-up uuids without end
                self._key_ids.clear()
            secret = self.secret_of(uuid)
            self._key_ids[uuid] = key_id(secret) if secret else None
        return self._key_ids[uuid]

    def runtime_tag(self) -> str | None:
        """This runtime's tag, as the devices it starts announce it (its launcher makes the
        id it comes from, perhaps after this service started)."""
        if self._runtime_tag is None and self.data_dir is not None:
            self._runtime_tag = runtime_tag(self.data_dir)
        return self._runtime_tag

    async def _follow_if_proven(
        self, conn: DeviceConnection, url: str, claim: AddressClaim
    ) -> None:
        """A device whose link is down and whose robot was at rest, announced at another
        address, is followed there only if what answers there proves it holds the device's
        secret and serves from that very address (a proof passed on from the real device
        covers the real device's address). Otherwise it is a claim for an administrator to
        accept (PUT /devices/{name}/address) or ignore: marked proven when it is the device,
        but its link is live or its robot was moving or in a fault."""
        secret = self.secret_of(conn.record.uuid)
        refused = await disproof(url, secret) if secret else "no pairing secret is kept for it"
        async with self._lock:
            if self.connections.get(conn.name) is not conn or conn.record.url == url:
                return
            pinned = conn.pinned
            if refused is None and not pinned:
                self._move(conn, url)
                return
            if refused is not None:
                log.warning(
                    "%s: a device announces its uuid at %s without proving it is %s there "
                    "(%s): not followed",
                    conn.name,
                    url,
                    conn.name,
                    refused,
                )
            else:
                log.warning(
                    "%s proves it serves from %s, but %s: the move waits for the user",
                    conn.name,
                    url,
                    pinned,
                )
            self.claims[conn.name] = claim.model_copy(update={"proven": refused is None})
        self._publish_devices()

    def _move(self, conn: DeviceConnection, url: str) -> None:
        log.warning("%s moves from %s to %s", conn.name, conn.record.url, url)
        self.claims[conn.name] = AddressClaim(
            url=conn.record.url, name=conn.record.name, seen=time.time(), followed=True
        )
        conn.move_to(url)
        self._background(self._persist_url(conn.name, conn.record))
        self._publish_devices()

    async def repoint(self, local_name: str, url: str) -> AddedDevice:
        """The user moves a device to another address: its robot halted first, the one link
        moved at once (every service uses it), the address stored."""
        url = url.rstrip("/")
        async with self._lock:
            conn = self._get(local_name)
            record = await self._record_from_url(url, local_name)
            if record.uuid != conn.record.uuid:
                raise Conflict(
                    f"the device at {url} is not {local_name} (uuid {record.uuid!r})",
                    code="wrong_device",
                )
            conn.halt("address changed by the user")
            self._move(conn, url)
        return self._added(conn)

    def vouches_for(self, device: Detected) -> bool:
        """Whether an added device's link is live at the address this announcement gives:
        then the device is there, whatever became of its announcement's records (they may
        have lapsed while the link was down, their confirmations lost with it)."""
        return any(
            conn.status == "connected"
            and conn.record.uuid == device.uuid
            and conn.record.url == device.url
            for conn in self.connections.values()
        )

    def on_gone(self, service_name: str) -> None:
        if self.announced.gone(service_name):
            self._publish_detected()
            self._publish_devices()

    @property
    def detected(self) -> dict[str, Detected]:
        """Per uuid, the announcement that speaks for it."""
        return self.announced.by_uuid

    def _added_urls(self) -> dict[str, str]:
        return {c.record.uuid: c.record.url for c in self.connections.values()}

    def _background(self, job: Coroutine[Any, Any, None]) -> None:
        task = asyncio.ensure_future(job)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _persist_url(self, local_name: str, record: DeviceRecord) -> None:
        async with self._lock:
            conn = self.connections.get(local_name)
            if conn is None or conn.record.uuid != record.uuid:
                return  # removed meanwhile: writing now would bring it back
            try:
                await self.storage.put(RECORD_PREFIX + local_name, "device", record.model_dump())
            except OpenPendantError as exc:
                log.warning("could not store the new address of %s: %s", local_name, exc.message)

    # Added devices --------------------------------------------------------------------------

    async def load(self) -> None:
        """Reconnect every device added before; waits for the storage to come up."""
        while True:
            try:
                variables = await self.storage.query(type_name="device")
                break
            except OpenPendantError as exc:
                log.info("waiting for variable storage: %s", exc.message)
                await asyncio.sleep(0.2)
        async with self._lock:
            for variable in variables:
                record = DeviceRecord.model_validate(variable.value)
                if record.local_name not in self.connections:
                    self._connect(record)
            self.loaded = True
        self._publish_devices()

    async def add(self, request: AddDeviceRequest) -> AddedDevice:
        async with self._lock:
            if request.local_name in self.connections:
                raise Conflict(
                    f"the name {request.local_name!r} is already used", code="name_taken"
                )
            if request.uuid is not None:
                record = self._record_from_detected(request.uuid, request.local_name)
                if request.pairing is None:
                    await self._require_proof(record)
            else:
                record = await self._record_from_url(str(request.url), request.local_name)
            for conn in self.connections.values():
                if conn.record.uuid == record.uuid:
                    raise Conflict(
                        f"this device is already added as {conn.name!r}", code="already_added"
                    )
            if record.kind not in registry().kinds:
                raise DeviceError(
                    f"no installed plugin knows devices of kind {record.kind!r}",
                    code="unknown_kind",
                )
            if request.pairing is not None and self.data_dir is not None:
                keep_secret(self.data_dir, record.uuid, request.pairing)
                self._key_ids.pop(record.uuid, None)
            # Persist first: if storage refuses, nothing has changed.
            await self.storage.put(
                RECORD_PREFIX + record.local_name,
                "device",
                record.model_dump(),
                tags=["device"],
                expected_version=0,
            )
            conn = self._connect(record)
        self._publish_devices()
        self._publish_detected()
        return self._added(conn)

    async def remove(self, local_name: str) -> AddedDevice:
        async with self._lock:
            conn = self._get(local_name)
            await self.storage.delete(RECORD_PREFIX + local_name)
            del self.connections[local_name]
            self.claims.pop(local_name, None)
            self.leases.drop(local_name)
            # Gone from the link socket's view before its session ends: no service may
            # command it under this name any more.
            self.links.on_removed(local_name)
            await conn.stop()
        self._publish_devices()
        self._publish_detected()
        return self._added(conn)

    async def _require_proof(self, record: DeviceRecord) -> None:
        """Added with the key this runtime keeps (no pairing code): what answers at the
        announced address must prove it holds that key, there. The key's id it announces is
        no proof: anyone may copy it."""
        secret = self.secret_of(record.uuid)
        if secret is None:
            return  # a device that was never paired: its link says what it is
        refused = await disproof(record.url, secret)
        if refused is not None:
            log.warning("refused to add %s at %s: %s", record.uuid, record.url, refused)
            raise Conflict(
                f"the device at {record.url} did not prove it is the one paired here "
                f"({refused}); add it with its pairing code",
                code="unproven",
            )

    def _record_from_detected(self, uuid: str, local_name: str) -> DeviceRecord:
        found = self.detected.get(uuid)
        if found is None:
            raise NotFound(f"no detected device with uuid {uuid!r}", code="device_not_detected")
        return DeviceRecord(
            uuid=found.uuid,
            local_name=local_name,
            kind=found.kind,
            model=found.model,
            name=found.name,
            url=found.url,
        )

    async def _record_from_url(self, url: str, local_name: str) -> DeviceRecord:
        url = url.rstrip("/")
        try:
            async with httpx.AsyncClient(base_url=url, timeout=2.0, verify=CLIENT_TLS) as http:
                info = await fetch_info(http, url)
            identity = info["identity"]
            if not isinstance(identity, dict):
                raise TypeError("identity is not an object")
        except (httpx.HTTPError, ValueError, KeyError, TypeError) as exc:
            reason = short(describe(exc))
            log.warning("refused to add the device at %s: %s", url, reason)
            raise DeviceError(
                f"no OpenPendant device answers at {url}: {reason}", code="device_unreachable"
            ) from exc
        try:
            return DeviceRecord(
                uuid=checked_uuid(identity.get("uuid")),
                local_name=local_name,
                kind=clean_text(str(identity.get("kind", "")), 16),
                model=clean_text(str(identity.get("model", "")), 64),
                name=clean_text(str(identity.get("name", "")), 64),
                url=url,
            )
        except ValueError as exc:
            log.warning("refused to add the device at %s: %s", url, short(str(exc)))
            raise DeviceError(
                f"the device at {url} does not identify itself properly: {exc}",
                code="device_invalid",
            ) from exc

    def _connect(self, record: DeviceRecord) -> DeviceConnection:
        conn = DeviceConnection(
            record,
            self._on_state,
            self._on_status,
            self.timing,
            tool_setup=lambda name: stored_tool(self.storage, name),
            secret=lambda: self.secret_of(record.uuid),
        )
        self.connections[record.local_name] = conn
        found = self.detected.get(record.uuid)
        if found is not None and found.url != record.url:
            claim = AddressClaim(url=found.url, name=found.name, seen=time.time())
            self._background(self._follow_if_proven(conn, found.url, claim))
        conn.start()
        return conn

    def _on_status(self, conn: DeviceConnection) -> None:
        if self.connections.get(conn.name) is not conn:
            return  # removed: its last words are not news
        self.links.on_status(conn)
        self._publish_devices()

    async def close(self) -> None:
        for conn in list(self.connections.values()):
            await conn.stop()

    # Views ----------------------------------------------------------------------------------

    def connection(self, local_name: str) -> DeviceConnection:
        return self._get(local_name)

    def _get(self, local_name: str) -> DeviceConnection:
        conn = self.connections.get(local_name)
        if conn is None:
            if not self.loaded:  # it may well be added: not known yet is not "gone"
                raise Unavailable(
                    "the device manager is loading the added devices", code="starting"
                )
            raise NotFound(f"no device named {local_name!r}", code="device_not_found")
        return conn

    def _added(self, conn: DeviceConnection) -> AddedDevice:
        r = conn.record
        lease = self.leases.info(r.local_name)
        return AddedDevice(
            local_name=r.local_name,
            uuid=r.uuid,
            kind=r.kind,
            model=r.model,
            name=r.name,
            url=r.url,
            status=conn.status,
            last_error=conn.last_error,
            connected_since=conn.connected_since,
            detected=self.announced.announces(r.uuid),
            controlled_by=lease.holder,
            control_expires=lease.expires,
            link=conn.generation,
            state_age=state_age(conn),
            address_claim=self.claims.get(r.local_name),
        )

    # Control leases -------------------------------------------------------------------------

    def acquire_lease(self, local_name: str, holder: str, token: str | None) -> LeaseGranted:
        self._get(local_name)
        granted = self.leases.acquire(local_name, holder, token)
        self._publish_devices()
        return granted

    def check_lease(self, local_name: str, token: str | None) -> LeaseGranted:
        self._get(local_name)
        return self.leases.check(local_name, token)

    async def set_tool(self, local_name: str, setup: ToolSetup, token: str | None) -> RobotInfo:
        """A robot's new tool setup, by whoever controls it: applied to the robot (which
        halts), then stored. Should storing fail, the robot is given back its old setup."""
        conn = self._get(local_name)
        if not declares(conn.record.kind, "tool"):
            raise InvalidValue(f"{local_name} is a {conn.record.kind}, which carries no tool")
        self.leases.check(local_name, token)
        old = conn.info
        info = await conn.set_tool(setup.model_dump())
        try:
            await self.storage.put(tool_variable(local_name), "tool", setup.model_dump())
        except OpenPendantError:
            if old is not None:
                before = RobotInfo.model_validate(old["info"])
                back = ToolSetup(tcp=before.tcp, payload=before.payload)
                with contextlib.suppress(OpenPendantError):
                    await conn.set_tool(back.model_dump())
            raise
        return RobotInfo.model_validate(info["info"])

    def release_lease(self, local_name: str, token: str | None) -> None:
        self._get(local_name)
        self.leases.release(local_name, token)
        self._publish_devices()

    def lease_info(self, local_name: str) -> LeaseInfo:
        self._get(local_name)
        return self.leases.info(local_name)

    async def sweep_leases(self) -> None:
        while True:
            await asyncio.sleep(0.5)
            if self.leases.sweep():
                self._publish_devices()

    def added_list(self) -> list[AddedDevice]:
        return [self._added(c) for _, c in sorted(self.connections.items())]

    def details(self, local_name: str) -> DeviceDetails:
        conn = self._get(local_name)
        return DeviceDetails(**self._added(conn).model_dump(), info=conn.info)

    def detected_list(self) -> list[DetectedDevice]:
        added_as = {c.record.uuid: name for name, c in self.connections.items()}
        urls = self.announced.urls_by_uuid()
        own = self.runtime_tag()
        listed = []
        for d in sorted(self.detected.values(), key=lambda d: (d.kind, d.name, d.uuid)):
            seen, why = mark(d, d.uuid in added_as, self.key_of(d.uuid), own)
            listed.append(
                DetectedDevice(
                    uuid=d.uuid,
                    name=d.name,
                    kind=d.kind,
                    model=d.model,
                    api=d.api,
                    address=f"{d.host}:{d.port}",
                    url=d.url,
                    added_as=added_as.get(d.uuid),
                    last_seen=d.last_seen,
                    also_at=[url for url in urls.get(d.uuid, []) if url != d.url],
                    mark=seen,
                    elsewhere=why,
                )
            )
        return listed

    def state_text(self, local_name: str) -> str:
        conn = self._get(local_name)
        if conn.status != "connected" or conn.last_state is None:
            raise Unavailable(
                f"{local_name} is {conn.status}"
                + (f": {conn.last_error}" if conn.last_error else ""),
                code="link_stale" if conn.status == "stale" else "device_disconnected",
                words=link_words(local_name, conn.status),
            )
        return conn.last_state

    # Live updates ---------------------------------------------------------------------------

    def snapshot_messages(self, states: bool = True) -> list[str]:
        messages = [self._detected_message(), self.devices_message()]
        if not states:
            return messages
        for name, conn in sorted(self.connections.items()):
            if conn.last_state is not None:
                messages.append(_state_message(name, conn.last_state))
        return messages

    def _on_state(self, conn: DeviceConnection, text: str) -> None:
        if self.connections.get(conn.name) is not conn:
            return  # removed: its session is ending
        if self.fanout.subscribers:
            self.fanout.publish(_state_message(conn.name, text), key=f"state:{conn.name}")
        self.links.on_state(conn, text)

    def _detected_message(self) -> str:
        return json.dumps(
            {"type": "detected", "detected": [d.model_dump() for d in self.detected_list()]}
        )

    def devices_message(self) -> str:
        return json.dumps(
            {"type": "devices", "devices": [d.model_dump() for d in self.added_list()]}
        )

    # Both lists are whole snapshots: a newer one replaces one not yet sent (keyed), so a
    # slow client is never behind by more than one of each.
    def _publish_detected(self) -> None:
        if self.fanout.subscribers or self.events.subscribers:
            message = self._detected_message()
            self.fanout.publish(message, key="detected")
            self.events.publish(message, key="detected")

    def _publish_devices(self) -> None:
        if self.fanout.subscribers or self.events.subscribers or self.links.clients:
            message = self.devices_message()
            self.fanout.publish(message, key="devices")
            self.events.publish(message, key="devices")
            self.links.on_devices(message)


def state_age(conn: DeviceConnection) -> float | None:
    if conn.status != "connected":
        return None
    fresh = conn.freshness
    age = fresh.age() if declares(conn.record.kind, "session") else fresh.silence()
    return round(age, 4) if math.isfinite(age) else None


def _state_message(local_name: str, state_text: str) -> str:
    return (
        f'{{"type":"state","device":{json.dumps(local_name)},"ts":{time.time()},'
        f'"state":{state_text}}}'
    )
