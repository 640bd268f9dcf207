"""Advertisements as seen by the browser: hostile or malformed TXT records; instance names
stable across restarts and in UTF-8 (issue 32); which names are asked to confirm themselves,
and when one is gone (issue 31)."""

from __future__ import annotations

import itertools
import socket
from collections.abc import Callable

import pytest
from zeroconf import current_time_millis
from zeroconf._cache import DNSCache
from zeroconf._dns import DNSPointer, DNSService
from zeroconf._protocol.incoming import DNSIncoming
from zeroconf._protocol.outgoing import DNSOutgoing
from zeroconf.asyncio import AsyncServiceInfo

from openpendant.runtime.kit import confirmations
from openpendant.runtime.kit.confirmations import Confirmations, NewestRecord, Step
from openpendant.runtime.kit.device_auth import key_id
from openpendant.runtime.kit.discovery import (
    DNS_IN,
    DNS_SRV,
    SERVICE_TYPE,
    Advertisement,
    checked_uuid,
    clean_text,
    newest_record,
    parse_info,
)

KEY = key_id("the device's pairing secret")


def info(properties: dict[bytes, bytes], port: int = 8000) -> AsyncServiceInfo:
    return AsyncServiceInfo(
        SERVICE_TYPE,
        f"x.{SERVICE_TYPE}",
        port=port,
        addresses=[socket.inet_aton("127.0.0.1")],
        properties=properties,
    )


def test_advertisement_round_trip() -> None:
    ad = Advertisement(
        uuid="1234-abcd",
        kind="robot",
        model="ur5",
        name="cell ur5",
        host="127.0.0.1",
        port=4321,
        key=KEY,
        runtime="0123456789abcdef",
    )
    found = parse_info(ad.service_info())
    assert found is not None
    assert (found.uuid, found.kind, found.model, found.name, found.url) == (
        "1234-abcd",
        "robot",
        "ur5",
        "cell ur5",
        "http://127.0.0.1:4321",
    )
    assert (found.key, found.runtime) == (KEY, "0123456789abcdef")
    assert "secret" not in str(ad.service_info().properties)  # its key's id, never the key


def test_a_malformed_key_id_or_runtime_tag_is_read_as_none() -> None:
    for bad in (KEY + "0", KEY[:-1], KEY.upper(), "g" * 16, "\u202e" + KEY[1:]):
        found = parse_info(
            info({b"uuid": b"u", b"kind": b"robot", b"key": bad.encode(), b"runtime": bad.encode()})
        )
        assert found is not None and (found.key, found.runtime) == ("", ""), bad


def test_malformed_kind_missing_uuid_or_port_is_ignored() -> None:
    # Any well-formed kind is read (a plugin may declare it; the device manager lists only
    # kinds an installed plugin knows); a malformed one is not.
    found = parse_info(info({b"uuid": b"u", b"kind": b"conveyor_2"}))
    assert found is not None and found.kind == "conveyor_2"
    for kind in (b"Toaster", b"", b"a" * 17, b"ro bot", b"9robot"):
        assert parse_info(info({b"uuid": b"u", b"kind": kind})) is None, kind
    assert parse_info(info({b"kind": b"robot"})) is None
    assert parse_info(info({b"uuid": b"u", b"kind": b"robot"}, port=0)) is None


def test_untrusted_text_is_cleaned_not_interpreted() -> None:
    found = parse_info(
        info(
            {
                b"uuid": b"u-1",
                b"kind": b"robot",
                b"name": b"<script>alert(1)</script>\n\xe2\x80\xae" + b"\xff" * 150,
            }
        )
    )
    assert found is not None
    assert found.uuid == "u-1"
    assert found.name.startswith("<script>alert(1)</script>")  # kept as text; the UI escapes
    assert len(found.name) <= 64 and "\n" not in found.name
    assert "\u202e" not in found.name  # a right-to-left override would reorder what is shown
    assert clean_text(None) == ""
    assert clean_text("a\u200bb\u2066c\x7f") == "abc"


def test_uuids_are_refused_not_cut() -> None:
    """Two long ids sharing a prefix must stay two devices; control characters, an empty id
    or more than 64 characters are not an id."""
    for bad in (b"u\x00\x1b[31m", b"", b"x" * 65, b"a b", "\u202eabc".encode()):
        assert parse_info(info({b"uuid": bad, b"kind": b"robot"})) is None
    assert checked_uuid("x" * 64) == "x" * 64
    with pytest.raises(ValueError, match="1-64"):
        checked_uuid("x" * 5_000_000)


def advertised(name: str, uuid: str = "aaaaaaaa-1", key: str = KEY, port: int = 1) -> Advertisement:
    return Advertisement(
        uuid=uuid, kind="robot", model="m", name=name, host="127.0.0.1", port=port, key=key
    )


