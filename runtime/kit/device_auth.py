"""A device obeys only the runtime it is paired with: a secret per device, kept by both
(`<data-dir>/device-secrets/<uuid>`, readable by its owner only; a device on another computer
shows it as its pairing code, and the administrator gives it when adding the device).

The secret itself never travels. Each command request and command socket carries
`X-Device-Auth: <time>.<nonce>.<body digest>.<mac>`, the MAC an HMAC-SHA256 of time, nonce,
the driver's boot id, method, path and the body's SHA-256: good for a minute, once, for that
body, and only by the driver process it was made for. The driver checks the MAC before it
reads a byte of the body (only its runtime makes it read one), then the body against the
digest. The boot id is random at each start of a driver and
sent in the `X-Device-Boot` header of its every answer, so a command or a socket's handshake
captured before a restart (when the record of what was used is gone) is refused after it.

A device that announces itself at a new address proves it has the secret by answering a
fresh challenge (`GET /pair/proof?nonce=…`) before the runtime follows it; an impostor
cannot. The proof covers the address the device serves the challenge from (the
local end of the connection it came in on, so a device bound to every interface names the
one it was reached at), and the runtime checks it against the address it reached: an
impostor that passes the challenge on to the real device gets back a proof of the device's
own address, not of the impostor's."""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import json
import math
import re
import secrets
import time
from collections import OrderedDict
from collections.abc import Generator
from pathlib import Path

import httpx

from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.constant_time import same_secret

HEADER = "X-Device-Auth"
BOOT_HEADER = "X-Device-Boot"
PROOF_PATH = "/pair/proof"
MAX_PROOF = 4096  # bytes of a proof's answer
WINDOW = 60.0  # s either side of the device's clock
FOLDER = "device-secrets"
RUNTIME_ID = "runtime-id"  # the installation's id in its data directory (the launcher's)
SAFE_UUID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._:-]{0,63}\Z")


def secret_path(data_dir: Path, uuid: str) -> Path:
    if not SAFE_UUID.match(uuid) or uuid in (".", ".."):
        raise ValueError(f"not a device uuid: {uuid[:40]!r}")
    return data_dir / FOLDER / uuid


def known_secret(data_dir: Path, uuid: str) -> str | None:
    try:
        return secret_path(data_dir, uuid).read_text().strip() or None
    except (FileNotFoundError, ValueError):
        return None


def keep_secret(data_dir: Path, uuid: str, secret: str) -> None:
    path = secret_path(data_dir, uuid)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.parent.chmod(0o700)
    path.touch(mode=0o600)
    path.chmod(0o600)
    path.write_text(secret + "\n")


def device_secret(data_dir: Path, uuid: str) -> str:
    """The device's secret, made on its first start."""
    found = known_secret(data_dir, uuid)
    if found is None:
        found = secrets.token_urlsafe(24)
        keep_secret(data_dir, uuid, found)
    return found


def _mac(secret: str, text: str) -> str:
    return hmac.new(secret.encode(), text.encode(), hashlib.sha256).hexdigest()


def key_id(secret: str) -> str:
    """The public name of a pairing key, announced by its device: a runtime that holds a key
    for the device's uuid sees whether it is this one. The same for every holder of the key
    and, a MAC of a fixed text under it, nothing of the key (a guess of a weak key can be
    checked against it offline, as against any signed request on the wire). Anyone may copy
    it: it marks, the challenge proves."""
    return _mac(secret, "openpendant key id")[:16]


def runtime_tag(data_dir: Path) -> str | None:
    """The public name of the runtime whose data directory this is, announced by the devices
    it starts so that other runtimes list them as its own; None before the launcher made its
    id. A hash: the id itself names its devices' uuids."""
    try:
        made = (data_dir / RUNTIME_ID).read_text().strip()
    except (FileNotFoundError, NotADirectoryError):
        return None
    return hashlib.sha256(f"openpendant runtime/{made}".encode()).hexdigest()[:16] if made else None


def new_boot() -> str:
    """A driver process's boot id."""
    return secrets.token_hex(8)


def body_digest(body: bytes) -> str:
    return hashlib.sha256(body).hexdigest()


EMPTY_BODY = body_digest(b"")


def _signed_text(stamp: str, nonce: str, boot: str, method: str, path: str, digest: str) -> str:
    return f"{stamp}.{nonce}.{boot}.{method.upper()}.{path}.{digest}"


def sign(
    secret: str,
    method: str,
    path: str,
    *,
    boot: str,
    body: bytes = b"",
    now: float | None = None,
) -> str:
    """The header's value for one request to the driver process whose boot id is `boot`."""
    stamp = f"{now if now is not None else time.time():.3f}"
    nonce = secrets.token_hex(8)
    digest = body_digest(body)
    mac = _mac(secret, _signed_text(stamp, nonce, boot, method, path, digest))
    return f"{stamp}.{nonce}.{digest}.{mac}"


