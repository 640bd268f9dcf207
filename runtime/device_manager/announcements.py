"""The devices announced on the network, kept per announcement (its instance name), not per
uuid: two announcements may claim one uuid (a device and an impostor, or a device and its
own stale record), and the goodbye of one must not take the other off the list."""

from __future__ import annotations

import logging
from collections.abc import Callable

from runtime.kit.discovery import Detected

log = logging.getLogger(__name__)

# Announcements kept at most: a flood of made-up ones must not grow the list without end.
MAX_ANNOUNCEMENTS = 1024


class Announcements:
    def __init__(self, added_urls: Callable[[], dict[str, str]]) -> None:
        """`added_urls()`: per uuid, the address its added device is linked at."""
        self.added_urls = added_urls
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
        device is linked at now, else the newest."""
        added = self.added_urls()
        chosen: dict[str, Detected] = {}
        for device in sorted(self._by_name.values(), key=lambda d: d.last_seen):
            current = chosen.get(device.uuid)
            if current is None or current.url != added.get(device.uuid):
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
