"""Each process's event loop watched for hold-ups. A link is stale after 200 ms without a
state, and a loop held up for that long (a callback computing, a blocking call, the machine
overloaded) makes it so: when a link goes stale, this says whether the process on either
end was the one that stopped, and where. Every hold-up is counted in the process's metrics;
the long ones are logged with what the loop's thread was doing meanwhile (seen by a thread
of its own), at most one line every few seconds."""

from __future__ import annotations

import asyncio
import logging
import os
import sys
import threading
import time
import traceback

from prometheus_client import Histogram

log = logging.getLogger(__name__)

PERIOD = 0.05  # s between the watch's wake-ups (20 a second: a few µs of CPU each)
HELD_UP = 0.1  # s late that is logged: half of a link's staleness
QUIET = 5.0  # s between two such lines at the most; the others are counted in the next
FRAMES = 6  # of the loop thread's stack, innermost first

LOOP_LAG = Histogram(
    "openpendant_event_loop_lag_seconds",
    "How late the event loop woke a timer: time it spent elsewhere, or waiting for the CPU",
    buckets=(0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.2, 0.5, 1.0),
)


class LoopWatch:
    """Wakes every `period` and measures how late it woke; a thread looks at the loop's
    stack once it is `held_up` late."""

    def __init__(self, period: float = PERIOD, held_up: float = HELD_UP) -> None:
        self.period = period
        self.held_up = held_up
        self.worst = 0.0  # the longest hold-up not yet logged
        self.unsaid = 0  # hold-ups over `held_up` not yet logged
        self.said_at = -QUIET
        self.beat = time.monotonic()  # the loop's last wake-up
        self.seen = ""  # the loop thread's stack during the worst hold-up not yet logged
        self._caught = ""  # ... during the current one
        self._ident = 0  # the loop's thread, once it runs

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        self._ident = threading.get_ident()
        self.beat = time.monotonic()
        stop = threading.Event()
        threading.Thread(target=self._look, args=(stop,), name="loop watch", daemon=True).start()
        try:
            while True:
                before = loop.time()
                await asyncio.sleep(self.period)
                self.observe(loop.time() - before - self.period)
                self.beat = time.monotonic()
        finally:
            stop.set()

    def _look(self, stop: threading.Event) -> None:
        while not stop.wait(self.period):
            beat = self.beat
            if time.monotonic() - beat > self.held_up and not self._caught:
                frame = sys._current_frames().get(self._ident)
                if frame is not None and self.beat == beat:  # still held up
                    stack = traceback.extract_stack(frame)[-FRAMES:]
                    self._caught = " < ".join(
                        f"{f.name} ({os.path.basename(f.filename)}:{f.lineno})"
                        for f in reversed(stack)
                    )

    def observe(self, late: float) -> None:
        late = max(0.0, late)
        LOOP_LAG.observe(late)
        caught, self._caught = self._caught, ""
        if late < self.held_up:
            return
        self.unsaid += 1
        if late > self.worst:
            self.worst, self.seen = late, caught
        now = time.monotonic()
        if now - self.said_at < QUIET:
            return
        more = f" ({self.unsaid} such since the last report)" if self.unsaid > 1 else ""
        where = f"; meanwhile: {self.seen}" if self.seen else ""
        log.warning("the event loop was held up for %.0f ms%s%s", self.worst * 1000, more, where)
        self.said_at, self.unsaid, self.worst, self.seen = now, 0, 0.0, ""
