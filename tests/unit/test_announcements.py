"""Announcements kept per instance name: an impostor's goodbye leaves the genuine device
listed, the address a device is linked at speaks for its uuid, the list is bounded."""

from __future__ import annotations

import pytest

from runtime.device_manager import announcements
from runtime.device_manager.announcements import Announcements
from runtime.kit.discovery import Detected

pytestmark = pytest.mark.concurrent

UUID = "3f2b8c1e-0000-4000-8000-000000000001"


def announced(name: str, port: int, seen: float, uuid: str = UUID) -> Detected:
    return Detected(uuid, "robot", "ur5", "ur5", "1", "127.0.0.1", port, name, last_seen=seen)


def test_a_goodbye_ends_only_its_own_announcement() -> None:
    book = Announcements(dict)
    book.found(announced("genuine._openpendant._tcp.local.", 8001, seen=1.0))
    book.found(announced("impostor._openpendant._tcp.local.", 9001, seen=2.0))
    assert book.by_uuid[UUID].port == 9001  # nobody added it: the newest speaks
    assert book.urls_by_uuid() == {UUID: ["http://127.0.0.1:8001", "http://127.0.0.1:9001"]}
    assert book.gone("impostor._openpendant._tcp.local.")
    assert book.by_uuid[UUID].port == 8001
    assert not book.gone("impostor._openpendant._tcp.local.")  # said twice: no change
    assert book.gone("genuine._openpendant._tcp.local.")
    assert book.by_uuid == {}


def test_the_address_a_device_is_linked_at_speaks_for_it() -> None:
    book = Announcements(lambda: {UUID: "http://127.0.0.1:8001"})
    book.found(announced("genuine._openpendant._tcp.local.", 8001, seen=1.0))
    book.found(announced("impostor._openpendant._tcp.local.", 9001, seen=2.0))
    assert book.by_uuid[UUID].port == 8001


def test_the_list_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(announcements, "MAX_ANNOUNCEMENTS", 3)
    book = Announcements(dict)
    uuids = [f"3f2b8c1e-0000-4000-8000-00000000000{i}" for i in range(4)]
    taken = [book.found(announced(f"d{i}.local.", 8000 + i, 1.0, u)) for i, u in enumerate(uuids)]
    assert taken == [True, True, True, False]
    assert book.found(announced("d0.local.", 8100, 2.0, uuids[0]))  # a known one still changes
    assert sorted(book.by_uuid) == sorted(uuids[:3]) and book.by_uuid[uuids[0]].port == 8100
