"""Volumes deformed by a 3D MLS on the GPU: the cells method (the deformed lattice's cells
split into tetrahedra) and the backward method (Newton's method on f), slab by slab of output
slices (see :doc:`/volumes`).

How the construction is built (one per GL context, and the fields it deforms by) is in
:doc:`/architecture`."""

from .api import volume_bounds, volume_coordinate_map, warp_volume
from .frame import VolumeBounds
from .options import VOLUME_METHODS, SlabOptions, VolumeOptions

__all__ = [
    "VOLUME_METHODS",
    "SlabOptions",
    "VolumeBounds",
    "VolumeOptions",
    "volume_bounds",
    "volume_coordinate_map",
    "warp_volume",
]
