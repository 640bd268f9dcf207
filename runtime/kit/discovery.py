"""DNS-SD advertisement and browsing of `_openpendant._tcp.local.` (DESIGN.md §5).

Every Zeroconf instance here is created with an explicit interface list: tests and a runtime
bound to loopback must never multicast on a real interface.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import logging
import re
import socket
import time
import unicodedata
from collections.abc import Awaitable, Callable, Coroutine
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any, Literal, cast

from zeroconf import (
    InterfaceChoice,
    IPVersion,
    ServiceStateChange,
    Zeroconf,
    current_time_millis,
)

# Exported by zeroconf, outside its __all__:
from zeroconf._cache import DNSCache
from zeroconf._dns import DNSQuestion, DNSRecord
from zeroconf._protocol.outgoing import DNSOutgoing
from zeroconf.asyncio import AsyncServiceBrowser, AsyncServiceInfo, AsyncZeroconf

from openpendant.runtime.kit.api_version import API_VERSION
from openpendant.runtime.kit.confirmations import Confirmations

log = logging.getLogger(__name__)

SERVICE_TYPE = "_openpendant._tcp.local."
SO_RCVBUFFORCE = getattr(socket, "SO_RCVBUFFORCE", 33)
# A device kind, as its plugin names it (robot, camera, detector, io, gripper, input, …).
KIND_PATTERN = re.compile(r"^[a-z][a-z0-9_]{0,15}\Z")
DEFAULT_TTL = 15
FOLLOW_INTERFACES = 5.0  # s between re-scans of the network interfaces
RECEIVE_BUFFER = 4 << 20  # bytes: a burst of announcements must not overflow the socket
RESOLVE_ATTEMPTS = 3
SWEEP = 0.25  # s between checks that detected devices still answer
DNS_TXT, DNS_SRV, DNS_IN, DNS_QUERY = 16, 33, 1, 0x0000  # RFC 1035 / 2782 numbers
UUID_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._:-]{0,63}\Z")
# A pairing key's id or a runtime's tag, as announced (runtime/kit/device_auth.py).
PUBLIC_ID = re.compile(r"^[0-9a-f]{16}\Z")
LABEL_BYTES = 63  # RFC 1035 §2.3.4: a DNS label's limit
# python-zeroconf writes every "." of a name as a label boundary, with no escaping: a dot in
# an instance name would reach every browser as two labels. RFC 6763 §4.1.1 allows dots
# there, so one is announced as U+2024 ONE DOT LEADER, which looks the same.
DOT = "\u2024"
NAME_CHECK = 0.25  # s: how long a new announcer waits for a live holder of its name to answer
NAME_COPIES = 9  # "-2" … "-9" tried for a name that is taken
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


async def follow_interfaces(zc: AsyncZeroconf, receiving: bool = False) -> None:
    """Interfaces that come and go after start (a cable plugged in, a VPN, a namespace's
    veth) are listened and announced on: a re-scan is a no-op when nothing changed."""
    while True:
        await asyncio.sleep(FOLLOW_INTERFACES)
        try:
            await zc.zeroconf.async_update_interfaces()
        except (OSError, RuntimeError) as exc:
            log.warning("could not follow the network interfaces: %s", exc)
            continue
        if receiving:
            enlarge_receive_buffers(zc)


def enlarge_receive_buffers(zc: AsyncZeroconf) -> None:
    for reader in zc.zeroconf.engine.readers:
        sock = reader.sock
        try:  # beyond net.core.rmem_max where allowed (root), else up to it
            sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, RECEIVE_BUFFER)
        except OSError:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)


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


def instance_label(name: str, suffix: str, fallback: str) -> str:
    """An instance name as RFC 6763 §4.1.1 has it: the user's name in UTF-8 (any script,
    spaces, dots, punctuation), no control or format characters, at most 63 bytes with
    `suffix`, cut where a character ends."""
    text = unicodedata.normalize("NFC", clean_text(name, LABEL_BYTES)).strip() or fallback
    tail = f" {suffix}".replace(".", DOT)
    head = text.replace(".", DOT).encode()[: LABEL_BYTES - len(tail.encode())]
    return head.decode("utf-8", "ignore").rstrip() + tail


@dataclass(frozen=True)
class Advertisement:
    uuid: str
    kind: str
    model: str
    name: str
    host: str
    port: int
    # The id of the device's pairing key (device_auth.key_id; "" for none): announced, and
    # with the uuid it makes the names, so that a device restarted keeps them (browsers
    # replace its old records instead of listing both) and two devices that claim one uuid
    # with different keys (a cloned board, an impostor) do not share them, where the
    # goodbye of either would end the other's announcement in every browser.
    key: str
    # The tag of the runtime that started the device (device_auth.runtime_tag), if one did.
    runtime: str = ""
    api: str = API_VERSION
    # s: how long browsers keep the records when no goodbye comes (a device that lost
    # power). RFC 6762's 75 minutes is far too long for a pendant's list of devices.
    ttl: int = DEFAULT_TTL
    # RFC 6762 §9: 2, 3, … when another live announcer holds the name (the same uuid and key
    # on two processes at once): the newcomer takes the next.
    copy: int = 1

    @property
    def tag(self) -> str:
        made = hashlib.blake2s(f"{self.uuid}\n{self.key}".encode(), digest_size=4).hexdigest()
        return made if self.copy == 1 else f"{made}-{self.copy}"

    def instance_name(self) -> str:
        label = instance_label(self.name, f"[{self.uuid[:8]} {self.tag}]", self.kind)
        return f"{label}.{SERVICE_TYPE}"

    def service_info(self) -> AsyncServiceInfo:
        properties = {
            "uuid": self.uuid,
            "kind": self.kind,
            "model": self.model,
            "name": self.name,
            "api": self.api,
        }
        properties |= {k: v for k, v in (("key", self.key), ("runtime", self.runtime)) if v}
        host = re.sub(r"[^A-Za-z0-9-]", "-", self.uuid[:12])
        return AsyncServiceInfo(
            SERVICE_TYPE,
            self.instance_name(),
            addresses=[socket.inet_aton(self.host)],
            port=self.port,
            properties=properties,
            # Its own host name too: two announcers of one uuid on one host name would have
            # their addresses merged in every browser's cache (one's port, the other's IP).
            server=f"openpendant-{host}-{self.tag}.local.",
            host_ttl=self.ttl,
            other_ttl=self.ttl,
        )


async def name_taken(zc: Zeroconf, proposed: AsyncServiceInfo, wait: float = NAME_CHECK) -> bool:
    """Whether another live announcer answers for `proposed`'s name within `wait` s.

    Asked as a probe (RFC 6762 §8.1), which a responder answers at once: a plain question
    about a record it multicast within the last second is answered only after that second
    (§14), and a copy started in that second took the name of the device it copies. The
    proposed records go in the authority section (§8.2), so the probe differs from the
    holder's own check, which it heard: zeroconf drops a packet that repeats, byte for
    byte, one received within the last second."""
    name = proposed.name
    query = DNSOutgoing(DNS_QUERY)
    query.add_question(DNSQuestion(name, DNS_SRV, DNS_IN))
    # Typed for pointers only; zeroconf writes any record there.
    authorities = cast(list[DNSRecord], query.authorities)
    authorities += [proposed.dns_service(), proposed.dns_text()]
    zc.async_send(query)
    deadline = time.monotonic() + wait
    while newest_record(zc.cache, current_time_millis(), name) is None:
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        await zc.async_wait(left * 1000.0)  # wakes on every update of the cache
    return True


class Advertiser:
    """Announces one device for as long as it runs; says goodbye on stop."""

    def __init__(self, interfaces: Interfaces) -> None:
        self._interfaces = interfaces
        self._zc: AsyncZeroconf | None = None
        self._info: AsyncServiceInfo | None = None
        self._announcing: Awaitable[object] | None = None
        self._follower: asyncio.Task[None] | None = None

    async def start(self, ad: Advertisement) -> None:
        if not KIND_PATTERN.match(ad.kind):
            raise ValueError(f"malformed device kind {ad.kind!r}")
        self._zc = make_zeroconf(self._interfaces)
        await self._zc.zeroconf.async_wait_for_start()
        # The names are the device's own (its uuid and key), so zeroconf's probing (about
        # 1.5 s, against the ≤ 1 s discovery target) is not needed: one question whether
        # the same device runs elsewhere already. The returned task repeats the
        # announcement (the first is out already).
        while ad.copy < NAME_COPIES and await name_taken(self._zc.zeroconf, ad.service_info()):
            ad = replace(ad, copy=ad.copy + 1)
        self._info = ad.service_info()
        self._announcing = await self._zc.async_register_service(
            self._info, cooperating_responders=True
        )
        self._follower = asyncio.create_task(follow_interfaces(self._zc))
        log.info("advertising %s", self._info.name, extra={"port": ad.port, "uuid": ad.uuid})

    @property
    def announced(self) -> str | None:
        """The instance name it announces under (None before it starts)."""
        return self._info.name if self._info is not None else None

    async def stop(self) -> None:
        if self._zc is None:
            return
        if self._follower is not None:
            self._follower.cancel()
        try:
            if self._info is not None:
                # The goodbye is sent by the task this returns: closing before it finishes
                # left stopped devices listed until their records' TTL ran out.
                goodbye = await self._zc.async_unregister_service(self._info)
                await goodbye
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
    key: str = ""  # the id of its pairing key, as announced ("": none announced)
    runtime: str = ""  # the tag of the runtime that started it, as announced

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
    kind = clean_text(props.get(b"kind"), 64)  # refused below when too long, never cut
    addresses = info.parsed_addresses(IPVersion.V4Only)
    if not KIND_PATTERN.match(kind) or not addresses or not info.port:
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
        key=public_id(props.get(b"key")),
        runtime=public_id(props.get(b"runtime")),
    )


def public_id(raw: bytes | None) -> str:
    """A key id or a runtime tag as announced; "" when there is none or it is malformed."""
    text = clean_text(raw, 32)  # a longer one is refused, not cut
    return text if PUBLIC_ID.match(text) else ""


def newest_record(cache: DNSCache, now: float, name: str) -> tuple[float, float] | None:
    """The newest live service record of `name` in zeroconf's cache: (created, TTL) in ms."""
    records = cache.get_all_by_details(name, DNS_SRV, DNS_IN)
    live = [r for r in records if not r.is_expired(now)]
    if not live:
        return None
    record = max(live, key=lambda r: r.created)
    return record.created, record.ttl * 1000.0