def label(ad: Advertisement) -> str:
    name = ad.instance_name()
    assert name.endswith("." + SERVICE_TYPE)
    return name[: -len(SERVICE_TYPE) - 1]


def test_instance_names_are_safe_and_unique_per_device() -> None:
    a = advertised("bad\x00 name\u202e\n!")
    b = advertised("bad\x00 name\u202e\n!", uuid="bbbbbbbb-1")
    assert a.instance_name() != b.instance_name()
    assert label(a).startswith("bad name! [aaaaaaaa ")  # no control or format characters
    # Another announcement of the same uuid with another key (a cloned board, an impostor)
    # has names of its own: its goodbye ends only its own records.
    clone = advertised("bad\x00 name\u202e\n!", key=key_id("another secret"))
    assert clone.instance_name() != a.instance_name()
    assert clone.service_info().server != a.service_info().server  # its addresses its own


def test_the_same_device_restarted_has_the_same_names() -> None:
    """Issue 32: a random tag changed them at every start; browsers listed the device's
    new name beside its old records until they lapsed."""
    before, after = advertised("cell ur5", port=40001), advertised("cell ur5", port=40777)
    assert before.instance_name() == after.instance_name()
    assert before.service_info().server == after.service_info().server


def test_a_utf8_name_with_spaces_and_dots_survives_in_one_label() -> None:
    """RFC 6763 §4.1.1: any UTF-8 text. The old names dropped all but ASCII letters and
    digits ("Zelle Sd 21"); zeroconf writes a dot as a label boundary, so it is sent as the
    one dot leader that looks the same."""
    ad = advertised("Zelle Süd 2.1")
    assert label(ad).startswith("Zelle Süd 2\u20241 [aaaaaaaa ")
    out = DNSOutgoing(0x8400)
    out.add_answer_at_time(DNSPointer(SERVICE_TYPE, DNS_PTR, DNS_IN, 120, ad.instance_name()), 0)
    wire = out.packets()[0]
    raw = label(ad).encode()
    assert bytes([len(raw)]) + raw in wire  # one label, its length first
    (answer,) = DNSIncoming(wire).answers()
    assert isinstance(answer, DNSPointer) and answer.alias == ad.instance_name()
    found = parse_info(ad.service_info())
    assert found is not None and found.name == "Zelle Süd 2.1"  # the name itself, as given


def test_a_long_utf8_name_is_cut_where_a_character_ends() -> None:
    for extra in range(12):  # the cut falls inside a 2-, 3- and 4-byte character in turn
        name = "x" * extra + "Schweißzelle Süd № 7 — Förderband € 😀 Ende der Linie"
        text = label(advertised(name))
        raw = text.encode()
        assert 63 - 5 < len(raw) <= 63, (extra, len(raw))  # cut no more than needed
        raw.decode("utf-8")  # strictly: no character cut in two
        head, _, tail = text.rpartition(" [")
        assert name.startswith(head) and tail.startswith("aaaaaaaa "), text


NAME = "cell ur5 [3f2b8c1e 0a1b]._openpendant._tcp.local."
TTL = 3000.0  # ms
TICK = 250.0  # ms, as the browser steps
DNS_PTR = 12


class Cache:
    """When each name's service record was last received, as zeroconf's cache keeps it."""

    def __init__(self) -> None:
        self.made: dict[str, float] = {}

    def newest(self, now: float) -> NewestRecord:
        def live(name: str) -> tuple[float, float] | None:
            made = self.made.get(name)
            return (made, TTL) if made is not None and now < made + TTL else None

        return live


def steps(
    book: Confirmations,
    cache: Cache,
    start: float,
    end: float,
    vouched: Callable[[str], bool] = lambda name: False,
) -> list[tuple[float, Step]]:
    """The browser's steps from `start` until `end`, nothing answering."""
    done = []
    now = start
    while now < end:
        done.append((now, book.step(now, cache.newest(now), vouched)))
        now += TICK
    return done


def times(done: list[tuple[float, Step]], what: str) -> list[float]:
    return [now for now, step in done if NAME in getattr(step, what)]


