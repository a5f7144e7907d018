"""The bundled 3D examples, made by code (deterministic, nothing stored but their handles):
a 64^3 phantom volume and an icosphere mesh in the same frame."""

from __future__ import annotations

import numpy as np

from ..core.config import check_integer

__all__ = ["MAX_SUBDIVISIONS", "PHANTOM_SIZE", "icosphere", "phantom_volume"]

#: The most subdivisions of :func:`icosphere`: 655,362 vertices, 1,310,720 faces (seconds).
MAX_SUBDIVISIONS = 8
#: The phantom's side: (D, H, W) = (64, 64, 64).
PHANTOM_SIZE = 64
#: (centre (x, y, z), radii (x, y, z), value) of the phantom's solids, drawn in order.
_SOLIDS = (
    ((32.0, 32.0, 32.0), (26.0, 20.0, 16.0), 110),  # the body
    ((32.0, 42.0, 34.0), (10.0, 3.0, 4.0), 160),  # a flat ellipsoid
    ((24.0, 28.0, 32.0), (7.0, 7.0, 7.0), 200),  # a large sphere
    ((42.0, 30.0, 30.0), (4.5, 4.5, 4.5), 255),  # a small sphere
)
#: The grid: lines along each axis every 8 voxels, drawn over everything but the spheres.
_GRID_STEP, _GRID_VALUE = 8, 40


def phantom_volume() -> np.ndarray:
    """The phantom: (64, 64, 64) uint8, an ellipsoid body holding an ellipsoid and two
    spheres, and lines every 8 voxels along x, y and z (value 40) through it all but the
    spheres."""
    n = PHANTOM_SIZE
    z, y, x = np.ogrid[0:n, 0:n, 0:n]
    volume = np.zeros((n, n, n), np.uint8)
    on = [(c % _GRID_STEP) == 0 for c in (x, y, z)]
    grid = (on[0] & on[1]) | (on[1] & on[2]) | (on[0] & on[2])
    for index, (centre, radii, value) in enumerate(_SOLIDS):
        inside = sum(((c - m) / r) ** 2 for c, m, r in zip((x, y, z), centre, radii, strict=True))
        volume[inside <= 1.0] = value
        if index == 1:  # the grid over the body and the ellipsoid, under the spheres
            volume[np.broadcast_to(grid, volume.shape)] = _GRID_VALUE
    return volume


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit icosphere: an icosahedron whose triangles are split in four ``subdivisions``
    times, the new vertices pushed onto the sphere; (vertices (V, 3), faces (F, 3)), the
    faces wound outwards. 2 subdivisions: 162 vertices, 320 faces; at most
    :data:`MAX_SUBDIVISIONS` (``TypeError`` for a count that is not an integer, ``ValueError``
    below 0 or beyond)."""
    # each subdivision makes 4 times the faces, in Python lists: memory and time grow 4-fold
    subdivisions = check_integer("subdivisions", subdivisions, low=0, high=MAX_SUBDIVISIONS)
    t = (1.0 + 5.0**0.5) / 2.0
    vertices = [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
        (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
        (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1),
    ]  # fmt: skip
    faces = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
        (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
        (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
        (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]  # fmt: skip
    points = [np.array(v, dtype=np.float64) / np.linalg.norm(v) for v in vertices]
    for _ in range(subdivisions):
        middle: dict[tuple[int, int], int] = {}
        split = []
        for a, b, c in faces:
            ab, bc, ca = (_halfway(points, middle, i, j) for i, j in ((a, b), (b, c), (c, a)))
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = split
    return np.array(points), np.array(faces, dtype=np.int64)


def _halfway(points: list, middle: dict[tuple[int, int], int], a: int, b: int) -> int:
    """The index of the vertex halfway between vertices a and b on the sphere, made once."""
    key = (min(a, b), max(a, b))
    if key not in middle:
        m = points[a] + points[b]
        points.append(m / np.linalg.norm(m))
        middle[key] = len(points) - 1
    return middle[key]
