"""glmls: image deformation by Moving Least Squares on the GPU, with error analysis.

Conventions: points are ``(x, y)`` = (column, row) float arrays of shape (N, 2); pixel centres
sit at integer coordinates; f(v) = v M + T with row vectors.

The top level holds what a user calls: :class:`MLS` (and its :class:`InverseMLS`) and
:func:`warp`, their configuration and :class:`WarpOptions`, the handle types, image files,
the bundled data, the exceptions and the names of the choices.
The numerical analysis lives in :mod:`glmls.analysis`, the OpenGL plumbing (contexts, the
warp pipeline) in :mod:`glmls.gl`, the float64 reference of the mathematics in
:mod:`glmls.reference`.
"""

from . import (
    analysis,
    data,
    gl,
    mls3,  # noqa: F401  (registers the MLS of (N, 3) handles)
    reference,
)
from .core.config import RADIUS_WEIGHTS, TRANSFORMS, WEIGHTS, MLSConfig
from .core.handleset import HANDLE_KINDS, HandleSet
from .core.mesh3 import DeformedMesh
from .core.segments import polyline_segments
from .errors import (
    BorderWarning,
    ContextError,
    DegenerateHandlesError,
    GLUnavailableError,
    ImageWarning,
    InputFileError,
    ReleasedError,
)
from .files.images import imread, imwrite
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
    "BorderWarning",
    "Bounds",
    "ContextError",
    "DeformedMesh",
    "DegenerateHandlesError",
    "GLUnavailableError",
    "HandleSet",
    "ImageWarning",
    "InputFileError",
    "InverseMLS",
    "MLSConfig",
    "ReleasedError",
    "WarpOptions",
    "__version__",
    "analysis",
    "data",
    "gl",
    "imread",
    "imwrite",
    "polyline_segments",
    "reference",
    "warp",
]
