"""The variable storage: values kept between runs (numbers, text, true/false, lists, poses)."""

from __future__ import annotations

from typing import Any

from openpendant.sandbox.library.base import host, sandbox_function, text_arg
from openpendant.sandbox.values import Pose


@sandbox_function
def stored(name: str) -> Any:
    """A stored variable's value (a pose comes back as a pose)."""
    found = host().call("store.get", {"name": text_arg(name, "variable name")})
    if found["type"] == "pose":
        return Pose.from_wire(found["value"])
    return found["value"]


@sandbox_function
def store(name: str, value: Any) -> None:
    """Keep `value` under `name` in the variable storage."""
    text_arg(name, "variable name")
    if isinstance(value, Pose):
        host().call("store.set", {"name": name, "type": "pose", "value": value.wire()})
    else:
        host().call("store.set", {"name": name, "value": value})
