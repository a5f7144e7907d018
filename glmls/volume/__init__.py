"""Volumes deformed by a 3D MLS on the GPU: the cells method (tetrahedra) and the backward
method, slab by slab of output slices."""

from .api import volume_bounds, volume_coordinate_map, warp_volume
from .construction import VolumeWarper
from .fields import Field, ReferenceField
from .frame import CornerLattice, VolumeBounds, VolumeFrame
from .kernel_field import KernelField
from .options import VOLUME_METHODS, SlabOptions, VolumeOptions

__all__ = [
    "VOLUME_METHODS",
    "CornerLattice",
    "Field",
    "KernelField",
    "ReferenceField",
    "SlabOptions",
    "VolumeBounds",
    "VolumeFrame",
    "VolumeOptions",
    "VolumeWarper",
    "volume_bounds",
    "volume_coordinate_map",
    "warp_volume",
]
