"""A URDF made from a serial arm's Denavit-Hartenberg parameters, for robots whose maker
publishes DH parameters but no URDF here (Universal Robots' e-Series).

Standard (distal) DH: joint i turns about z of frame i-1, and frame i = frame i-1 ·
Rz(q_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i). In the URDF, link i is frame i-1 turned by q_i;
joint i+1 sits at Tz(d_i) · Tx(a_i) · Rx(alpha_i) in it, and the flange is the frame after
the last joint.

The bodies are primitive shapes (spheres at the corners, cylinders between them) that wrap
the arm generously: they are what collision checks and the 3D view use, so larger is the
safe side. A link's body runs from its joint along z to `offset` (where the link's tube lies
on the joint axis, UR's shoulder and elbow offsets; by default d), then along x by a, then
back along z to d at the next joint."""

from __future__ import annotations

import hashlib
import itertools
import math
import os
import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from pydantic import Field

from openpendant.runtime.interfaces.common import Strict

GENERATED_PACKAGE = "openpendant-urdf"  # the `package://` name of generated URDFs
COVER_COLOR = "0.72 0.78 0.84 1"  # a light grey-blue, like the arms' covers
MIN_SEGMENT = 1e-6  # m: shorter segments are the same point


class DHLink(Strict):
    joint: str = Field(min_length=1, max_length=64)
    link: str = Field(min_length=1, max_length=64)
    d: float = Field(ge=-5, le=5)  # m
    a: float = Field(ge=-5, le=5)  # m
    alpha: float = Field(ge=-math.pi, le=math.pi)  # rad
    radius: float = Field(gt=0, le=1)  # m, of the body around this link
    offset: float | None = Field(default=None, ge=-5, le=5)  # m along z, the tube's height


class DHArm(Strict):
    """What a robot-info YAML gives under `dh` instead of a `urdf`."""

    base_radius: float = Field(gt=0, le=1)  # m, the foot, from z=0 up to the first joint
    links: list[DHLink] = Field(min_length=1, max_length=16)


def dh_transform(d: float, a: float, alpha: float) -> np.ndarray:
    """Tz(d) · Tx(a) · Rx(alpha) as a 4×4 matrix."""
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[1, 0, 0, a], [0, c, -s, 0], [0, s, c, d], [0, 0, 0, 1]], dtype=float)


def _rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (fixed x, y, z) of a rotation matrix."""
    pitch = math.atan2(-rotation[2, 0], math.hypot(rotation[0, 0], rotation[1, 0]))
    if abs(math.cos(pitch)) < 1e-9:  # gimbal lock: put all of the turn in yaw
        return 0.0, pitch, math.atan2(-rotation[0, 1], rotation[1, 1])
    return (
        math.atan2(rotation[2, 1], rotation[2, 2]),
        pitch,
        math.atan2(rotation[1, 0], rotation[0, 0]),
    )


def origin_element(transform: np.ndarray) -> str:
    xyz = " ".join(f"{v:.9g}" for v in transform[:3, 3])
    rpy = " ".join(f"{v:.12g}" for v in _rpy(transform[:3, :3]))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def body_elements(points: list[np.ndarray], radius: float, end_sphere: bool) -> list[str]:
    """Shapes along a polyline: a sphere on each corner, a cylinder along each segment."""
    corners = [points[0]]
    for p in points[1:]:
        if np.linalg.norm(p - corners[-1]) > MIN_SEGMENT:
            corners.append(p)
    shapes = []
    last = len(corners) - 1
    for i, corner in enumerate(corners):
        if i < last or end_sphere:
            shapes.append((np.eye(4), corner, f'<sphere radius="{radius:.6g}"/>'))
    for start, end in itertools.pairwise(corners):
        axis = end - start
        length = float(np.linalg.norm(axis))
        z = axis / length
        helper = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        pose = np.eye(4)
        pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
        cylinder = f'<cylinder radius="{radius:.6g}" length="{length:.9g}"/>'
        shapes.append((pose, (start + end) / 2, cylinder))
    elements = []
    for pose, centre, geometry in shapes:
        placed = pose.copy()
        placed[:3, 3] = centre
        for tag in ("visual", "collision"):
            material = '<material name="cover"/>' if tag == "visual" else ""
            elements.append(
                f"<{tag}>{origin_element(placed)}<geometry>{geometry}</geometry>{material}</{tag}>"
            )
    return elements


def _link_points(link: DHLink) -> list[np.ndarray]:
    offset = link.d if link.offset is None else link.offset
    return [
        np.array([0.0, 0, 0]),
        np.array([0.0, 0, offset]),
        np.array([link.a, 0, offset]),
        np.array([link.a, 0, link.d]),
    ]


def dh_urdf(
    name: str,
    arm: DHArm,
    links: tuple[str, str],
    limits: list[tuple[float, float, float]],
) -> str:
    """The URDF text of `arm` between `links` (base, flange); `limits` = (lower, upper,
    max velocity) of each joint."""
    base_link, flange_link = links
    if len(limits) != len(arm.links):
        raise ValueError(f"{len(limits)} joint limits for {len(arm.links)} DH links")
    lines = [f"<robot name={quoteattr(name)}>"]
    lines.append(f'<material name="cover"><color rgba="{COVER_COLOR}"/></material>')
    first = arm.links[0]
    foot = [np.array([0.0, 0, 0]), np.array([0.0, 0, max(first.d, 0.0)])]
    lines.append(f"<link name={quoteattr(base_link)}>")
    lines += body_elements(foot, arm.base_radius, end_sphere=False)
    lines.append("</link>")
    parent, placement = base_link, np.eye(4)
    for index, (link, (lower, upper, velocity)) in enumerate(zip(arm.links, limits, strict=True)):
        last = index == len(arm.links) - 1
        lines.append(
            f'<joint name={quoteattr(link.joint)} type="revolute">{origin_element(placement)}'
            f"<parent link={quoteattr(parent)}/><child link={quoteattr(link.link)}/>"
            f'<axis xyz="0 0 1"/>'
            f'<limit lower="{lower:.12g}" upper="{upper:.12g}" velocity="{velocity:.12g}"'
            ' effort="0"/></joint>'
        )
        lines.append(f"<link name={quoteattr(link.link)}>")
        lines += body_elements(_link_points(link), link.radius, end_sphere=not last)
        lines.append("</link>")
        parent, placement = link.link, dh_transform(link.d, link.a, link.alpha)
    lines.append(
        f'<joint name="flange" type="fixed">{origin_element(placement)}'
        f"<parent link={quoteattr(parent)}/><child link={quoteattr(flange_link)}/></joint>"
    )
    lines.append(f"<link name={quoteattr(flange_link)}/>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def generated_dir() -> Path:
    """Where generated URDFs are kept: a cache, remade whenever missing."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "openpendant" / "urdf"


def write_generated(name: str, text: str) -> str:
    """Stores `text` under a name that changes with its content (the 3D view caches robot
    files) and returns its `package://` URI."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    filename = f"{re.sub(r'[^A-Za-z0-9_-]', '_', name)[:64]}-{digest}.urdf"
    folder = generated_dir()
    path = folder / filename
    if not path.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        scratch = folder / f".{filename}.{os.getpid()}"
        scratch.write_text(text)
        scratch.replace(path)  # atomic: another process may be writing the same file
    return f"package://{GENERATED_PACKAGE}/{filename}"
