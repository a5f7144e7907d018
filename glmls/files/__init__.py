"""Files: images (:mod:`.images`, 16-bit PNGs kept 16-bit; their colour profiles:
:mod:`.profiles`), volumes (:mod:`.volumes`: NIfTI, TIFF stacks, ``.npy``; the dtypes they
are warped in: :mod:`.volume_dtypes`), triangle meshes (:mod:`.meshes`: PLY, OBJ, STL),
handle and reference-point files (:mod:`.landmarks`: points, segments and polylines in 2D,
points in 3D, BigWarp's and elastix's landmarks), and writing outputs whole or not at all
(:mod:`.atomic`)."""

from .atomic import atomic_write
from .images import imread, imwrite
from .landmarks import read_handle_set, read_handles, read_points, write_handle_set, write_handles
from .meshes import Mesh, read_mesh, write_mesh
from .profiles import read_icc_profile
from .volumes import (
    NiftiHeader,
    Volume,
    read_volume,
    volume_to_world,
    world_to_volume,
    write_volume,
)

__all__ = [
    "Mesh",
    "NiftiHeader",
    "Volume",
    "atomic_write",
    "imread",
    "imwrite",
    "read_handle_set",
    "read_handles",
    "read_icc_profile",
    "read_mesh",
    "read_points",
    "read_volume",
    "volume_to_world",
    "world_to_volume",
    "write_handle_set",
    "write_handles",
    "write_mesh",
    "write_volume",
]
