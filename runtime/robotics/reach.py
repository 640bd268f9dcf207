"""How far a joint's motion can carry the points of a robot's links, per unit of the joint's
motion: bounds that hold at every configuration, fixed by the links' geometry and worked out
once. A revolute joint turned by δ moves a point by at most its distance from the axis times
|δ|; that distance is measured exactly for a link fixed to the joint (or to the link that
carries the axis), and bounded through the joint offsets of the kinematic chain otherwise."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.geometry import BodyPart

Axis = tuple[FloatArray, FloatArray]  # a point and a unit direction


class Reach:
    def __init__(self, model: pin.Model) -> None:
        self.model = model
        data = model.createData()
        pin.computeJointJacobians(model, data, pin.neutral(model))
        # Each single-axis revolute joint's axis, in its own frame and in its parent's.
        self.own: dict[int, Axis] = {}
        self.carried: dict[int, Axis] = {}
        for j in range(1, model.njoints):
            joint = model.joints[j]
            if joint.nv != 1:
                continue
            motion = pin.getJointJacobian(model, data, j, pin.ReferenceFrame.LOCAL)[:, joint.idx_v]
            if np.linalg.norm(motion[:3]) > 1e-12 or abs(np.linalg.norm(motion[3:]) - 1) > 1e-9:
                continue  # not a pure rotation about an axis through the joint's origin
            direction = motion[3:]
            self.own[j] = (np.zeros(3), direction)
            placement = model.jointPlacements[j]
            self.carried[j] = (placement.translation.copy(), placement.rotation @ direction)

    def moved(self, joint: int, part: BodyPart) -> float | None:
        """How far a unit motion of `joint` moves any point of `part` (None: it does not
        move the part)."""
        chain = self._chain_length(joint, part.joint)
        if chain is None:
            return None
        if joint not in self.own:
            return chain + _reach(self._points(part))
        if part.joint == joint:
            return _from_axis(self._points(part), *self.own[joint])
        # The next joint down sits at a fixed offset in this joint's frame: only the part
        # of it across the axis counts.
        below = part.joint
        while self.model.parents[below] != joint:
            below = int(self.model.parents[below])
        origin = self.model.jointPlacements[below].translation[None, :]
        across = _from_axis((origin, 0.0), *self.own[joint])
        return across + chain - self._offset(below) + _reach(self._points(part))

    def still(self, joint: int, part: BodyPart) -> float:
        """For a part `joint` does not move: how far any of its points lies from the joint's
        axis. Turning one link about an axis changes its distance to another no more than
        turning the other back about it would: the nearer of the two to the axis bounds it.
        (inf for a joint that is not revolute.)"""
        if joint not in self.own:
            return np.inf
        if part.joint == self.model.parents[joint] and joint in self.carried:
            return _from_axis(self._points(part), *self.carried[joint])
        common, up, down = joint, 0.0, 0.0
        while self._chain_length(common, part.joint) is None:
            up += self._offset(common)
            common = int(self.model.parents[common])
        down = self._chain_length(common, part.joint) or 0.0
        return up + down + _reach(self._points(part))

    def _points(self, part: BodyPart) -> tuple[FloatArray, float]:
        """Points whose hull holds the part, in its joint's frame, and a radius about them
        (a hull's vertices, or the bounding sphere's centre)."""
        placement = self.model.frames[part.frame].placement * part.shape.local
        if part.shape.hull is not None:
            vertices = part.shape.hull[0]
            return vertices @ placement.rotation.T + placement.translation, 0.0
        return placement.act(part.shape.center)[None, :], part.shape.radius

    def _offset(self, joint: int) -> float:
        return float(np.linalg.norm(self.model.jointPlacements[joint].translation))

    def _chain_length(self, ancestor: int, joint: int) -> float | None:
        """Sum of the joint offsets from `ancestor` down to `joint`, or None when `joint`
        does not descend from it."""
        length = 0.0
        while joint != ancestor:
            if joint == 0:
                return None
            length += self._offset(joint)
            joint = int(self.model.parents[joint])
        return length


def _reach(points: tuple[FloatArray, float]) -> float:
    """How far the part lies from its joint's origin, at most."""
    centers, radius = points
    return float(np.max(np.linalg.norm(centers, axis=1))) + radius


def _from_axis(
    points: tuple[FloatArray, float], origin: FloatArray, direction: FloatArray
) -> float:
    """How far the part lies from an axis, at most (a hull's farthest point from a line is
    one of its vertices)."""
    centers, radius = points
    offsets = centers - origin
    across = offsets - np.outer(offsets @ direction, direction)
    return float(np.max(np.linalg.norm(across, axis=1))) + radius
