"""An RR standard robot's `robot_info` as OpenPendant's robot info: its joints and their
limits, and a URDF made from its kinematic chain (runtime/robotics/chain_urdf.py)."""

from __future__ import annotations

from typing import Any

import numpy as np

from openpendant.runtime.interfaces.robot import JointLimits, RobotInfo
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.robotics.chain_urdf import ChainJoint, KinematicChain, chain_urdf
from openpendant.runtime.robotics.dh_urdf import write_generated

JOINT_TYPES = {0: "revolute", 1: "revolute", 2: "prismatic", 3: "prismatic"}  # RR JointType
BASE_LINK = "base"


def _text(identifier: Any, default: str) -> str:
    name = getattr(identifier, "name", "") if identifier is not None else ""
    return str(name or default)


def robot_info_of(info: Any, node: Any) -> RobotInfo:
    """`info`: a `com.robotraconteur.robotics.robot.RobotInfo` read from the robot."""
    if not info.chains:
        raise InvalidValue("the robot's info has no kinematic chain: give a robot-info file")
    chain = info.chains[0]
    axes = np.asarray(node.NamedArrayToArray(chain.H), dtype=float).reshape(-1, 3)
    offsets = np.asarray(node.NamedArrayToArray(chain.P), dtype=float).reshape(-1, 3)
    numbers = list(chain.joint_numbers) if chain.joint_numbers is not None else []
    joints_info = [info.joint_info[i] for i in numbers] if numbers else list(info.joint_info)
    if len(axes) != len(joints_info) or len(offsets) != len(joints_info) + 1:
        raise InvalidValue(
            f"the robot's chain has {len(axes)} axes and {len(offsets)} offsets "
            f"for {len(joints_info)} joints"
        )
    limits, chain_joints = [], []
    for index, joint in enumerate(joints_info):
        name = _text(joint.joint_identifier, f"joint_{index + 1}")
        bounds = joint.joint_limits
        jerk = float(getattr(bounds, "jerk", 0.0) or 0.0)
        limits.append(
            JointLimits(
                name=name,
                lower=float(bounds.lower),
                upper=float(bounds.upper),
                max_velocity=float(bounds.velocity),
                max_acceleration=float(bounds.acceleration),
                max_jerk=jerk if jerk > 0 else None,
            )
        )
        chain_joints.append(
            ChainJoint(
                name=name,
                kind=JOINT_TYPES.get(int(joint.joint_type), "revolute"),
                axis=axes[index].tolist(),
                offset=offsets[index].tolist(),
                lower=float(bounds.lower),
                upper=float(bounds.upper),
                max_velocity=float(bounds.velocity),
            )
        )
    pose = node.NamedArrayToArray(chain.flange_pose).reshape(-1)  # w x y z, then x y z
    w, x, y, z, px, py, pz = (float(v) for v in pose[:7])
    tool_offset = offsets[-1] + np.array([px, py, pz])
    device = info.device_info
    model = _text(getattr(device, "model", None), "") or _text(
        getattr(device, "device", None), "rr-robot"
    )
    flange_link = _text(chain.flange_identifier, "flange")
    urdf = chain_urdf(
        model,
        KinematicChain(
            joints=chain_joints,
            flange_offset=tool_offset.tolist(),
            flange_orientation=[x, y, z, w] if (w, x, y, z) != (0, 0, 0, 0) else [0, 0, 0, 1],
        ),
        (BASE_LINK, flange_link),
    )
    home = [0.0 if j.lower <= 0.0 <= j.upper else (j.lower + j.upper) / 2 for j in limits]
    return RobotInfo(
        model=model[:64],
        manufacturer=_text(getattr(device, "manufacturer", None), ""),
        description=str(getattr(device, "user_description", "") or ""),
        urdf=write_generated(model, urdf),
        base_link=BASE_LINK,
        flange_link=flange_link,
        joints=limits,
        home=home,
    )
