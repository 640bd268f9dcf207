"""A URDF made from a serial arm's kinematic chain as Robot Raconteur's robot info gives it
(product of exponentials): with every joint at zero, joint i's axis is H[i] and its origin
lies at P[0] + … + P[i] in the base frame; the flange lies P[n] beyond the last joint,
turned by the flange rotation. At zero every link's frame is the base frame moved to its
joint, so each URDF joint is a translation by P[i] with its axis H[i].

The bodies wrap each link generously (a tube of `radius` from its joint to the next), like
the DH arms' (dh_urdf.py): collision checks and the 3D view use them."""

from __future__ import annotations

from typing import Literal
from xml.sax.saxutils import quoteattr

import numpy as np
from pydantic import Field, model_validator

from openpendant.runtime.interfaces.common import Strict, Vector3
from openpendant.runtime.robotics.dh_urdf import COVER_COLOR, body_elements, origin_element

DEFAULT_RADIUS = 0.04  # m around each link: the chain gives no shapes


class ChainJoint(Strict):
    name: str = Field(min_length=1, max_length=64)
    kind: Literal["revolute", "prismatic"] = "revolute"
    axis: Vector3  # H[i], in the base frame with every joint at zero
    offset: Vector3  # P[i], from the previous joint (the base for the first) to this one
    lower: float
    upper: float
    max_velocity: float = Field(gt=0)

    @model_validator(mode="after")
    def _unit_axis(self) -> ChainJoint:
        norm = float(np.linalg.norm(self.axis))
        if not 0.99 < norm < 1.01:
            raise ValueError(f"joint {self.name}: its axis must be a unit vector (is {norm:.3g})")
        return self


class KinematicChain(Strict):
    joints: list[ChainJoint] = Field(min_length=1, max_length=64)
    flange_offset: Vector3  # P[n], from the last joint to the flange
    # The flange's orientation in the base frame with every joint at zero (x, y, z, w).
    flange_orientation: list[float] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0, 1.0], min_length=4, max_length=4
    )
    radius: float = Field(default=DEFAULT_RADIUS, gt=0, le=1)


def _rotation(quaternion: list[float]) -> np.ndarray:
    x, y, z, w = np.asarray(quaternion, dtype=float) / np.linalg.norm(quaternion)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _moved(offset: Vector3, rotation: np.ndarray | None = None) -> np.ndarray:
    transform = np.eye(4)
    transform[:3, 3] = offset
    if rotation is not None:
        transform[:3, :3] = rotation
    return transform


def chain_urdf(name: str, chain: KinematicChain, links: tuple[str, str]) -> str:
    """The URDF text of `chain` between `links` (base, flange)."""
    base_link, flange_link = links
    offsets = [np.asarray(j.offset, dtype=float) for j in chain.joints]
    offsets.append(np.asarray(chain.flange_offset, dtype=float))
    lines = [f"<robot name={quoteattr(name)}>"]
    lines.append(f'<material name="cover"><color rgba="{COVER_COLOR}"/></material>')
    lines.append(f"<link name={quoteattr(base_link)}>")
    lines += body_elements([np.zeros(3), offsets[0]], chain.radius, end_sphere=False)
    lines.append("</link>")
    parent = base_link
    for index, joint in enumerate(chain.joints):
        link = f"{joint.name}_link"
        axis = " ".join(f"{v:.12g}" for v in joint.axis)
        lines.append(
            f"<joint name={quoteattr(joint.name)} type={quoteattr(joint.kind)}>"
            f"{origin_element(_moved(joint.offset))}"
            f"<parent link={quoteattr(parent)}/><child link={quoteattr(link)}/>"
            f'<axis xyz="{axis}"/>'
            f'<limit lower="{joint.lower:.12g}" upper="{joint.upper:.12g}"'
            f' velocity="{joint.max_velocity:.12g}" effort="0"/></joint>'
        )
        lines.append(f"<link name={quoteattr(link)}>")
        last = index == len(chain.joints) - 1
        lines += body_elements([np.zeros(3), offsets[index + 1]], chain.radius, not last)
        lines.append("</link>")
        parent = link
    flange = _moved(chain.flange_offset, _rotation(chain.flange_orientation))
    lines.append(
        f'<joint name={quoteattr(flange_link + "_mount")} type="fixed">{origin_element(flange)}'
        f"<parent link={quoteattr(parent)}/><child link={quoteattr(flange_link)}/></joint>"
    )
    lines.append(f"<link name={quoteattr(flange_link)}/>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
