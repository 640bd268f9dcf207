"""Time: waits the pause button holds, and waiting for a condition with a timeout."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.base import (
    MAX_WAIT,
    host,
    number_arg,
    poll_until,
    sandbox_function,
)


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


@sandbox_function
def seconds_since_start() -> float:
    """Seconds since the program started, pauses included."""
    return host().elapsed()
