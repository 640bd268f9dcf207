"""What the blocks' handlers share (each category's own are in blockly_blocks/<category>/
handlers.py). A handler is `async def handler(run, args)`: `run` is the run's RunHost, `args`
what the sandbox function sent, checked here again; a refusal is a CallRefused, which fails
the program at its block with the reason."""

from __future__ import annotations

import re
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.sandbox.supervisor import CallRefused

M = TypeVar("M", bound=BaseModel)
DEVICE_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}\Z")


def checked(model: type[M], value: Any) -> M:
    """A value from the sandbox as a model, or the reason it is not one."""
    try:
        return model.model_validate(value)
    except ValidationError as exc:
        message, _ = describe_validation_errors(exc.errors())
        raise CallRefused(message, "invalid_request") from None
