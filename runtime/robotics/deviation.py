"""How far a robot is from the path it was planned to follow: the distance of its TCP from
the planned TCP path (a polyline through the planned samples), or of its joints from the
planned joint path. Geometric, not timed: a pause or the speed override change when the
robot is somewhere on its path, not whether it is on it. (Near a crossing of the path
with itself the nearer pass counts.)"""

from __future__ import annotations

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray

BUDGET = 2_000_000  # floats of work space at a time: bounded memory on long paths


def distances_to_polyline(points: FloatArray, queries: FloatArray) -> FloatArray:
    """For each row of `queries`, its distance to the polyline through `points`."""
    if len(points) == 1:
        return np.asarray(np.linalg.norm(queries - points[0], axis=1))
    a, b = points[:-1], points[1:]
    ab = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    best = np.full(len(queries), np.inf)
    chunk = max(1, BUDGET // (len(queries) * points.shape[1]))
    for start in range(0, len(a), chunk):
        end = start + chunk
        sa, sab, sl = a[start:end], ab[start:end], length2[start:end]
        rel = queries[:, None, :] - sa[None, :, :]
        u = np.clip(np.einsum("qsj,sj->qs", rel, sab) / sl, 0.0, 1.0)
        gap = rel - u[:, :, None] * sab[None, :, :]
        best = np.minimum(best, np.min(np.linalg.norm(gap, axis=2), axis=1))
    return best
