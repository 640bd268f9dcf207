"""A robot's collision bodies: the URDF's collision geometry on each link, plus the objects
it carries on its TCP (tool, held part), placed for any joint configuration."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.paths import resolve_package_uri
from openpendant.runtime.robotics import geometry
from openpendant.runtime.robotics.geometry import BodyPart, Shape
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.reach import Reach


def _origin(element: ET.Element | None) -> pin.SE3:
    if element is None:
        return pin.SE3.Identity()
    xyz = [float(v) for v in element.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in element.get("rpy", "0 0 0").split()]
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))


def _urdf_shape(name: str, element: ET.Element, urdf: Path, local: pin.SE3) -> Shape | None:
    child = element.find("geometry")
    if child is None or len(child) == 0:
        return None
    g = child[0]
    if g.tag == "mesh":
        scale = tuple(float(v) for v in g.get("scale", "1 1 1").split())
        path = resolve_package_uri(g.get("filename", ""), relative_to=urdf.parent)
        if path.suffix.lower() != ".stl":
            raise InvalidValue(f"collision mesh {path.name}: only STL meshes are read")
        return geometry.mesh(name, path, (scale[0], scale[1], scale[2]), local)
    if g.tag == "box":
        return geometry.box(name, [float(v) for v in g.get("size", "").split()], local)
    if g.tag == "cylinder":
        return geometry.cylinder(name, float(g.get("radius", 0)), float(g.get("length", 0)), local)
    if g.tag == "sphere":
        return geometry.sphere(name, float(g.get("radius", 0)), local)
    return None


class RobotBody:
    """Collision bodies of one robot; placements are in the world frame given its base pose.
    Owns its own pinocchio data, so it can run beside the robot's Kinematics."""

    def __init__(self, name: str, kinematics: Kinematics, urdf: Path | None = None) -> None:
        self.name = name
        self.kinematics = kinematics
        self.model = kinematics.model
        self.data = self.model.createData()
        self.parts: list[BodyPart] = []
        self._reach = Reach(self.model)
        self._part_bounds: FloatArray | None = None
        self.carried: list[BodyPart] = []
        path = urdf or resolve_package_uri(kinematics.info.urdf)
        for link in ET.parse(path).getroot().iter("link"):
            link_name = link.get("name", "")
            if not self.model.existFrame(link_name):
                continue
            frame = self.model.getFrameId(link_name)
            joint = int(self.model.frames[frame].parentJoint)
            for k, element in enumerate(link.findall("collision")):
                label = f"{name}/{link_name}" + (f"#{k}" if k else "")
                shape = _urdf_shape(label, element, path, _origin(element.find("origin")))
                if shape is not None:
                    self.parts.append(BodyPart(shape, frame, joint))
        self._root = pin.SE3.Identity()  # the model's root in the world, at the last place
        self._jacobians_current = False
        self.world_base = pin.SE3.Identity()
        self.q: FloatArray = np.array(kinematics.info.home, dtype=float)
        self.place(self.q)
        self.self_pairs = self._self_pairs()

    def _self_pairs(self) -> list[tuple[BodyPart, BodyPart]]:
        """The pairs of the robot's own links that can hit each other: not on the same or
        adjacent joints (a joint's two sides always touch), and not touching at the home
        position (meshes that overlap by design)."""
        parents = self.model.parents
        pairs = []
        for i, a in enumerate(self.parts):
            for b in self.parts[i + 1 :]:
                if a.joint == b.joint or parents[a.joint] == b.joint or parents[b.joint] == a.joint:
                    continue
                if geometry.proximity(a.shape, b.shape).distance <= 0:
                    continue
                pairs.append((a, b))
        return pairs

    @property
    def moving(self) -> list[BodyPart]:
        """Bodies a joint moves, carried ones included (the others never move into anything)."""
        return [p for p in self.parts if p.joint != 0] + self.carried

    @property
    def shapes(self) -> list[Shape]:
        return [p.shape for p in (*self.parts, *self.carried)]

    def carry(self, shapes: list[Shape]) -> None:
        """Objects fixed to the TCP (their `local` placement is in the TCP frame)."""
        self.carried = [
            BodyPart(
                s,
                self.kinematics.tcp_frame,
                int(self.model.frames[self.kinematics.tcp_frame].parentJoint),
            )
            for s in shapes
        ]
        self._part_bounds = None
        self.place(self.q)

    def set_base(self, world_base: pin.SE3) -> None:
        self.world_base = world_base
        self.place(self.q)

    def place(self, q: FloatArray) -> None:
        """Put every body where joint positions `q` (robot-info order) put it."""
        self.q = np.asarray(q, dtype=float)
        full = pin.neutral(self.model)
        full[self.kinematics.order] = self.q
        pin.framesForwardKinematics(self.model, self.data, full)
        root = self.world_base * self.data.oMf[self.kinematics.base_frame].inverse()
        self._root = root
        self._jacobians_current = False
        for part in (*self.parts, *self.carried):
            part.shape.place(root * self.data.oMf[part.frame])

    def point_jacobian(self, part: BodyPart, point: FloatArray) -> FloatArray:
        """3-by-n Jacobian of a world point fixed to `part`, at the last placed q, in the
        robot's joint order and along the world axes."""
        if not self._jacobians_current:  # once per placement, however many contacts
            pin.computeJointJacobians(self.model, self.data)
            self._jacobians_current = True
        jac = pin.getFrameJacobian(
            self.model, self.data, part.frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )[:, self.kinematics.order]
        rotation = self._root.rotation
        origin = self._root.act(self.data.oMf[part.frame].translation)
        linear = rotation @ jac[:3]
        angular = rotation @ jac[3:]
        offset = point - origin
        jacobian: FloatArray = linear + np.cross(angular.T, offset).T
        return jacobian

    def reach_bounds(self) -> FloatArray:
        """For each joint, a bound on the distance from its axis to any point it moves: a
        joint step δq moves no body point further than Σ bound_j |δq_j|."""
        bounds: FloatArray = self.part_reach_bounds().max(axis=0, initial=0.0)
        return bounds

    def part_reach_bounds(self) -> FloatArray:
        """For each moving part (rows, as in `moving`) and each joint, a bound on the
        distance from the joint's axis to any point of the part: a joint step δq moves no
        point of part p further than Σ bound_pj |δq_j|. Worked out once per carried load."""
        if self._part_bounds is None:
            moving = self.moving
            bounds = np.zeros((len(moving), len(self.kinematics.order)))
            for k, j in enumerate(self._joints()):
                for p, part in enumerate(moving):
                    bounds[p, k] = self._reach.moved(j, part) or 0.0
            self._part_bounds = bounds
        return self._part_bounds.copy()

    @cached_property
    def self_pair_bounds(self) -> FloatArray:
        """For each of `self_pairs` and each joint, a bound on how far the joint moves a point
        of one link of the pair relative to the other: a joint step δq changes the pair's
        distance by at most Σ bound_j |δq_j|. A joint that moves both links (or neither)
        moves them as one and counts zero. Fixed by the links' geometry: worked out once."""
        bounds = np.zeros((len(self.self_pairs), len(self.kinematics.order)))
        for k, j in enumerate(self._joints()):
            for p, (a, b) in enumerate(self.self_pairs):
                to_a, to_b = self._reach.moved(j, a), self._reach.moved(j, b)
                if (to_a is None) == (to_b is None):
                    continue
                moved, still = (to_a, b) if to_a is not None else (to_b, a)
                assert moved is not None
                bounds[p, k] = min(moved, self._reach.still(j, still))
        return bounds

    def _joints(self) -> list[int]:
        """Model joint indices in robot-info order."""
        model = self.model
        joint_of_q = {model.joints[j].idx_q: j for j in range(1, model.njoints)}
        return [joint_of_q[i] for i in self.kinematics.order]
