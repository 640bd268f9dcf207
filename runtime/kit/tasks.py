"""Stopping a task for sure. Python 3.11's asyncio.wait_for swallows a cancellation that
arrives in the loop round in which the awaited result also did (fixed in 3.12), and
libraries await through it (pymodbus on every request): one cancel may leave a loop
running for ever, and the process hanging on shutdown."""

from __future__ import annotations

import asyncio
from typing import Any

RETRY = 0.05  # s before a cancel is sent again


async def cancel_for_sure(task: asyncio.Task[Any]) -> None:
    """Cancel `task` until it has ended; its own outcome is not this caller's."""
    while not task.done():
        task.cancel()
        await asyncio.wait([task], timeout=RETRY)
    if not task.cancelled():
        task.exception()  # retrieved: an error at its end is not logged as never seen
