"""Program control: log lines, pause for the operator, end the run."""

from __future__ import annotations

from typing import Any

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.base import host, sandbox_function

LEVELS = ("info", "warning", "error")


@sandbox_function
def log(text: Any, level: str = "info") -> None:
    """A line in the program's output, marked info, warning or error."""
    if level not in LEVELS:
        raise SandboxError(f"a log level is one of {', '.join(LEVELS)}")
    host().output(str(text), level)


@sandbox_function
def confirm(message: Any = "Continue?") -> None:
    """Pause here until the operator presses resume, showing the message."""
    host().confirm(str(message))


@sandbox_function
def stop_program() -> None:
    """End the run here, as finished."""
    host().finish()
