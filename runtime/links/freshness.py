"""How old a stream's newest state is, from the sender's own timestamps.

The sender's clock may be offset from ours (a driver on another board). The smallest
`arrival - ts` seen recently is taken as that offset plus the fastest delivery; a state
that arrives later than that, or no new state at all, ages. A window of minima lets the
estimate follow a slowly drifting clock.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections import deque
from dataclasses import dataclass

WINDOW = 1.0  # s per block of the minimum filter
BLOCKS = 10
STAMP = re.compile(r'^\{"seqno":(\d{1,18}),"ts":(-?[0-9.]+(?:[eE][-+]?\d+)?)[,}]')


@dataclass
class Stamp:
    seqno: int
    ts: float


def state_stamp(text: str) -> Stamp:
    """The sequence number and timestamp a state starts with (the interfaces' models put them
    first); any other order is parsed in full."""
    match = STAMP.match(text)
    if match is not None:
        return Stamp(int(match.group(1)), float(match.group(2)))
    body = json.loads(text)
    if not isinstance(body, dict):
        raise ValueError("a state is a JSON object")
    seqno, ts = body.get("seqno"), body.get("ts")
    if not isinstance(seqno, int) or not isinstance(ts, int | float):
        raise ValueError("a state needs an integer seqno and a numeric ts")
    return Stamp(seqno, float(ts))


class Freshness:
    def __init__(self) -> None:
        self._blocks: deque[tuple[float, float]] = deque(maxlen=BLOCKS)  # (block start, min)
        self.seqno: int | None = None
        self.arrival = 0.0  # local monotonic time the newest state came
        self.heard = 0.0  # ... and the latest message, repeated or not
        self._delay = 0.0  # its wall-clock arrival minus its timestamp

    def reset(self) -> None:
        self._blocks.clear()
        self.seqno = None

    def observe(self, seqno: int, ts: float) -> float:
        """Records a state; returns its age on arrival (s). A repeated seqno is no news."""
        arrival = self.heard = time.monotonic()
        if self.seqno is not None and seqno == self.seqno:
            return self.age(arrival)
        delay = time.time() - ts
        self.seqno, self.arrival, self._delay = seqno, arrival, delay
        if not self._blocks or arrival - self._blocks[-1][0] >= WINDOW:
            self._blocks.append((arrival, delay))
        elif delay < self._blocks[-1][1]:
            self._blocks[-1] = (self._blocks[-1][0], delay)
        return self.age(arrival)

    def silence(self, now: float | None = None) -> float:
        """Seconds since the stream last said anything (for devices whose state rests)."""
        if self.seqno is None:
            return math.inf
        return (time.monotonic() if now is None else now) - self.heard

    def age(self, now: float | None = None) -> float:
        """Seconds since the newest state was sent, as far as the stream shows."""
        if self.seqno is None or not self._blocks:
            return math.inf
        if now is None:
            now = time.monotonic()
        offset = min(m for _, m in self._blocks)
        return (self._delay - offset) + max(now - self.arrival, 0.0)
