"""`openpendant doctor`: is this computer ready to run a cell? Each check says `ok`, `warn`
(it runs, but something is off) or `fix` (it will not work until this is done), and what to
do; the exit status is 1 when anything needs fixing. Nothing is changed: it only looks."""

from __future__ import annotations

import contextlib
import ctypes
import datetime
import ipaddress
import json
import socket
import sqlite3
import stat
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal
from urllib.parse import urlsplit

import ifaddr
from cryptography import x509

from openpendant.runtime.kit.settings import RuntimeSettings, is_loopback
from openpendant.runtime.kit.tls import host_names, permitted, tls_files
from openpendant.runtime.launcher.backup import BackupError, check_databases, runtime_running

Verdict = Literal["ok", "warn", "fix"]
IFF_UP, IFF_MULTICAST = 0x1, 0x1000
CONNECT_TIMEOUT = 1.0  # s a device has to accept a connection


@dataclass(frozen=True)
class Finding:
    verdict: Verdict
    what: str
    todo: str = ""

    def line(self) -> str:
        return f"{self.verdict:4}  {self.what}" + (f"\n      → {self.todo}" if self.todo else "")


def data_directory(settings: RuntimeSettings) -> Iterator[Finding]:
    data = settings.data_dir
    if not data.exists():
        yield Finding("ok", f"data directory {data}: made at the first start")
        return
    opened = [
        path
        for path in (data, *data.rglob("*"))
        if not path.is_symlink() and stat.S_IMODE(path.lstat().st_mode) & 0o077
    ]
    if opened:
        shown = ", ".join(str(p) for p in opened[:3]) + (" …" if len(opened) > 3 else "")
        yield Finding(
            "warn",
            f"readable by other users: {shown}",
            f"chmod -R go-rwx {data} (the runtime does this itself at its next start)",
        )
    else:
        yield Finding("ok", f"data directory {data}: its owner's only")
    try:
        check_databases(data)
    except BackupError as exc:
        yield Finding("fix", str(exc).split("; ")[0], str(exc).split("; ", 1)[-1])
    else:
        yield Finding("ok", "databases whole, at versions this release knows")


def ports(settings: RuntimeSettings) -> Iterator[Finding]:
    if runtime_running(settings.data_dir):
        yield Finding("ok", f"a runtime is running on {settings.data_dir}: its ports are its own")
        return
    wanted = [("UI", settings.port, "--port (or port: in the config)")]
    if settings.jog_port:
        wanted.append(("jog socket", settings.jog_port, "jog_port: in the config"))
    if settings.tls.enabled and settings.tls.redirect_port:
        wanted.append(("plain HTTP", settings.tls.redirect_port, "tls.redirect_port"))
    for what, port, how in wanted:
        family = socket.AF_INET6 if ":" in settings.host else socket.AF_INET
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            try:
                probe.bind((settings.host, port))
            except OSError as exc:
                yield Finding(
                    "fix",
                    f"the {what} port {settings.host}:{port} cannot be used: {exc.strerror}",
                    f"stop what holds it (ss -ltnp 'sport = :{port}') or choose another with {how}",
                )
            else:
                yield Finding("ok", f"the {what} port {settings.host}:{port} is free")


def _interface_flags(name: str) -> int | None:
    try:
        return int(Path(f"/sys/class/net/{name}/flags").read_text().strip(), 16)
    except (OSError, ValueError):
        return None


def multicast(settings: RuntimeSettings) -> Iterator[Finding]:
    chosen = settings.zeroconf_interfaces()
    for adapter in ifaddr.get_adapters():
        addresses = [str(ip.ip) for ip in adapter.ips if isinstance(ip.ip, str)]
        if chosen != "all" and not set(addresses) & set(chosen):
            continue
        flags = _interface_flags(adapter.name)
        if flags is None:
            continue
        loopback = any(ipaddress.ip_address(a).is_loopback for a in addresses)
        if not flags & IFF_UP:
            yield Finding("warn", f"{adapter.name} is down: no device is found through it")
        elif not flags & IFF_MULTICAST and not loopback:
            yield Finding(
                "fix",
                f"{adapter.name} ({', '.join(addresses)}) has multicast off: devices on it "
                "are never discovered",
                f"ip link set {adapter.name} multicast on",
            )
        else:
            yield Finding("ok", f"discovery on {adapter.name} ({', '.join(addresses)})")


