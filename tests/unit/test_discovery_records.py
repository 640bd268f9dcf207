"""Advertisements as seen by the browser: hostile or malformed TXT records."""

from __future__ import annotations

import socket

import pytest
from zeroconf.asyncio import AsyncServiceInfo

from runtime.kit.discovery import (
    SERVICE_TYPE,
    Advertisement,
    checked_uuid,
    clean_text,
    parse_info,
)


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
        uuid="1234-abcd", kind="robot", model="ur5", name="cell ur5", host="127.0.0.1", port=4321
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


def test_instance_names_are_safe_and_unique_per_device() -> None:
    a = Advertisement(
        uuid="aaaaaaaa-1", kind="robot", model="m", name="<bad> name!", host="127.0.0.1", port=1
    )
    b = Advertisement(
        uuid="bbbbbbbb-1", kind="robot", model="m", name="<bad> name!", host="127.0.0.1", port=1
    )
    assert a.instance_name() != b.instance_name()
    assert "<" not in a.instance_name()
    # Another announcement with the same identity (a cloned board, an impostor) has a name of
    # its own: its goodbye ends only its own records.
    clone = Advertisement(
        uuid="aaaaaaaa-1", kind="robot", model="m", name="<bad> name!", host="127.0.0.1", port=1
    )
    assert clone.instance_name() != a.instance_name()
    assert clone.service_info().server != a.service_info().server  # its addresses its own
    assert a.instance_name() == a.instance_name()