def test_a_lapsed_name_is_gone_once_then_asked_for_again_less_and_less_often() -> None:
    """Its confirmations lost in an outage, the name was forgotten: zeroconf, which keeps
    the pointer for 19 minutes, never reported it again though the device was back."""
    book, cache = Confirmations(), Cache()
    cache.made[NAME] = 0.0
    book.confirmed(NAME, 0.0)
    done = steps(book, cache, 0.0, 10 * 60_000.0)
    asked = times(done, "ask")
    assert times(done, "gone") == [3000.0]  # when its record lapsed, and once
    assert asked[:3] == [1500.0, 2000.0, 2500.0]  # past half its TTL, every tenth of it
    lost = [t for t in asked if t >= 3000.0]
    assert lost[:3] == [3000.0, 3500.0, 4000.0]
    gaps = [b - a for a, b in itertools.pairwise(lost)]
    for at, gap in zip(lost, gaps, strict=False):
        wanted = min(confirmations.LOST_LONGEST, max(500.0, 0.1 * (at - 3000.0)))
        assert wanted <= gap < wanted + TICK, (at, gap)
    assert gaps == sorted(gaps) and max(gaps) < confirmations.LOST_LONGEST + TICK
    assert len(lost) < 80 and lost[-1] > 9 * 60_000.0  # seldom, but still asked
    assert book.follows(NAME) and book.is_lost(NAME)

    # It answers: handed over to be resolved once per answer, then confirmed as before.
    back = done[-1][0] + TICK
    cache.made[NAME] = back
    done = steps(book, cache, back, back + 1000.0)
    assert times(done, "recheck") == [back] and times(done, "ask") == []
    book.confirmed(NAME, back + 1000.0)
    done = steps(book, cache, back + 1000.0, back + 2000.0)
    assert times(done, "ask") == [back + 1500.0]
    assert not book.is_lost(NAME) and times(done, "gone") == []


def test_a_name_whose_device_has_a_live_link_is_never_gone_and_is_asked_when_it_returns() -> None:
    book, cache = Confirmations(), Cache()
    other = "conveyor [9c0d 77aa]._openpendant._tcp.local."  # no link: nobody added it
    for name in (NAME, other):
        cache.made[name] = 0.0
        book.confirmed(name, 0.0)
    link = {"live": True}

    def vouched(name: str) -> bool:
        return name == NAME and link["live"]

    done = steps(book, cache, 0.0, 8000.0, vouched)  # lapsed at 3 s while the link lives
    assert times(done, "gone") == [] and 3000.0 in times(done, "ask")
    assert [now for now, step in done if other in step.gone] == [3000.0]
    link["live"] = False
    done = steps(book, cache, 8000.0, 60_000.0, vouched)
    assert times(done, "gone") == [8000.0]  # the link is down too: gone
    assert 59_750.0 not in times(done, "ask")  # asked every ~5 s by now
    link["live"] = True  # the link is back, so is the network: all asked at once
    done = steps(book, cache, 60_000.0, 61_000.0, vouched)
    assert times(done, "ask")[0] == 60_000.0 and times(done, "gone") == []
    assert other in done[0][1].ask


def test_goodbyes_unresolved_names_and_how_long_a_lapsed_name_is_asked_for() -> None:
    book, cache = Confirmations(), Cache()
    cache.made[NAME] = 0.0
    book.confirmed(NAME, 0.0)
    assert book.ended(NAME) and not book.follows(NAME)  # a goodbye: gone now, not asked
    del cache.made[NAME]  # goodbyes take the records out of the cache

    book.unresolved(NAME, 0.0)  # announced, never resolved: asked later, nothing to report
    done = steps(book, cache, 0.0, 2000.0)
    assert times(done, "ask")[0] == 500.0 and times(done, "gone") == []
    assert not book.ended(NAME) and book.follows(NAME)  # its pointer's end: still asked
    done = steps(book, cache, 2000.0, confirmations.LOST_KEEP + 1000.0)
    assert not book.follows(NAME) and times(done, "gone") == []

    # A lapsed name whose device's link stays live is kept past that.
    cache.made[NAME] = 0.0
    book.confirmed(NAME, 0.0)
    steps(book, cache, 0.0, confirmations.LOST_KEEP + 10_000.0, lambda name: True)
    assert book.is_lost(NAME)


def test_a_record_answering_again_is_seen_though_zeroconf_kept_its_pointer() -> None:
    """zeroconf's own cache, as the browser reads it: the pointer it keeps for 19 minutes
    would report nothing new when the device answers again; the service record does."""
    cache, now = DNSCache(), current_time_millis()
    ago = now - 10_000

    def service(created: float) -> DNSService:
        unique = DNS_IN | 0x8000  # the cache-flush bit, as devices send it
        return DNSService(NAME, DNS_SRV, unique, 3, 0, 0, 8000, "b.local.", created=created)

    pointer = DNSPointer(SERVICE_TYPE, DNS_PTR, DNS_IN, 1125, NAME, created=ago)
    cache.async_add_records([pointer, service(ago)])
    assert newest_record(cache, now, NAME) is None  # lapsed, though its pointer is kept
    cache.async_add_records([service(now)])  # the same record, brought back by an answer
    assert newest_record(cache, now, NAME) == (now, 3000.0)
