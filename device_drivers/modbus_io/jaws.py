"""Simulated gripper fingers: they travel toward a target opening at a set speed and stop on
an object held between them. Computed from the time the move began (no ticking task), so a
poll at any moment reads where the fingers are."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class JawsAt:
    width: float  # m of opening now
    moving: bool
    blocked: bool  # stopped by an object before its target


class Jaws:
    def __init__(
        self, stroke: float, speed: float, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.stroke = stroke
        self.clock = clock
        self._from, self._target, self._speed = stroke, stroke, speed
        self._since = clock()
        # The width of what lies between the fingers (a part), or None: nothing there. Set
        # by a test or by the simulated cell when the fingers close around a part.
        self.object_width: float | None = None

    def go(self, target: float, speed: float) -> None:
        """Start toward `target` (m) from wherever the fingers are now."""
        self._from = self.at().width
        self._target = min(max(target, 0.0), self.stroke)
        self._speed = max(speed, 1e-6)
        self._since = self.clock()

    def halt(self) -> None:
        self._from = self._target = self.at().width
        self._since = self.clock()

    def place(self, width: float | None) -> None:
        """An object of this width now lies between the fingers (None: taken away). Fingers
        already closed tighter than it are not pushed open: it is only felt while closing."""
        self._from, self._since = self.at().width, self.clock()  # carry on from here
        self.object_width = width

    def at(self) -> JawsAt:
        travelled = (self.clock() - self._since) * self._speed
        closing = self._target < self._from
        stop = self._target
        held = self.object_width
        if closing and held is not None and self._target < held <= self._from:
            stop = held  # the object is in the way
        width = max(self._from - travelled, stop) if closing else min(self._from + travelled, stop)
        arrived = abs(width - stop) < 1e-9
        return JawsAt(width=width, moving=not arrived, blocked=arrived and stop != self._target)
