"""A path monitor, as a robot controller has one: while a planned move runs (the motion
service's moves, the Jog panel's steps and Move to), the robot's actual TCP is compared with
the path that was planned and collision-checked; farther from it than the tolerance, the
move is stopped (halted, and a protective stop) with `path_deviation`."""

from __future__ import annotations

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.robotics.deviation import distances_to_polyline
from openpendant.runtime.robotics.kinematics import Kinematics


class PathDeviation(OpenPendantError):
    status = 409
    code = "path_deviation"


class PathMonitor:
    def __init__(
        self,
        kinematics: Kinematics,
        planned: FloatArray,
        tolerance: float,
        joint_tolerance: float,
    ) -> None:
        """`planned`: the joint positions of the trajectory's samples, in order."""
        self.kinematics = kinematics
        self.joints = planned
        self.tcp = np.array([kinematics.tcp(q).translation for q in planned])
        self.tolerance = tolerance
        self.joint_tolerance = joint_tolerance
        self.worst = 0.0  # m, the largest TCP distance seen

    def check(self, joint_position: FloatArray) -> None:
        tcp = self.kinematics.tcp(joint_position).translation
        distance = float(distances_to_polyline(self.tcp, tcp[None, :])[0])
        self.worst = max(self.worst, distance)
        if distance > self.tolerance:
            raise PathDeviation(
                f"the TCP left its planned path by {distance * 1000:.1f} mm "
                f"(tolerance {self.tolerance * 1000:.1f} mm)",
                details={"distance": distance, "tolerance": self.tolerance},
            )
        joints = float(distances_to_polyline(self.joints, joint_position[None, :])[0])
        if joints > self.joint_tolerance:
            raise PathDeviation(
                f"the joints left their planned path by {joints:.4f} rad "
                f"(tolerance {self.joint_tolerance:.4f} rad)",
                details={"joint_distance": joints, "joint_tolerance": self.joint_tolerance},
            )
