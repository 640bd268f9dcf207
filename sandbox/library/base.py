"""What every sandbox function uses: the host it asks (the worker's pipe to the runtime) and
input checks that give a clear error before anything is sent."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.values import check_number

F = TypeVar("F", bound=Callable[..., Any])

MAX_NAME = 128
MAX_WAIT = 24 * 3600.0
POLL = 0.02


class ProgramError(Exception):
    """The runtime refused or failed what the program asked for; `words` as the runtime sent
    them (a code and params a UI says in its language), passed back with the error."""

    def __init__(self, message: str, code: str = "error", words: Any = None) -> None:
        super().__init__(message)
        self.code = code
        self.words = words


class Host(Protocol):
    def call(self, fn: str, args: dict[str, Any]) -> Any: ...

    def output(self, text: str, stream: str) -> None: ...

    def sleep(self, seconds: float) -> None:
        """Sleep that a pause holds: paused time does not count."""

    def confirm(self, message: str) -> None:
        """Pause until the operator resumes."""

    def at_block(self, block_id: str) -> None: ...

    def elapsed(self) -> float:
        """Seconds since the program started (not since its worker did: a spare worker
        waits for its program)."""

    def finish(self) -> None:
        """End the run now, as finished."""


_host: Host | None = None
REGISTRY: dict[str, Callable[..., Any]] = {}


def bind(host: Host) -> None:
    global _host
    _host = host


def host() -> Host:
    if _host is None:
        raise SandboxError("not running in a program worker")
    return _host


def sandbox_function(fn: F) -> F:
    """Make this function one of the names programs can call."""
    if fn.__name__ in REGISTRY:
        raise ValueError(f"two sandbox functions named {fn.__name__}")
    REGISTRY[fn.__name__] = fn
    return fn


def text_arg(value: Any, what: str, *, max_length: int = MAX_NAME) -> str:
    if not isinstance(value, str) or not value:
        raise SandboxError(f"{what} must be non-empty text")
    if len(value) > max_length:
        raise SandboxError(f"{what} is longer than {max_length} characters")
    return value


def number_arg(value: Any, what: str, *, low: float = -math.inf, high: float = math.inf) -> float:
    number = check_number(value, what)
    if not low <= number <= high:
        raise SandboxError(f"{what} must be between {low:g} and {high:g}, not {number:g}")
    return number


def bool_arg(value: Any, what: str) -> bool:
    if not isinstance(value, bool):
        raise SandboxError(f"{what} must be true or false, not {type(value).__name__}")
    return value


def poll_until(condition: Callable[[], Any], timeout: Any, failure: str) -> None:
    """Check every POLL s (pausable) until `condition()` is true; fail after `timeout` s."""
    limit = number_arg(timeout, "timeout", low=0, high=MAX_WAIT)
    waited = 0.0
    while not condition():
        if waited >= limit:
            raise ProgramError(f"{failure} within {limit:g} s", "timeout")
        host().sleep(POLL)
        waited += POLL
