"""Control leases: one holder at a time, proven by a token, lapsing when not renewed."""

from __future__ import annotations

import time

import pytest

from runtime.device_manager.leases import LeaseBook, LeaseRefused
from runtime.kit.errors import Conflict


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
