"""The one registry of variable types. Each type validates a value and returns it in its
stored (normalised, JSON-ready) form. The types are the plugins' (the built-in ones are the
core plugin's, `runtime/plugin.py`): a plugin adds one with a `VariableType` declaration."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

from pydantic import BaseModel, ValidationError

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.interfaces.common import all_finite
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.errors import InvalidValue

MAX_VALUE_BYTES = 4 * 1024 * 1024
MAX_DEPTH = 64

Validator = Callable[[Any], Any]


@dataclass(frozen=True)
class VariableType:
    name: str
    description: str
    validate: Validator


@cache
def types() -> dict[str, VariableType]:
    """Every installed plugin's variable types; one whose validator cannot be loaded is left
    out and reported with its plugin."""
    found: dict[str, VariableType] = {}
    plugins = registry()
    for name, declared in plugins.variable_types.items():
        try:
            validator = resolve(declared.validator)
        except Exception as exc:  # a broken plugin leaves the rest working
            owner = plugins.owner.get(("variable type", name), "?")
            plugins.fail(owner, declared.validator, f"{type(exc).__name__}: {exc}")
            continue
        if isinstance(validator, type) and issubclass(validator, BaseModel):
            validator = _model_validator(validator)
        found[name] = VariableType(name, declared.description, validator)
    return found


def validate_value(type_name: str, value: Any) -> Any:
    known_types = types()
    if type_name not in known_types:
        known = ", ".join(sorted(known_types))
        raise InvalidValue(
            f"unknown variable type {type_name!r} (known: {known})", code="unknown_type"
        )
    _check_json_value(value)
    return known_types[type_name].validate(value)


def _check_json_value(value: Any) -> None:
    if not all_finite(value):
        raise InvalidValue(
            "value holds a NaN or infinite number, or is nested too deeply", code="not_finite"
        )
    try:
        size = len(json.dumps(value, allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise InvalidValue(f"value is not plain JSON: {exc}") from exc
    if size > MAX_VALUE_BYTES:
        raise InvalidValue(
            f"value is {size} bytes; the limit is {MAX_VALUE_BYTES}", code="too_large"
        )


def _model_validator(model: type[BaseModel]) -> Validator:
    def validate(value: Any) -> Any:
        try:
            return model.model_validate(value).model_dump(mode="json")
        except ValidationError as exc:
            message, _ = describe_validation_errors(exc.errors())
            raise InvalidValue(message) from exc

    return validate


def number(value: Any) -> float | int:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidValue("a number variable needs a number")
    if isinstance(value, float) and not math.isfinite(value):
        raise InvalidValue("a number must be finite", code="not_finite")
    return value


def string(value: Any) -> str:
    if not isinstance(value, str):
        raise InvalidValue("a string variable needs a string")
    return value


def boolean(value: Any) -> bool:
    if not isinstance(value, bool):
        raise InvalidValue("a bool variable needs true or false")
    return value


def json_list(value: Any) -> list[Any]:
    if not isinstance(value, list):
        raise InvalidValue("a list variable needs a JSON array")
    return value


def any_json(value: Any) -> Any:
    return value