def address_text(host: str, port: int) -> str:
    """`host:port` as both ends spell it (an IPv4 address mapped into IPv6 as itself)."""
    try:
        ip = ipaddress.ip_address(host.split("%", 1)[0])
    except ValueError:
        return f"{host.lower()}:{port}"
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        ip = ip.ipv4_mapped
    return f"[{ip.compressed}]:{port}" if ip.version == 6 else f"{ip}:{port}"


def proof(secret: str, nonce: str, address: str) -> str:
    """The answer to a challenge, from the device serving it at `address` (`host:port`)."""
    return _mac(secret, f"proof.{nonce}.{address}")


async def disproof(url: str, secret: str, timeout: float = 2.0) -> str | None:
    """None when what answers at `url` proves it holds the secret and serves from the address
    this runtime reached; else why it does not."""
    nonce = secrets.token_hex(16)
    try:
        # No proxy from the environment: the address reached must be the device's own.
        async with (
            httpx.AsyncClient(
                base_url=url, timeout=timeout, trust_env=False, verify=CLIENT_TLS
            ) as http,
            http.stream("GET", PROOF_PATH, params={"nonce": nonce}) as answer,
        ):
            if answer.status_code != 200:
                return f"no proof (HTTP {answer.status_code})"
            stream = answer.extensions.get("network_stream")
            peer = stream.get_extra_info("server_addr") if stream is not None else None
            raw = bytearray()
            async for chunk in answer.aiter_bytes():
                raw += chunk
                if len(raw) > MAX_PROOF:
                    return "its answer to the challenge is too long"
        body = json.loads(raw)
    except (httpx.HTTPError, ValueError) as exc:
        return f"no proof: {type(exc).__name__}"
    if not isinstance(body, dict):
        return "no proof: its answer is not an object"
    if not isinstance(peer, tuple) or len(peer) < 2:
        return "the address it was reached at is not known"
    reached = address_text(str(peer[0]), int(peer[1]))
    if same_secret(str(body.get("proof", "")), proof(secret, nonce, reached)):
        return None
    covered = str(body.get("address", ""))[:80]
    if covered != reached:
        return f"its proof is for {covered!r}, not for {reached}: passed on from elsewhere"
    return "a wrong proof"


class Verifier:
    """The device's side: each signature is good once, within the window, for this process."""

    def __init__(self, secret: str, boot: str) -> None:
        self.secret = secret
        self.boot = boot
        self.seen: OrderedDict[str, float] = OrderedDict()

    def check_header(
        self, value: str | None, method: str, path: str, now: float | None = None
    ) -> str | None:
        """The body digest a genuine, fresh, unused header vouches for (the header is used
        up); None for any other header."""
        if not value or not value.isascii() or value.count(".") < 4 or len(value) > 300:
            return None
        stamp, nonce, digest, mac = value.rsplit(".", 3)
        try:
            at = float(stamp)
        except ValueError:
            return None
        now = time.time() if now is None else now
        if not math.isfinite(at) or abs(now - at) > WINDOW or value in self.seen:
            return None
        expected = _mac(self.secret, _signed_text(stamp, nonce, self.boot, method, path, digest))
        if not same_secret(mac, expected):
            return None
        self.seen[value] = at
        while self.seen and next(iter(self.seen.values())) < now - 2 * WINDOW:
            self.seen.popitem(last=False)
        return digest

    def check(
        self,
        value: str | None,
        method: str,
        path: str,
        body: bytes = b"",
        now: float | None = None,
    ) -> bool:
        digest = self.check_header(value, method, path, now)
        return digest is not None and same_secret(digest, body_digest(body))


class DeviceAuth(httpx.Auth):
    """Signs every request of an httpx client to one device, for the driver process whose
    boot id it learned from the first answer. A command refused because it was signed for no
    process or another is signed again for the boot id the refusal names and sent once more
    (it is this client's own request, not a replay) only while no boot id is known, or, with
    `follow_restarts`, after any restart (a halt, a test's view of a device). A runtime's
    session follows none: a driver that restarted ends it, and nothing of the old session is
    sent to the new process."""

    requires_request_body = True

    def __init__(self, secret: str, boot: str | None = None, follow_restarts: bool = False):
        self.secret = secret
        self.boot = boot or ""
        self.follow_restarts = follow_restarts

    def header(self, method: str, path: str, body: bytes = b"") -> str:
        return sign(self.secret, method, path, boot=self.boot, body=body)

    def auth_flow(self, request: httpx.Request) -> Generator[httpx.Request, httpx.Response, None]:
        request.headers[HEADER] = self.header(request.method, request.url.path, request.content)
        response = yield request
        named = response.headers.get(BOOT_HEADER, "")
        if not named or named == self.boot or len(named) > 64:
            return
        if self.boot and not self.follow_restarts:
            return
        self.boot = named
        if response.status_code == 401:
            request.headers[HEADER] = self.header(request.method, request.url.path, request.content)
            yield request
