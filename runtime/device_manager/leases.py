"""Single point of control: at most one client holds a device's control lease at a time.
Others may watch but not command it until the holder releases the lease or lets it lapse."""

from __future__ import annotations

import json
import logging
import os
import secrets
import time
from dataclasses import dataclass
from pathlib import Path

from openpendant.runtime.device_manager.models import LeaseGranted, LeaseInfo
from openpendant.runtime.kit.constant_time import same_secret
from openpendant.runtime.kit.errors import Conflict, OpenPendantError
from openpendant.runtime.kit.words import words

log = logging.getLogger(__name__)

LEASE_SECONDS = 15.0


class LeaseRefused(OpenPendantError):
    status = 409
    code = "lease_held"


@dataclass
class _Lease:
    holder: str
    token: str
    expires: float


class LeaseBook:
    """Leases in memory, and on disk (`path`) as they are taken and released, so that a
    restarted device manager hands no robot to someone else while its holder lives: each
    lease comes back with a full term, which its holder's next use renews."""

    def __init__(self, seconds: float = LEASE_SECONDS, path: Path | None = None) -> None:
        self.seconds = seconds
        self.path = path
        self._leases: dict[str, _Lease] = {}
        self._load()

    def _load(self) -> None:
        if self.path is None or not self.path.is_file():
            return
        try:
            stored = json.loads(self.path.read_text())
            restart = time.time() + self.seconds
            for device, lease in stored.items():
                self._leases[device] = _Lease(
                    holder=str(lease["holder"]),
                    token=str(lease["token"]),
                    expires=max(float(lease["expires"]), restart),
                )
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            log.warning("could not restore the control leases from %s: %s", self.path, exc)

    def _save(self) -> None:
        if self.path is None:
            return
        body = {
            device: {"holder": lease.holder, "token": lease.token, "expires": lease.expires}
            for device, lease in self._leases.items()
        }
        temporary = self.path.with_suffix(".tmp")
        try:
            descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            with os.fdopen(descriptor, "w") as out:
                json.dump(body, out)
            os.replace(temporary, self.path)
        except OSError as exc:
            log.warning("could not store the control leases in %s: %s", self.path, exc)

    def _live(self, device: str, now: float) -> _Lease | None:
        lease = self._leases.get(device)
        if lease is not None and lease.expires <= now:
            del self._leases[device]
            self._save()
            return None
        return lease

    def info(self, device: str) -> LeaseInfo:
        lease = self._live(device, time.time())
        if lease is None:
            return LeaseInfo(device=device)
        return LeaseInfo(device=device, holder=lease.holder, expires=lease.expires)

    def acquire(self, device: str, holder: str, token: str | None = None) -> LeaseGranted:
        """Take the lease if it is free; the current holder (by token) renews it."""
        now = time.time()
        lease = self._live(device, now)
        if lease is not None and lease.token != token:
            raise LeaseRefused(
                f"{device} is controlled by {lease.holder!r} for another "
                f"{lease.expires - now:.0f} s unless they release it",
                words=words("lease.held", device=device, holder=lease.holder),
            )
        if lease is None:
            token = secrets.token_urlsafe(16)
            lease = _Lease(holder=holder, token=token, expires=now + self.seconds)
            self._leases[device] = lease
            self._save()
        else:
            lease.expires = now + self.seconds
        return LeaseGranted(
            device=device, holder=lease.holder, token=lease.token, expires=lease.expires
        )

    def check(self, device: str, token: str | None) -> LeaseGranted:
        """The holder's token is valid: the lease is renewed by the use. Otherwise refused."""
        lease = self._live(device, time.time())
        if lease is None:
            raise LeaseRefused(
                f"take control of {device} first",
                code="lease_required",
                words=words("lease.required", device=device),
            )
        if token is None or not same_secret(lease.token, token):
            raise LeaseRefused(
                f"{device} is controlled by {lease.holder!r}",
                words=words("lease.held", device=device, holder=lease.holder),
            )
        return self.acquire(device, lease.holder, token)

    def release(self, device: str, token: str | None) -> None:
        lease = self._live(device, time.time())
        if lease is None:
            return
        if token is None or not same_secret(lease.token, token):
            raise Conflict(
                f"{device} is controlled by {lease.holder!r}",
                code="lease_held",
                words=words("lease.held", device=device, holder=lease.holder),
            )
        del self._leases[device]
        self._save()

    def drop(self, device: str) -> None:
        if self._leases.pop(device, None) is not None:
            self._save()

    def sweep(self) -> bool:
        """Forget lapsed leases; True when any lapsed."""
        now = time.time()
        lapsed = [d for d, lease in self._leases.items() if lease.expires <= now]
        for device in lapsed:
            del self._leases[device]
        if lapsed:
            self._save()
        return bool(lapsed)
