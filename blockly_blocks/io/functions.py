"""Digital I/O by name: "<robot>.do<N>" and "<robot>.di<N>" are a robot controller's
outputs and inputs (numbered from 0); "<block>.<signal>" a signal of an I/O block (its
register map names them)."""

from __future__ import annotations

from typing import Any

from openpendant.sandbox.library.base import (
    bool_arg,
    host,
    number_arg,
    poll_until,
    sandbox_function,
    text_arg,
)


@sandbox_function
def set_output(name: str, value: Any) -> None:
    """Switch a digital output on (true) or off (false)."""
    host().call(
        "io.set", {"name": text_arg(name, "output name"), "value": bool_arg(value, "value")}
    )


@sandbox_function
def get_input(name: str) -> bool:
    return bool(host().call("io.get", {"name": text_arg(name, "input name")}))


@sandbox_function
def get_output(name: str) -> bool:
    return bool(host().call("io.get", {"name": text_arg(name, "output name")}))


@sandbox_function
def wait_for_input(name: str, value: Any, timeout: Any) -> None:
    """Wait until the input reads `value`; fail after `timeout` seconds."""
    wanted = bool_arg(value, "value")
    poll_until(lambda: get_input(name) is wanted, timeout, f"{name} did not turn {wanted}")


@sandbox_function
def set_analog_output(name: str, value: Any) -> None:
    """Set an analog output to a value in its unit (within its range)."""
    host().call(
        "io.set_analog",
        {"name": text_arg(name, "output name"), "value": number_arg(value, "value")},
    )


@sandbox_function
def get_analog(name: str) -> float:
    """An analog input or output, in its unit."""
    return float(host().call("io.get_analog", {"name": text_arg(name, "signal name")}))
