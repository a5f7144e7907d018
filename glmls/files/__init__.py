"""Files: images (:func:`~glmls.imread`, :func:`~glmls.imwrite`: 16-bit PNGs kept 16-bit,
and their colour profiles, :func:`read_icc_profile`), volumes (:func:`~glmls.read_volume`,
:func:`~glmls.write_volume`: NIfTI, TIFF stacks, ``.npy``; a NIfTI file's
:class:`NiftiHeader` and world coordinates, :func:`world_to_volume`), triangle meshes
(:func:`~glmls.read_mesh`, :func:`~glmls.write_mesh`: PLY, OBJ, STL), handle and
reference-point files (:func:`read_handle_set`, :func:`read_handles`, :func:`read_points`,
:func:`write_handles`: points, segments and polylines in 2D, points in 3D, BigWarp's and
elastix's landmarks), and writing outputs whole or not at all (:func:`atomic_write`).

The modules inside (``glmls.files.volumes``, ``glmls.files.landmarks``, ...) hold these and
the rules they follow, such as the dtypes a volume is warped in
(``glmls.files.volume_dtypes``)."""

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
