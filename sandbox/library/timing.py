"""Time: waits the pause button holds, and waiting for a condition with a timeout."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.base import ProgramError, host, number_arg, sandbox_function

MAX_WAIT = 24 * 3600.0
POLL = 0.02


@sandbox_function
def wait(seconds: Any) -> None:
    """Wait this many seconds (pausing the program pauses the wait)."""
    host().sleep(number_arg(seconds, "seconds", low=0, high=MAX_WAIT))


@sandbox_function
def wait_until(condition: Callable[[], Any], timeout: Any) -> None:
    """Wait until `condition()` is true; fail after `timeout` seconds."""
    if not callable(condition):
        raise SandboxError("wait until needs a condition")
    poll_until(condition, timeout, "the condition was not met")


def poll_until(condition: Callable[[], Any], timeout: Any, failure: str) -> None:
    """Check every POLL s (pausable) until `condition()` is true; fail after `timeout` s."""
    limit = number_arg(timeout, "timeout", low=0, high=MAX_WAIT)
    waited = 0.0
    while not condition():
        if waited >= limit:
            raise ProgramError(f"{failure} within {limit:g} s", "timeout")
        host().sleep(POLL)
        waited += POLL


@sandbox_function
def seconds_since_start() -> float:
    """Seconds since the program started."""
    return time.monotonic() - STARTED


STARTED = time.monotonic()
