"""The one registry of variable types. Each type validates a value and returns it in its
stored (normalised, JSON-ready) form; a later issue adds a type with one `register` call."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ValidationError

from runtime.interfaces.common import Pose, all_finite
from runtime.interfaces.robot import ToolSetup
from runtime.interfaces.scene import SceneObject
from runtime.interfaces.variables import (
    DeviceRecord,
    Frame,
    JointWaypoint,
    PoseWaypoint,
    StoredProgram,
)
from runtime.kit.app import describe_validation_errors
from runtime.kit.errors import InvalidValue

MAX_VALUE_BYTES = 4 * 1024 * 1024
MAX_DEPTH = 64

Validator = Callable[[Any], Any]


@dataclass(frozen=True)
class VariableType:
    name: str
    description: str
    validate: Validator


REGISTRY: dict[str, VariableType] = {}


def register(name: str, description: str, validator: Validator | type[BaseModel]) -> None:
    if name in REGISTRY:
        raise ValueError(f"variable type {name!r} is already registered")
    if isinstance(validator, type) and issubclass(validator, BaseModel):
        REGISTRY[name] = VariableType(name, description, _model_validator(validator))
    else:
        REGISTRY[name] = VariableType(name, description, validator)


def validate_value(type_name: str, value: Any) -> Any:
    if type_name not in REGISTRY:
        known = ", ".join(sorted(REGISTRY))
        raise InvalidValue(
            f"unknown variable type {type_name!r} (known: {known})", code="unknown_type"
        )
    _check_json_value(value)
    return REGISTRY[type_name].validate(value)


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


def _number(value: Any) -> float | int:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidValue("a number variable needs a number")
    if isinstance(value, float) and not math.isfinite(value):
        raise InvalidValue("a number must be finite", code="not_finite")
    return value


def _string(value: Any) -> str:
    if not isinstance(value, str):
        raise InvalidValue("a string variable needs a string")
    return value


def _bool(value: Any) -> bool:
    if not isinstance(value, bool):
        raise InvalidValue("a bool variable needs true or false")
    return value


def _list(value: Any) -> list[Any]:
    if not isinstance(value, list):
        raise InvalidValue("a list variable needs a JSON array")
    return value


def _json(value: Any) -> Any:
    return value


register("number", "a finite number", _number)
register("string", "text", _string)
register("bool", "true or false", _bool)
register("joint_waypoint", "joint positions (rad) and the robot they were taught on", JointWaypoint)
register("pose_waypoint", "a TCP pose (m, unit quaternion) in a frame", PoseWaypoint)
register("pose", "a pose: position (m) and orientation (unit quaternion)", Pose)
register("frame", "a coordinate frame: pose in a parent frame", Frame)
register("list", "a list of JSON values", _list)
register("json", "any JSON value", _json)
register("device", "a device added under a local name", DeviceRecord)
register("tool", "what a robot carries: its TCP (in the flange frame) and payload", ToolSetup)
register("scene_object", "an obstacle, keep-out zone or held object of the scene", SceneObject)
register("program", "a program: its Blockly workspace and generated Python", StoredProgram)
