"""Files: images (:mod:`.images`, 16-bit PNGs kept 16-bit), handle and reference-point files
(:mod:`.landmarks`: points, segments and polylines), and writing outputs whole or not at all
(:mod:`.atomic`)."""

from .atomic import atomic_write
from .images import imread, imwrite
from .landmarks import read_handle_set, read_handles, read_points, write_handle_set, write_handles

__all__ = [
    "atomic_write",
    "imread",
    "imwrite",
    "read_handle_set",
    "read_handles",
    "read_points",
    "write_handle_set",
    "write_handles",
]
