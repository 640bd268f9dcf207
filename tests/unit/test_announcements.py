"""Announcements kept per instance name: an impostor's goodbye leaves the genuine device
listed, the address a device is linked at (else the key this runtime holds) speaks for its
uuid, the list is bounded; each marked added here, paired, another's or new (issue 32)."""

from __future__ import annotations

import pytest

from openpendant.runtime.device_manager import announcements
from openpendant.runtime.device_manager.announcements import Announcements, mark
from openpendant.runtime.kit.device_auth import key_id
from openpendant.runtime.kit.discovery import Detected

pytestmark = pytest.mark.concurrent

UUID = "3f2b8c1e-0000-4000-8000-000000000001"


OURS, THEIRS = key_id("the key this runtime holds"), key_id("another key")
HERE, THERE = "0123456789abcdef", "fedcba9876543210"  # runtime tags


def announced(
    name: str, port: int, seen: float, uuid: str = UUID, key: str = "", runtime: str = ""
) -> Detected:
    return Detected(
        uuid, "robot", "ur5", "ur5", "1", "127.0.0.1", port, name, seen, key=key, runtime=runtime
    )


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


def test_the_key_this_runtime_holds_speaks_for_a_uuid_not_added() -> None:
    """The newest used to: a clone announcing the uuid after the device took its place."""
    book = Announcements(dict, {UUID: OURS}.get)
    book.found(announced("genuine._openpendant._tcp.local.", 8001, seen=1.0, key=OURS))
    book.found(announced("clone._openpendant._tcp.local.", 9001, seen=2.0, key=THEIRS))
    assert book.by_uuid[UUID].port == 8001


def test_each_announcement_is_marked_as_this_runtime_sees_it() -> None:
    def seen(key: str, runtime: str, added: bool, held: str | None) -> tuple[str, str | None]:
        return mark(announced("d.local.", 1, 1.0, key=key, runtime=runtime), added, held, HERE)

    assert seen(OURS, HERE, added=True, held=OURS) == ("added", None)
    assert seen(OURS, "", added=True, held=None) == ("added", None)  # added without a key
    assert seen(OURS, HERE, added=False, held=OURS) == ("paired", None)
    assert seen(OURS, THERE, added=False, held=OURS) == ("paired", None)  # shared: ours too
    assert seen(THEIRS, THERE, added=False, held=None) == ("elsewhere", "other_runtime")
    # A uuid this runtime holds a key for, announced without it: another device.
    assert seen(THEIRS, HERE, added=True, held=OURS) == ("elsewhere", "other_key")
    assert seen("", "", added=False, held=OURS) == ("elsewhere", "other_key")
    assert seen(THEIRS, "", added=False, held=None) == ("new", None)  # started by hand
    assert seen(THEIRS, HERE, added=False, held=None) == ("new", None)  # claims us: no key
