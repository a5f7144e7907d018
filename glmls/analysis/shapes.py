"""2-D shapes as triangles in image pixel coordinates ((x, y) = (column, row), pixel centres
at integers), for the GPU to rasterise: segments of a width, disks, arrows. Pure numpy; the
offscreen pictures (:mod:`.canvas`) and the window's overlays draw them."""

from __future__ import annotations

import numpy as np

__all__ = ["arrow_triangles", "disk_triangles", "segment_triangles"]


def segment_triangles(a: np.ndarray, b: np.ndarray, width: float) -> np.ndarray:
    """Each segment a[k] -> b[k] as a quad of the given width: (6 K', 2) triangle vertices
    (zero-length segments are left out)."""
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > 0
    a, b, d, length = a[keep], b[keep], d[keep], length[keep]
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None] * (width / 2)
    quads = np.stack([a - normal, a + normal, b + normal, a - normal, b + normal, b - normal], 1)
    return quads.reshape(-1, 2)


def disk_triangles(centres: np.ndarray, radius: float, sides: int = 16) -> np.ndarray:
    """A regular polygon of ``sides`` around each centre: (3 sides K, 2) triangle vertices."""
    angle = np.linspace(0.0, 2 * np.pi, sides + 1)
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=1) * radius
    tri = np.stack([np.zeros_like(ring[:-1]), ring[:-1], ring[1:]], axis=1)  # (sides, 3, 2)
    return (centres[:, None, None, :] + tri[None]).reshape(-1, 2)


def arrow_triangles(src: np.ndarray, dst: np.ndarray, width: float, head: float) -> np.ndarray:
    """Arrows src[k] -> dst[k]: a shaft of ``width`` and a head ``head`` long (shorter arrows
    get a proportionally smaller head); zero-length arrows are left out."""
    d = dst - src
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > 0
    src, dst, d, length = src[keep], dst[keep], d[keep], length[keep]
    unit = d / length[:, None]
    head_length = np.minimum(head, 0.5 * length)[:, None]
    base = dst - unit * head_length
    normal = np.stack([-unit[:, 1], unit[:, 0]], axis=1) * (0.6 * head_length)
    heads = np.stack([dst, base + normal, base - normal], axis=1).reshape(-1, 2)
    return np.concatenate([segment_triangles(src, base, width), heads])
