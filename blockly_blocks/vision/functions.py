"""Vision: detect with a detector the user set up (the vision service), pick one detection by
its marker id or class, and the poses to grip it from above. A detection's pose is in the
robot's base frame, as every pose in a program is (the runtime places it there from the
camera's calibration and the robot's base in the world)."""

from __future__ import annotations

from typing import Any

from openpendant.sandbox.guards import SandboxError, register_value_type
from openpendant.sandbox.library.base import host, number_arg, sandbox_function, text_arg
from openpendant.sandbox.values import Pose

# Turned half round its x: the tool's z looks down into what the detection's z looks out of.
FACING_IT = (1.0, 0.0, 0.0, 0.0)


class Detection:
    """One thing found: its label (a marker's id, a class), confidence (0-1), pose (None
    where the camera is not calibrated and placed) and age (s) when it was detected."""

    __slots__ = ("_age", "_confidence", "_label", "_pose")

    def __init__(self, label: str, confidence: float, pose: Pose | None, age: float) -> None:
        self._label, self._confidence, self._pose, self._age = label, confidence, pose, age

    @property
    def label(self) -> str:
        return self._label

    @property
    def confidence(self) -> float:
        return self._confidence

    @property
    def pose(self) -> Pose | None:
        return self._pose

    @property
    def age(self) -> float:
        return self._age

    def __repr__(self) -> str:
        return f"Detection({self._label!r}, {self._confidence:.2f})"


register_value_type(Detection, ("label", "confidence", "pose", "age"))


def _detections(value: Any) -> list[Detection]:
    if not isinstance(value, list) or not all(isinstance(d, Detection) for d in value):
        raise SandboxError("expected the detections a detect block found")
    return value


def _located(value: Any) -> Pose:
    if value is None:
        raise SandboxError("nothing was detected with that label")
    if not isinstance(value, Detection):
        raise SandboxError(f"expected a detection, not {type(value).__name__}")
    if value.pose is None:
        raise SandboxError(
            f"detection {value.label} has no pose: calibrate the camera and place it in the world"
        )
    return value.pose


@sandbox_function
def detect(detector: str) -> list[Detection]:
    """Everything the detector finds in a new image of its camera."""
    found = host().call(
        "vision.detect", {"detector": text_arg(detector, "detector", max_length=32)}
    )
    return [
        Detection(
            str(d["label"]),
            float(d["confidence"]),
            None if d.get("pose") is None else Pose.from_wire(d["pose"]),
            float(d["age"]),
        )
        for d in found
    ]


@sandbox_function
def detection_find(detections: Any, label: Any) -> Detection | None:
    """The most confident detection with this label (a marker id or a class), or None."""
    wanted = str(int(label)) if isinstance(label, float) and label.is_integer() else str(label)
    matching = [d for d in _detections(detections) if d.label == wanted]
    return max(matching, key=lambda d: d.confidence) if matching else None


@sandbox_function
def detection_count(detections: Any) -> int:
    return len(_detections(detections))


@sandbox_function
def detection_grip_pose(detection: Any) -> Pose:
    """A pose at the detection facing it: the tool's z pointing into it, its x along the
    detection's (so the gripper closes across the same sides every time)."""
    return _located(detection).compose(Pose((0.0, 0.0, 0.0), FACING_IT))


@sandbox_function
def detection_above(detection: Any, mm: Any) -> Pose:
    """The grip pose raised by `mm` along the base's z: where to come from and go back to."""
    grip = detection_grip_pose(detection)
    height = number_arg(mm, "height", low=-2000, high=2000) / 1000.0
    x, y, z = grip.position
    return Pose((x, y, z + height), grip.orientation)
