"""STL meshes reduced to convex hulls: a hull contains the part, so distances to it are never
longer than to the part itself, and GJK on a hull is far faster than on a triangle soup."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.kit.errors import InvalidValue

MAX_STL_BYTES = 64 * 1024 * 1024


def read_stl(path: Path) -> FloatArray:
    """The vertices of a binary or ASCII STL file, as an (n, 3) array."""
    if path.stat().st_size > MAX_STL_BYTES:
        raise InvalidValue(f"{path.name} is larger than {MAX_STL_BYTES} bytes")
    data = path.read_bytes()
    if len(data) >= 84:
        count = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if 84 + 50 * count == len(data):
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            triangles = np.frombuffer(data, dtype=record, count=count, offset=84)
            return triangles["v"].reshape(-1, 3).astype(float)
    text = data.decode("ascii", errors="replace")
    vertices = [
        [float(v) for v in line.split()[1:4]]
        for line in text.splitlines()
        if line.strip().startswith("vertex")
    ]
    if not vertices:
        raise InvalidValue(f"{path.name} is not an STL mesh")
    return np.array(vertices)


@cache
def convex_hull(
    path: Path, scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
) -> tuple[FloatArray, list[tuple[int, int, int]]]:
    """Hull vertices and outward triangles of a mesh file (cached per file and scale)."""
    points = read_stl(path) * np.array(scale)
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError) as exc:
        raise InvalidValue(f"{path.name} has no volume to collide with: {exc}") from exc
    index = {int(v): i for i, v in enumerate(hull.vertices)}
    faces = [(index[int(a)], index[int(b)], index[int(c)]) for a, b, c in hull.simplices]
    return points[hull.vertices], faces
