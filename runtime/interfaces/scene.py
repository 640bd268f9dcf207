"""The collision scene: obstacles and keep-out zones in the world frame, and objects a robot
holds. Each is stored as a variable of type `scene_object`."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from openpendant.runtime.interfaces.common import Pose, Strict

ShapeKind = Literal["box", "cylinder", "sphere", "mesh"]
# How many numbers `size` holds for each shape, and what they mean.
SIZE_FIELDS: dict[str, tuple[str, ...]] = {
    "box": ("x", "y", "z"),
    "cylinder": ("radius", "length"),
    "sphere": ("radius",),
    "mesh": ("scale x", "scale y", "scale z"),
}
MAX_SIZE = 20.0  # m: bigger than any cell; a larger number is a typing slip


class SceneObject(Strict):
    """A box (edge lengths), a cylinder along its z axis (radius, length), a sphere (radius),
    or an STL mesh (scale); posed in the world frame, or in a robot's TCP frame when the robot
    holds it. A keep-out zone is a region the robot must not enter, shown but not solid."""

    shape: ShapeKind
    size: list[float] = Field(min_length=1, max_length=3)
    mesh: str | None = Field(default=None, max_length=512)
    pose: Pose = Field(default_factory=Pose)
    attached_to: str | None = Field(default=None, max_length=64)
    keep_out: bool = False
    color: str = Field(default="#8a94a6", pattern=r"^#[0-9a-fA-F]{6}$")

    @model_validator(mode="after")
    def _consistent(self) -> SceneObject:
        fields = SIZE_FIELDS[self.shape]
        if len(self.size) != len(fields):
            raise ValueError(f"a {self.shape} needs size [{', '.join(fields)}]")
        if any(not 0 < v <= MAX_SIZE for v in self.size):
            raise ValueError(f"every size of a {self.shape} must be in (0, {MAX_SIZE}] m")
        if (self.shape == "mesh") != (self.mesh is not None):
            raise ValueError("a mesh needs `mesh` (a package:// STL), and only a mesh has one")
        return self
