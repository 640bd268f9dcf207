"""The devices announced on the network, kept per announcement (its instance name), not per
uuid: two announcements may claim one uuid (a device and an impostor, or a device and its
own stale record), and the goodbye of one must not take the other off the list. Each is
marked as this runtime sees it: added here, paired with it, or another's."""

from __future__ import annotations

import logging
from collections.abc import Callable

from openpendant.runtime.device_manager.models import Elsewhere, Mark
from openpendant.runtime.kit.discovery import Detected

log = logging.getLogger(__name__)

# Announcements kept at most: a flood of made-up ones must not grow the list without end.
MAX_ANNOUNCEMENTS = 1024


def mark(
    device: Detected, added: bool, key: str | None, runtime: str | None
) -> tuple[Mark, Elsewhere | None]:
    """How this runtime sees an announcement. `added`: its uuid is one of this runtime's
    devices; `key`: the id of the pairing key this runtime holds for its uuid; `runtime`:
    this runtime's own tag. What a device announces proves nothing (the challenge does):
    the marks tell the user what to expect of an Add."""
    if key is not None and device.key != key:
        return "elsewhere", "other_key"
    if added:
        return "added", None
    if key is not None:
        return "paired", None
    if device.runtime and device.runtime != runtime:
        return "elsewhere", "other_runtime"
    return "new", None


class Announcements:
    def __init__(
        self,
        added_urls: Callable[[], dict[str, str]],
        key_of: Callable[[str], str | None] = lambda uuid: None,
    ) -> None:
        """`added_urls()`: per uuid, the address its added device is linked at. `key_of`:
        the id of the pairing key this runtime holds for a uuid, if it holds one."""
        self.added_urls = added_urls
        self.key_of = key_of
        self._by_name: dict[str, Detected] = {}

    def found(self, device: Detected) -> bool:
        """Whether it was taken (False: the list is full)."""
        if device.service_name not in self._by_name and len(self._by_name) >= MAX_ANNOUNCEMENTS:
            log.warning("%d devices announced: %s ignored", MAX_ANNOUNCEMENTS, device.uuid)
            return False
        self._by_name[device.service_name] = device
        return True

    def gone(self, service_name: str) -> bool:
        """Whether the list changed."""
        return self._by_name.pop(service_name, None) is not None

    @property
    def by_uuid(self) -> dict[str, Detected]:
        """Per uuid, the announcement that speaks for it: the one at the address the added
        device is linked at now, else one with the key this runtime holds for it, else the
        newest (of equals, the newest)."""
        added = self.added_urls()

        def rank(device: Detected) -> tuple[bool, bool]:
            return device.url == added.get(device.uuid), device.key == self.key_of(device.uuid)

        chosen: dict[str, Detected] = {}
        for device in sorted(self._by_name.values(), key=lambda d: d.last_seen):
            current = chosen.get(device.uuid)
            if current is None or rank(device) >= rank(current):
                chosen[device.uuid] = device
        return chosen

    def announces(self, uuid: str) -> bool:
        return any(device.uuid == uuid for device in self._by_name.values())

    def urls_by_uuid(self) -> dict[str, list[str]]:
        """Every address announcing each uuid (one pass: the list may hold a thousand)."""
        urls: dict[str, set[str]] = {}
        for device in self._by_name.values():
            urls.setdefault(device.uuid, set()).add(device.url)
        return {uuid: sorted(found) for uuid, found in urls.items()}
