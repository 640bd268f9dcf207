"""What a driver accepted and when: the last commands, with their wall-clock receive time and
the tag a client gave them. Diagnostics for operators, and how benchmarks time the path
from a client to the driver."""

from __future__ import annotations

import itertools
import time
from collections import deque

from pydantic import BaseModel


class LoggedCommand(BaseModel):
    seq: int
    t: float
    type: str
    tag: str | None = None


class CommandLog:
    def __init__(self, size: int = 2000) -> None:
        # Plain tuples: recording runs for every command, reading only on request.
        self._entries: deque[tuple[int, float, str, str | None]] = deque(maxlen=size)
        self._seq = itertools.count(1)

    def record(self, kind: str, tag: str | None = None) -> None:
        self._entries.append((next(self._seq), time.time(), kind, tag))

    def since(self, after: int = 0) -> list[LoggedCommand]:
        return [
            LoggedCommand(seq=s, t=t, type=k, tag=g) for s, t, k, g in self._entries if s > after
        ]
