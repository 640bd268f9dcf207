"""When a request reached the runtime: the webui proxy stamps what it forwards with
`X-Request-Start` (seconds since the epoch), so a service that promises a reaction time
counts from the runtime's front door, not from its own."""

from __future__ import annotations

import math
import time
from typing import Annotated

from fastapi import Header

HEADER = "X-Request-Start"
RequestStart = Annotated[str | None, Header(alias=HEADER, max_length=32)]
PLAUSIBLE_AGE = 60.0  # s: older or future stamps are not the proxy's


def stamp() -> str:
    return f"{time.time():.6f}"


def received_at(header: str | None) -> float | None:
    """The stamp, or None when there is none or it is no recent time (a direct caller)."""
    if header is None:
        return None
    try:
        value = float(header)
    except ValueError:
        return None
    now = time.time()
    if not math.isfinite(value) or not now - PLAUSIBLE_AGE < value <= now + 1.0:
        return None
    return value
