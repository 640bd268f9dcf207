"""Control leases: one holder at a time, proven by a token, lapsing when not renewed."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from openpendant.runtime.device_manager.leases import LeaseBook, LeaseRefused
from openpendant.runtime.kit.errors import Conflict


def test_one_holder_at_a_time_until_release() -> None:
    book = LeaseBook(seconds=10)
    mine = book.acquire("robot", "tablet-1")
    with pytest.raises(LeaseRefused, match="tablet-1"):
        book.acquire("robot", "tablet-2")
    with pytest.raises(LeaseRefused) as err:
        book.check("robot", "forged-token")
    assert err.value.code == "lease_held"
    assert book.check("robot", mine.token).holder == "tablet-1"
    with pytest.raises(Conflict):
        book.release("robot", "forged-token")
    book.release("robot", mine.token)
    assert book.acquire("robot", "tablet-2").holder == "tablet-2"


def test_the_holder_renews_with_its_token() -> None:
    book = LeaseBook(seconds=10)
    first = book.acquire("robot", "tablet-1")
    again = book.acquire("robot", "tablet-1", first.token)
    assert again.token == first.token
    assert again.expires >= first.expires


def test_an_unrenewed_lease_lapses() -> None:
    book = LeaseBook(seconds=0.05)
    mine = book.acquire("robot", "tablet-1")
    time.sleep(0.1)
    assert book.sweep()
    assert book.info("robot").holder is None
    with pytest.raises(LeaseRefused) as err:
        book.check("robot", mine.token)
    assert err.value.code == "lease_required"
    assert book.acquire("robot", "tablet-2").holder == "tablet-2"


def test_leases_are_per_device() -> None:
    book = LeaseBook()
    book.acquire("robot", "tablet-1")
    assert book.acquire("robot2", "tablet-2").holder == "tablet-2"


def test_leases_come_back_after_a_restart_with_a_full_term(tmp_path: Path) -> None:
    """A restarted device manager hands no robot to someone else while its holder lives:
    the holder's token still works, others are refused, and the file is private."""
    path = tmp_path / "leases.json"
    book = LeaseBook(seconds=10, path=path)
    mine = book.acquire("robot", "tablet-1")
    panda = book.acquire("panda", "program x")
    book.release("panda", panda.token)
    assert path.stat().st_mode & 0o777 == 0o600
    restarted = LeaseBook(seconds=10, path=path)
    assert restarted.check("robot", mine.token).holder == "tablet-1"
    with pytest.raises(LeaseRefused):
        restarted.acquire("robot", "tablet-2")
    assert restarted.info("panda").holder is None  # released before the restart


def test_a_lease_that_lapsed_before_a_restart_stays_lapsed(tmp_path: Path) -> None:
    path = tmp_path / "leases.json"
    book = LeaseBook(seconds=0.05, path=path)
    book.acquire("robot", "tablet-1")
    time.sleep(0.1)
    assert book.sweep()
    assert LeaseBook(seconds=10, path=path).info("robot").holder is None


def test_an_unreadable_lease_file_starts_empty(tmp_path: Path) -> None:
    path = tmp_path / "leases.json"
    path.write_text("{not json")
    assert LeaseBook(seconds=10, path=path).info("robot").holder is None
