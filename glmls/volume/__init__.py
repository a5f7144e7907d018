"""Volumes deformed by a 3D MLS on the GPU: the cells method (the deformed lattice's cells
split into tetrahedra) and the backward method (Newton's method on f), slab by slab of output
slices (see :doc:`/volumes`).

The construction itself lives in :mod:`glmls.volume.construction` (``VolumeWarper``, one per
GL context), what it deforms by in :mod:`glmls.volume.fields` and
:mod:`glmls.volume.kernel_field`."""

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
