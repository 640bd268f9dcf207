"""Shortening a planned joint polyline: the search leaves detours, and every vertex is a stop
of the robot. Only straight joint lines the caller's motion check accepts are ever put in,
so the result is as clear as that check says (the path check proves it afterwards)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray

Motion = Callable[[FloatArray, FloatArray], bool]  # whether the straight line a → b is clear

PULLS = 4  # rounds of drawing each vertex toward its neighbours


def shortcut(vertices: FloatArray, clear: Motion) -> FloatArray:
    """Fewer vertices and a shorter path from the same start to the same end."""
    path = drop_vertices(vertices, clear)
    for _ in range(PULLS):
        pulled = pull_vertices(path, clear)
        if np.array_equal(pulled, path):
            break
        path = drop_vertices(pulled, clear)
    return path


def drop_vertices(vertices: FloatArray, clear: Motion) -> FloatArray:
    """From each kept vertex, straight on to the furthest later vertex it reaches."""
    kept = [0]
    while kept[-1] < len(vertices) - 1:
        i = kept[-1]
        j = len(vertices) - 1
        while j > i + 1 and not clear(vertices[i], vertices[j]):
            j -= 1
        kept.append(j)
    return vertices[kept]


def pull_vertices(vertices: FloatArray, clear: Motion) -> FloatArray:
    """Each inner vertex moved toward the middle of its neighbours (the corner cut), as
    far of the way as the two lines to it stay clear: half, else a quarter, else not."""
    path = vertices.copy()
    for k in range(1, len(path) - 1):
        before, after = path[k - 1], path[k + 1]
        middle = (before + after) / 2
        for share in (0.5, 0.25):
            moved = path[k] + share * (middle - path[k])
            if clear(before, moved) and clear(moved, after):
                path[k] = moved
                break
    return path
