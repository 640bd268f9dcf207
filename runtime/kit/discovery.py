"""DNS-SD advertisement and browsing of `_openpendant._tcp.local.` (DESIGN.md §5).

Every Zeroconf instance here is created with an explicit interface list: tests and a runtime
bound to loopback must never multicast on a real interface.
"""

from __future__ import annotations

import asyncio
import logging
import re
import socket
import time
import unicodedata
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

from zeroconf import InterfaceChoice, IPVersion, ServiceStateChange, Zeroconf
from zeroconf.asyncio import AsyncServiceBrowser, AsyncServiceInfo, AsyncZeroconf

log = logging.getLogger(__name__)

SERVICE_TYPE = "_openpendant._tcp.local."
API_VERSION = "1"
KINDS = ("robot", "camera", "detector", "io", "gripper", "input")
UUID_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._:-]{0,63}$")
# Control, format (bidi overrides, zero-width), surrogate, private-use and separator
# characters: none belongs in a name shown on a pendant.
_HIDDEN = {"Cc", "Cf", "Cs", "Co", "Zl", "Zp"}

Interfaces = list[str] | Literal["all"]


def make_zeroconf(interfaces: Interfaces) -> AsyncZeroconf:
    if interfaces == "all":
        return AsyncZeroconf(interfaces=InterfaceChoice.All, ip_version=IPVersion.V4Only)
    if not interfaces:
        raise ValueError("discovery needs at least one interface address")
    return AsyncZeroconf(interfaces=list(interfaces), ip_version=IPVersion.V4Only)


def clean_text(raw: bytes | str | None, limit: int = 128) -> str:
    """Untrusted text: decoded leniently, control, format and bidi characters dropped,
    length capped."""
    if raw is None:
        return ""
    text = raw[: limit * 4].decode("utf-8", "replace") if isinstance(raw, bytes) else raw
    text = text[: limit * 4]
    return "".join(c for c in text if unicodedata.category(c) not in _HIDDEN)[:limit]


def checked_uuid(raw: object) -> str:
    """A device uuid as sent: refused, never cut, when it is not 1-64 plain characters (two
    long ids sharing a prefix must not become one device)."""
    text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else raw
    if not isinstance(text, str) or not UUID_PATTERN.match(text):
        shown = clean_text(repr(raw), 40)
        raise ValueError(f"a device uuid is 1-64 letters, digits and ._:- (got {shown})")
    return text


@dataclass(frozen=True)
class Advertisement:
    uuid: str
    kind: str
    model: str
    name: str
    host: str
    port: int
    api: str = API_VERSION

    def instance_name(self) -> str:
        label = re.sub(r"[^A-Za-z0-9 _-]", "", self.name)[:40] or self.kind
        return f"{label} [{self.uuid[:8]}].{SERVICE_TYPE}"

    def service_info(self) -> AsyncServiceInfo:
        return AsyncServiceInfo(
            SERVICE_TYPE,
            self.instance_name(),
            addresses=[socket.inet_aton(self.host)],
            port=self.port,
            properties={
                "uuid": self.uuid,
                "kind": self.kind,
                "model": self.model,
                "name": self.name,
                "api": self.api,
            },
            server=f"openpendant-{self.uuid[:12]}.local.",
        )


class Advertiser:
    """Announces one device for as long as it runs; says goodbye on stop."""

    def __init__(self, interfaces: Interfaces) -> None:
        self._interfaces = interfaces
        self._zc: AsyncZeroconf | None = None
        self._info: AsyncServiceInfo | None = None

    async def start(self, ad: Advertisement) -> None:
        if ad.kind not in KINDS:
            raise ValueError(f"unknown device kind {ad.kind!r}")
        self._zc = make_zeroconf(self._interfaces)
        self._info = ad.service_info()
        # Instance names carry the device uuid, so probing for conflicts only costs time
        # (about 1.5 s) against the ≤ 1 s discovery target.
        await self._zc.async_register_service(self._info, cooperating_responders=True)
        log.info("advertising %s", self._info.name, extra={"port": ad.port, "uuid": ad.uuid})

    async def stop(self) -> None:
        if self._zc is None:
            return
        try:
            if self._info is not None:
                await self._zc.async_unregister_service(self._info)
        finally:
            await self._zc.async_close()
            self._zc = None


@dataclass
class Detected:
    """A device seen on the network. All text fields are untrusted."""

    uuid: str
    kind: str
    model: str
    name: str
    api: str
    host: str
    port: int
    service_name: str
    last_seen: float = field(default_factory=time.time)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"


def parse_info(info: AsyncServiceInfo) -> Detected | None:
    """A resolved service record as a Detected device, or None when it is not usable."""
    props = info.properties or {}
    try:
        uuid = checked_uuid(props.get(b"uuid"))
    except ValueError as exc:
        log.warning("ignoring announcement %s: %s", clean_text(info.name, 80), exc)
        return None
    kind = clean_text(props.get(b"kind"), 16)
    addresses = info.parsed_addresses(IPVersion.V4Only)
    if kind not in KINDS or not addresses or not info.port:
        return None
    return Detected(
        uuid=uuid,
        kind=kind,
        model=clean_text(props.get(b"model"), 64),
        name=clean_text(props.get(b"name"), 64),
        api=clean_text(props.get(b"api"), 16),
        host=addresses[0],
        port=int(info.port),
        service_name=info.name,
    )


class Browser:
    """Continuously browses for devices and reports each appearance, change and goodbye."""

    def __init__(
        self,
        interfaces: Interfaces,
        on_found: Callable[[Detected], None],
        on_gone: Callable[[str], None],
    ) -> None:
        self._interfaces = interfaces
        self._on_found = on_found
        self._on_gone = on_gone
        self._zc: AsyncZeroconf | None = None
        self._browser: AsyncServiceBrowser | None = None
        self._tasks: set[asyncio.Task[None]] = set()

    async def start(self) -> None:
        self._zc = make_zeroconf(self._interfaces)
        self._browser = AsyncServiceBrowser(
            self._zc.zeroconf, SERVICE_TYPE, handlers=[self._on_change]
        )

    def _on_change(
        self, zeroconf: Zeroconf, service_type: str, name: str, state_change: ServiceStateChange
    ) -> None:
        if state_change is ServiceStateChange.Removed:
            self._on_gone(name)
            return
        task = asyncio.ensure_future(self._resolve(zeroconf, service_type, name))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _resolve(self, zeroconf: Zeroconf, service_type: str, name: str) -> None:
        info = AsyncServiceInfo(service_type, name)
        if not await info.async_request(zeroconf, 1500):
            log.warning("could not resolve %s", name)
            return
        detected = parse_info(info)
        if detected is None:
            log.warning("ignoring malformed advertisement %s", name)
            return
        self._on_found(detected)

    async def stop(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        if self._browser is not None:
            await self._browser.async_cancel()
        if self._zc is not None:
            await self._zc.async_close()