def time_sync() -> Iterator[Finding]:
    try:
        answer = subprocess.run(
            ["timedatectl", "show", "-p", "NTPSynchronized", "--value"],
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.TimeoutExpired):
        answer = None
    synced = answer is not None and answer.returncode == 0 and answer.stdout.strip() == "yes"
    if synced:
        yield Finding("ok", "the clock is synchronised")
    else:
        yield Finding(
            "warn",
            "the clock is not known to be synchronised: a device's signed commands are good "
            "for 60 s either side of its clock, and logs compare badly",
            "enable time synchronisation: timedatectl set-ntp true (systemd-timesyncd or chrony)",
        )


def device_addresses(settings: RuntimeSettings) -> list[tuple[str, str]]:
    """The added devices (name, URL), read from the variable storage without changing it."""
    path = settings.data_dir / "variables.sqlite"
    if not path.exists():
        return []
    try:
        with contextlib.closing(sqlite3.connect(f"{path.as_uri()}?mode=ro", uri=True)) as db:
            rows = db.execute(
                "SELECT name, value FROM variables WHERE type = 'device' ORDER BY name"
            ).fetchall()
    except sqlite3.Error:
        return []
    found = []
    for name, value in rows:
        with contextlib.suppress(ValueError, TypeError, KeyError):
            found.append((str(name).removeprefix("devices."), str(json.loads(value)["url"])))
    return found


def devices(settings: RuntimeSettings) -> Iterator[Finding]:
    for name, url in device_addresses(settings):
        parts = urlsplit(url)
        host, port = parts.hostname or "", parts.port or 80
        try:
            with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT):
                yield Finding("ok", f"device {name} answers at {host}:{port}")
        except OSError as exc:
            yield Finding(
                "warn",
                f"device {name} does not answer at {host}:{port} ({exc.strerror or exc})",
                "is it on, and on this network? (ping it; check the cable and its address)",
            )


def sandbox() -> Iterator[Finding]:
    try:
        ctypes.CDLL("libseccomp.so.2")  # as the sandbox loads it
    except OSError:
        yield Finding(
            "warn",
            "libseccomp is missing: programs run without their system-call filter",
            "apt-get install libseccomp2",
        )
    else:
        yield Finding("ok", "libseccomp is there: programs run with a system-call filter")


def https(settings: RuntimeSettings) -> Iterator[Finding]:
    files = tls_files(settings)
    if files is None:
        if not is_loopback(settings.host):
            yield Finding(
                "warn",
                "the UI is served to the network in clear: passwords and sessions can be read",
                "set tls: {enabled: true} in the config (or run --tls)",
            )
        return
    if files.ca is not None and not files.ca.is_file():
        yield Finding("ok", "HTTPS: the runtime makes its certificate authority at its next start")
        return
    try:
        certificate = x509.load_pem_x509_certificates(files.cert.read_bytes())[0]
    except (OSError, ValueError) as exc:
        yield Finding("fix", f"HTTPS: cannot read the certificate {files.cert}: {exc}")
        return
    if files.ca is not None:
        yield from _authority_reach(settings, files.ca)
    left = (certificate.not_valid_after_utc - datetime.datetime.now(datetime.UTC)).days
    renew = (
        "restart the runtime (it renews its own)" if files.ca else "renew the site's certificate"
    )
    if left < 0:
        yield Finding("fix", f"HTTPS: the certificate {files.cert} has expired", renew)
    elif left < 30:
        yield Finding("warn", f"HTTPS: the certificate {files.cert} ends in {left} days", renew)
    else:
        yield Finding("ok", f"HTTPS: a tablet trusts the fingerprint {files.fingerprint()}")


def _authority_reach(settings: RuntimeSettings, ca: Path) -> Iterator[Finding]:
    """The runtime's authority vouches only for the names and networks it was made with."""
    try:
        authority = x509.load_pem_x509_certificate(ca.read_bytes())
    except (OSError, ValueError) as exc:
        yield Finding("fix", f"HTTPS: cannot read the certificate authority {ca}: {exc}")
        return
    names, addresses = host_names(settings)
    outside = [str(n) for n in (*names, *addresses) if not permitted(n, authority)]
    if outside:
        yield Finding(
            "warn",
            f"HTTPS: the certificate authority was made before {', '.join(outside)} was this "
            "computer's: a tablet using it is warned",
            f"move {ca.parent} aside and start again (tablets must trust the new authority)",
        )


def findings(settings: RuntimeSettings) -> list[Finding]:
    return [
        *data_directory(settings),
        *ports(settings),
        *https(settings),
        *multicast(settings),
        *time_sync(),
        *devices(settings),
        *sandbox(),
    ]


def doctor(settings: RuntimeSettings) -> int:
    found = findings(settings)
    print("\n".join(f.line() for f in found))
    return 1 if any(f.verdict == "fix" for f in found) else 0
