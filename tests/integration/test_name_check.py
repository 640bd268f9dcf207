"""A second copy of a device (its uuid and key on another process) takes a name of its own
(RFC 6762 §9) even when it starts within a second of the first's announcement and of the
first's own name check: a plain question would be answered only after that second (§14),
and a packet repeating one the holder heard within it is dropped (zeroconf)."""

from __future__ import annotations

import asyncio
import secrets

from openpendant.runtime.kit.discovery import SERVICE_TYPE, Advertisement, Advertiser


async def copies(delays: list[float]) -> list[str | None]:
    """A device started once, then once more after each delay (s)."""
    uuid = f"namecheck-{secrets.token_hex(4)}"  # others' tests on this loopback
    started: list[Advertiser] = []
    try:
        for n, delay in enumerate([0.0, *delays]):
            await asyncio.sleep(delay)
            advertiser = Advertiser(["127.0.0.1"])
            ad = Advertisement(uuid, "robot", "ur5", "copied", "127.0.0.1", 40000 + n, "k" * 16)
            await advertiser.start(ad)
            started.append(advertiser)
        return [a.announced for a in started]
    finally:
        for advertiser in started:
            await advertiser.stop()


def test_copies_started_within_a_second_of_each_other_take_names_of_their_own() -> None:
    # 0.5 s: after the first's announcements (start returns after the first) went out.
    names = asyncio.run(copies([0.5, 0.0]))
    assert len(set(names)) == 3, names
    first, second, third = (str(n).removesuffix(f".{SERVICE_TYPE}") for n in names)
    assert second == first.removesuffix("]") + "-2]", names
    assert third == first.removesuffix("]") + "-3]", names
