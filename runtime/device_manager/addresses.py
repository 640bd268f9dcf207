"""Where a robot's link has been, and whether it may leave (DESIGN.md §6).

A STOP goes to every address the link used in the last minute as well as to the live
session: should the link have been moved to the wrong device, the real one still hears it.
A link whose robot was moving or in a fault when its session ended is held where it is: it
moves to another address only when the user says so."""

from __future__ import annotations

import functools
import json
import logging
import math
import time

import httpx

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.interfaces.endpoints import stream_commands
from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.device_auth import DeviceAuth

log = logging.getLogger(__name__)

RECENT = 60.0  # s an address a link used stays one that a STOP goes to
HALT_TIMEOUT = 1.0  # s a halt sent to an address the link has left may take
MOVING = 0.01  # rad/s (m/s for a linear axis): a joint faster than this is moving
FAULTS = ("error", "estop", "protective_stop")


class RecentAddresses:
    """The addresses a link used, each until `window` s after it was last used."""

    def __init__(self, window: float = RECENT) -> None:
        self.window = window
        self._used: dict[str, float] = {}

    def used(self, url: str, now: float | None = None) -> None:
        self._used[url] = time.monotonic() if now is None else now

    def recent(self, now: float | None = None) -> list[str]:
        now = time.monotonic() if now is None else now
        self._used = {url: at for url, at in self._used.items() if now - at <= self.window}
        return list(self._used)


def unsettled(state_text: str | None) -> str:
    """Why a robot whose newest state is this was not at rest: moving or in a fault ("" when
    at rest, or when there was no state)."""
    if state_text is None:
        return ""
    try:
        state = json.loads(state_text)
        flags = state.get("flags") or {}
        speeds = [abs(float(v)) for v in state.get("joint_velocity") or []]
    except (ValueError, TypeError, AttributeError):
        return "its state could not be read"
    faults = [name for name in FAULTS if flags.get(name)]
    if faults:
        return f"it was in a fault ({', '.join(faults)})"
    if flags.get("trajectory_running") or any(not math.isfinite(v) or v > MOVING for v in speeds):
        return "it was moving"
    return ""


@functools.cache
def halt_route(kind: str) -> tuple[str, str] | None:
    """(method, path) of the halt a kind with a command session declares, if any."""
    declared = registry().kinds.get(kind)
    if declared is None or not declared.session:
        return None
    try:
        ep = stream_commands(resolve(declared.interface)).get("halt")
    except Exception as exc:  # a plugin that cannot load: its streamed halt is all there is
        log.warning("the %s interface cannot be loaded: %s", kind, exc)
        return None
    return (ep.method, ep.url()) if ep is not None else None


async def halt_at(url: str, route: tuple[str, str], secret: str | None, device: str) -> None:
    """One halt, signed, to the device at `url` (outside any session)."""
    method, path = route
    # A halt is good for whichever process of the driver answers: signed for its boot id.
    auth = DeviceAuth(secret, follow_restarts=True) if secret else None
    try:
        async with httpx.AsyncClient(
            base_url=url, timeout=HALT_TIMEOUT, auth=auth, trust_env=False, verify=CLIENT_TLS
        ) as http:
            answer = await http.request(method, path)
    except httpx.HTTPError as exc:
        log.info("%s: the halt to %s did not arrive: %s", device, url, type(exc).__name__)
        return
    if answer.status_code >= 400:
        log.info("%s: %s refused the halt (HTTP %d)", device, url, answer.status_code)
    else:
        log.info("%s: halted at %s outside its session", device, url)