class Browser:
    """Continuously browses for devices and reports each appearance, change and goodbye.

    `vouched(device)`: whether the device has a live link at the address it announced; such
    a device is not reported gone when its records lapse (runtime/kit/confirmations.py)."""

    def __init__(
        self,
        interfaces: Interfaces,
        on_found: Callable[[Detected], None],
        on_gone: Callable[[str], None],
        vouched: Callable[[Detected], bool] = lambda device: False,
    ) -> None:
        self._interfaces = interfaces
        self._on_found = on_found
        self._on_gone = on_gone
        self._vouched = vouched
        self._zc: AsyncZeroconf | None = None
        self._browser: AsyncServiceBrowser | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self._follower: asyncio.Task[None] | None = None
        self._sweeper: asyncio.Task[None] | None = None
        self._confirmations = Confirmations()
        self._found: dict[str, Detected] = {}  # per instance name, as last resolved
        self._rechecking: set[str] = set()

    async def start(self) -> None:
        self._zc = make_zeroconf(self._interfaces)
        await self._zc.zeroconf.async_wait_for_start()
        enlarge_receive_buffers(self._zc)
        self._browser = AsyncServiceBrowser(
            self._zc.zeroconf, SERVICE_TYPE, handlers=[self._on_change]
        )
        self._follower = asyncio.create_task(follow_interfaces(self._zc, receiving=True))
        self._sweeper = asyncio.create_task(self._sweep())

    def _on_change(
        self, zeroconf: Zeroconf, service_type: str, name: str, state_change: ServiceStateChange
    ) -> None:
        if state_change is ServiceStateChange.Removed:
            if self._confirmations.ended(name):
                self._found.pop(name, None)
                self._on_gone(name)
            return
        self._start(self._resolve(zeroconf, service_type, name))

    def _start(self, job: Coroutine[Any, Any, None]) -> None:
        task = asyncio.ensure_future(job)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _resolve(self, zeroconf: Zeroconf, service_type: str, name: str) -> None:
        info = AsyncServiceInfo(service_type, name)
        for attempt in range(RESOLVE_ATTEMPTS):
            if await info.async_request(zeroconf, 1500):
                break
            await asyncio.sleep(0.2 * (attempt + 1))
        else:
            log.warning("could not resolve %s", clean_text(name, 120))
            self._confirmations.unresolved(name, current_time_millis())
            return
        detected = parse_info(info)
        if detected is None:
            log.warning("ignoring malformed advertisement %s", clean_text(name, 120))
            return
        if self._confirmations.is_lost(name):
            log.info("%s answers again", clean_text(name, 120))
        self._confirmations.confirmed(name, current_time_millis())
        self._found[name] = detected
        self._on_found(detected)

    async def _recheck(self, zeroconf: Zeroconf, name: str) -> None:
        try:
            await self._resolve(zeroconf, SERVICE_TYPE, name)
        finally:
            self._rechecking.discard(name)

    async def _sweep(self) -> None:
        """A device that vanished without a goodbye (power lost) leaves the list when its
        service record's TTL (the device's `discovery.ttl`) runs out. zeroconf keeps the
        pointer records for at least 19 minutes, so the service records decide: each is
        asked to confirm itself past half its TTL, and again every tenth of it; one that
        lapses is gone unless its device's link is live, and is asked for again until it
        answers (runtime/kit/confirmations.py)."""
        while True:
            await asyncio.sleep(SWEEP)
            if self._zc is not None:
                self._sweep_once(self._zc.zeroconf, current_time_millis())

    def _sweep_once(self, zc: Zeroconf, now: float) -> None:
        newest = partial(newest_record, zc.cache, now)
        step = self._confirmations.step(now, newest, self._is_vouched)
        for name in step.gone:
            log.info("%s stopped answering: gone", clean_text(name, 120))
            self._on_gone(name)
        # A lapsed name's device is kept: its link coming back is the network coming back.
        for name in [n for n in self._found if not self._confirmations.follows(n)]:
            del self._found[name]
        for name in step.recheck:
            if name not in self._rechecking:
                self._rechecking.add(name)
                self._start(self._recheck(zc, name))
        if step.ask:
            query = DNSOutgoing(DNS_QUERY)
            for name in step.ask:
                query.add_question(DNSQuestion(name, DNS_SRV, DNS_IN))
                if self._confirmations.is_lost(name):  # its text lapsed with it
                    query.add_question(DNSQuestion(name, DNS_TXT, DNS_IN))
            zc.async_send(query)

    def _is_vouched(self, name: str) -> bool:
        device = self._found.get(name)
        return device is not None and self._vouched(device)

    async def stop(self) -> None:
        for job in (self._follower, self._sweeper):
            if job is not None:
                job.cancel()
        for task in list(self._tasks):
            task.cancel()
        if self._browser is not None:
            await self._browser.async_cancel()
        if self._zc is not None:
            await self._zc.async_close()
