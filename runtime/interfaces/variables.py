"""The values other services and the UI read and write in the variable storage: a stored
variable, and the models of the typed values that more than one service uses."""

from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import JointVector, Pose, Strict

# A variable's name is only a name: no path separators, spaces, control or bidi characters.
NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_.\-]{0,127}\Z")
# The same for pydantic fields (whose Rust regex has no \Z; its $ is the end of the text).
VARIABLE_NAME = r"^[A-Za-z][A-Za-z0-9_.\-]{0,127}$"


class Variable(BaseModel):
    name: str
    type: str
    value: Any
    tags: list[str] = Field(default_factory=list)
    doc: str = ""
    created: float
    updated: float
    version: int


class JointWaypoint(Strict):
    """A joint-space point, taught on a given robot (radians, in its joint order)."""

    joints: JointVector
    robot: str = Field(min_length=1, max_length=64)


class PoseWaypoint(Strict):
    """A TCP pose in a named frame ("base" of the robot, "world", or a stored frame)."""

    pose: Pose
    frame: str = Field(default="base", min_length=1, max_length=64)
    robot: str | None = Field(default=None, max_length=64)


class Frame(Strict):
    """A coordinate frame: its pose in a parent frame."""

    pose: Pose
    parent: str = Field(default="world", min_length=1, max_length=64)


class DeviceRecord(Strict):
    """A device the user added, under its local name (written by the device manager)."""

    uuid: str = Field(min_length=1, max_length=64)
    local_name: str = Field(pattern=r"^[a-z][a-z0-9_]{0,31}$")
    kind: str = Field(max_length=16)
    model: str = Field(max_length=64)
    name: str = Field(max_length=64)
    url: str = Field(max_length=256)


class StoredProgram(Strict):
    """The variable storage's `program` type. The workspace is kept as JSON text: a long
    stack of blocks nests deeper than stored values may."""

    source: Literal["blocks", "python"]
    workspace_json: str | None = None
    python: str = Field(max_length=2_000_000)
