"""A process's event loop held up is counted, and said in its log (runtime/kit/loop_watch.py):
the first thing to know when a link went stale."""

from __future__ import annotations

import asyncio
import logging
import re
import time

import pytest
from prometheus_client import REGISTRY

from openpendant.runtime.kit.loop_watch import QUIET, LoopWatch


def count(at_most: str) -> float:
    value = REGISTRY.get_sample_value("openpendant_event_loop_lag_seconds_bucket", {"le": at_most})
    return value or 0.0


def total() -> float:
    return REGISTRY.get_sample_value("openpendant_event_loop_lag_seconds_count") or 0.0


def blocking_callback(watch: LoopWatch) -> None:
    # Held up well past `held_up`, and until the watching thread has seen it: at nice 19 beside
    # the real-time tests this whole process can wait for the CPU longer than the hold-up.
    start = time.monotonic()
    while time.monotonic() - start < 0.4 or (not watch._caught and time.monotonic() - start < 5):
        time.sleep(0.01)


def test_a_loop_held_up_is_counted_and_logged_once_in_a_while(
    caplog: pytest.LogCaptureFixture,
) -> None:
    watch = LoopWatch(period=0.01, held_up=0.1)

    async def scenario() -> None:
        task = asyncio.create_task(watch.run())
        await asyncio.sleep(0.05)  # on time: counted, not logged
        # A hold-up of the loaded machine's own may have been said already: ours is said next.
        watch.said_at, watch.worst = -QUIET, 0.0
        for _ in range(2):
            asyncio.get_running_loop().call_soon(blocking_callback, watch)
            await asyncio.sleep(0.45)
        task.cancel()

    before, quick_before = total(), count("0.1")
    with caplog.at_level(logging.WARNING, logger="openpendant.runtime.kit.loop_watch"):
        asyncio.run(scenario())
    assert total() - before >= 5
    held = (total() - before) - (count("0.1") - quick_before)
    assert held >= 2  # both hold-ups over 100 ms (a loaded machine may add its own)
    # Other loops of this process (an app a test still runs) may log theirs: this one's is
    # the line that names the callback.
    lines = [r.getMessage() for r in caplog.records if "blocking_callback" in r.getMessage()]
    # The first said at once, with what the loop was doing; the second within the quiet
    # time, kept for the next line.
    assert len(lines) == 1 and re.search(r"held up for \d+ ms", lines[0]), lines
    assert "meanwhile: blocking_callback (test_loop_watch.py:" in lines[0], lines
    assert watch.unsaid >= 1
