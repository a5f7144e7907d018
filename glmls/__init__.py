"""glmls: image deformation by Moving Least Squares on the GPU, with error analysis.

Conventions: points are ``(x, y)`` = (column, row) float arrays of shape (N, 2) (in 3D
``(x, y, z)`` = (column, row, slice), (N, 3)); pixel (voxel) centres sit at integer
coordinates; f(v) = v M + T with row vectors.

The top level holds what a user calls: :class:`MLS` (and its :class:`InverseMLS`) and
:func:`warp` (and :func:`warp_batch`), their configuration and :class:`WarpOptions`, the
handle types, image, volume and mesh files, the bundled data, the exceptions and the names of
the choices. The numerical analysis lives in :mod:`glmls.analysis`, random deformations for
data augmentation in :mod:`glmls.augment`, the OpenGL plumbing (contexts, the warp pipeline)
in :mod:`glmls.gl`, the float64 reference of the mathematics in :mod:`glmls.reference`, the
volume warps and their options in :mod:`glmls.volume`, handle files and the other file
formats in :mod:`glmls.files`, the bundled examples in :mod:`glmls.data` and the real-time
windows in :mod:`glmls.app`.
"""

from . import (
    analysis,
    augment,
    data,
    files,
    gl,
    mls3,  # noqa: F401  (registers the MLS of (N, 3) handles)
    reference,
    volume,
)
from .batch import BatchResult, warp_batch
from .core.config import RADIUS_WEIGHTS, TRANSFORMS, WEIGHTS, MLSConfig
from .core.handleset import HANDLE_KINDS, HandleSet
from .core.mesh3 import DeformedMesh
from .core.segments import polyline_segments
from .errors import (
    BorderWarning,
    ContextError,
    DegenerateHandlesError,
    DistributedUnavailableError,
    DtypeError,
    GLUnavailableError,
    ImageWarning,
    InputFileError,
    NoDisplayError,
    ReleasedError,
)
from .files.images import imread, imwrite
from .files.meshes import Mesh, read_mesh, write_mesh
from .files.volumes import Volume, read_volume, write_volume
from .imaging.frame import Bounds
from .imaging.options import WarpOptions
from .imaging.source import BORDERS, INTERPOLATIONS, METHODS
from .mls import MLS, InverseMLS, warp
from .version import __version__

__all__ = [
    "BORDERS",
    "HANDLE_KINDS",
    "INTERPOLATIONS",
    "METHODS",
    "MLS",
    "RADIUS_WEIGHTS",
    "TRANSFORMS",
    "WEIGHTS",
    "BatchResult",
    "BorderWarning",
    "Bounds",
    "ContextError",
    "DeformedMesh",
    "DegenerateHandlesError",
    "DistributedUnavailableError",
    "DtypeError",
    "GLUnavailableError",
    "HandleSet",
    "ImageWarning",
    "InputFileError",
    "InverseMLS",
    "MLSConfig",
    "Mesh",
    "NoDisplayError",
    "ReleasedError",
    "Volume",
    "WarpOptions",
    "__version__",
    "analysis",
    "augment",
    "data",
    "files",
    "gl",
    "imread",
    "imwrite",
    "polyline_segments",
    "read_mesh",
    "read_volume",
    "reference",
    "volume",
    "warp",
    "warp_batch",
    "write_mesh",
    "write_volume",
]
