"""The conveyor's sandbox functions: what a program calls, inside the sandbox worker. They
check their arguments, then ask the runtime (`handlers.py` answers)."""

from __future__ import annotations

from typing import Any

from openpendant.sandbox.library.base import host, number_arg, poll_until, text_arg

MAX_SPEED = 10_000.0  # mm/s: anything faster is a typo (the conveyor refuses over its own)


def run_conveyor(name: str, speed: Any) -> None:
    """Run the conveyor at `speed` mm/s (0 stops it, negative runs it back)."""
    host().call(
        "conveyor.run",
        {
            "conveyor": text_arg(name, "conveyor name", max_length=32),
            "speed": number_arg(speed, "speed", low=-MAX_SPEED, high=MAX_SPEED) / 1000.0,
        },
    )


def part_waiting(name: str) -> bool:
    """True while a part waits at the conveyor's sensor."""
    found = host().call("conveyor.part", {"conveyor": text_arg(name, "conveyor name")})
    return bool(found)


def wait_for_part(name: str, timeout: Any) -> None:
    """Wait until a part is at the sensor; fail after `timeout` seconds."""
    poll_until(lambda: part_waiting(name), timeout, f"no part reached the sensor of {name}")
