"""Lower bounds of the distance between a robot's parts and other shapes, far cheaper than
FCL's exact distances: the gap of the bounding spheres, and against a box or a cylinder, the
distance from the part's bounding sphere to that exact shape. A pair whose bound is beyond
what a query cares about is settled without FCL (a table's bounding sphere is metres wide and
meets every part; the box itself is near only the parts that are)."""

from __future__ import annotations

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.geometry import Shape


def sphere_gaps(
    centers: FloatArray, radii: FloatArray, other_centers: FloatArray, other_radii: FloatArray
) -> FloatArray:
    """Centre distance minus both radii, for every pair (rows: the first set)."""
    apart = np.linalg.norm(centers[:, None, :] - other_centers[None, :, :], axis=2)
    gaps: FloatArray = apart - radii[:, None] - other_radii[None, :]
    return gaps


class FixedShapes:
    """Shapes that stay where they are (a scene's obstacles), with what their bounds need
    stacked once: boxes and cylinders by their frames and sizes, anything else by its
    bounding sphere (a box or a cylinder lies inside its own: the bound to the shape itself is
    never the looser)."""

    def __init__(self, shapes: list[Shape]) -> None:
        self.shapes = shapes
        self.placements = [s.placements for s in shapes]
        boxes = [j for j, s in enumerate(shapes) if s.kind == "box"]
        cylinders = [j for j, s in enumerate(shapes) if s.kind == "cylinder"]
        self.solids = boxes + cylinders
        self.boxes = len(boxes)
        self.round = [j for j, s in enumerate(shapes) if s.kind not in ("box", "cylinder")]
        solids = [shapes[j] for j in self.solids]
        self.rotations = np.array([s.rotation for s in solids]).reshape(-1, 3, 3)
        self.origins = np.array([s.translation for s in solids]).reshape(-1, 3)
        # Box half sizes; a cylinder's radius, then its half length.
        self.half = np.array(
            [np.asarray(s.size) / 2 for s in solids[: self.boxes]]
            + [[s.size[0], 0.0, s.size[1] / 2] for s in solids[self.boxes :]]
        ).reshape(-1, 3)
        self.centers = np.array([shapes[j].world_center for j in self.round]).reshape(-1, 3)
        self.radii = np.array([shapes[j].radius for j in self.round])

    def current(self, shapes: list[Shape]) -> bool:
        """Whether these are the same shapes, none placed anew since."""
        return shapes is self.shapes and all(
            s.placements == n for s, n in zip(shapes, self.placements, strict=True)
        )

    def lower_bounds(self, centers: FloatArray, radii: FloatArray) -> FloatArray:
        """A lower bound of the distance from each bounding sphere (rows) to each shape."""
        gaps = np.empty((len(centers), len(self.shapes)))
        if self.round:
            gaps[:, self.round] = sphere_gaps(centers, radii, self.centers, self.radii)
        if self.solids:
            # Each sphere's centre in each solid's frame, and its signed distance to the solid
            # from how far it lies beyond each face (a cylinder: across its axis, and along
            # it): negative inside, so that a bound stays under a penetration's depth too.
            local = np.einsum("psk,skl->psl", centers[:, None, :] - self.origins, self.rotations)
            beyond = np.abs(local)
            cylinders = beyond[:, self.boxes :]
            cylinders[..., 0] = np.hypot(cylinders[..., 0], cylinders[..., 1])
            cylinders[..., 1] = -np.inf
            beyond -= self.half
            outside = np.linalg.norm(np.maximum(beyond, 0.0), axis=2)
            inside = np.minimum(beyond.max(axis=2), 0.0)
            gaps[:, self.solids] = outside + inside - radii[:, None]
        return gaps
