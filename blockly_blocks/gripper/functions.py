"""Grippers by the name they were added under: open, close (with the force set for this
run), whether they hold a part, and waiting for a grip."""

from __future__ import annotations

from typing import Any

from openpendant.sandbox.library.base import (
    host,
    number_arg,
    poll_until,
    sandbox_function,
    text_arg,
)


@sandbox_function
def gripper_activate(gripper: str) -> None:
    """Make the gripper ready after power-up; nothing happens if it already is."""
    host().call("gripper.activate", {"gripper": text_arg(gripper, "gripper")})


@sandbox_function
def gripper_open(gripper: str) -> None:
    """Open the gripper fully; returns when its fingers have stopped."""
    host().call("gripper.open", {"gripper": text_arg(gripper, "gripper")})


@sandbox_function
def gripper_close(gripper: str) -> None:
    """Close the gripper until it is closed or holds a part; returns when it has stopped."""
    host().call("gripper.close", {"gripper": text_arg(gripper, "gripper")})


@sandbox_function
def gripper_set_force(gripper: str, newtons: Any) -> None:
    """The force of this gripper's following closes, in N (within what it can do)."""
    host().call(
        "gripper.force",
        {"gripper": text_arg(gripper, "gripper"), "force": number_arg(newtons, "force", low=0)},
    )


@sandbox_function
def gripper_holds_part(gripper: str) -> bool:
    """True while the gripper reports a part between its fingers."""
    return bool(host().call("gripper.holds", {"gripper": text_arg(gripper, "gripper")}))


@sandbox_function
def gripper_wait_for_grip(gripper: str, timeout: Any) -> None:
    """Wait until the gripper holds a part; fail after `timeout` seconds."""
    poll_until(lambda: gripper_holds_part(gripper), timeout, f"{gripper} did not grip a part")
