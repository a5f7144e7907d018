"""glmls: image deformation by Moving Least Squares on the GPU, with error analysis.

Conventions: points are ``(x, y)`` = (column, row) float arrays of shape (N, 2); pixel centres
sit at integer coordinates; f(v) = v M + T with row vectors.
"""

from .config import RADIUS_WEIGHTS, TRANSFORMS, WEIGHTS, MLSConfig
from .context import GLContext, get_context
from .errors import DegenerateHandlesError, GLUnavailableError, ReleasedError
from .io import imread, imwrite
from .mls import MLS
from .pipeline import INTERPOLATIONS, METHODS, WarpPipeline
from .warp import Foldovers, foldovers, warp

__version__ = "0.1.0"

__all__ = [
    "INTERPOLATIONS",
    "METHODS",
    "MLS",
    "RADIUS_WEIGHTS",
    "TRANSFORMS",
    "WEIGHTS",
    "DegenerateHandlesError",
    "Foldovers",
    "GLContext",
    "GLUnavailableError",
    "MLSConfig",
    "ReleasedError",
    "WarpPipeline",
    "__version__",
    "foldovers",
    "get_context",
    "imread",
    "imwrite",
    "warp",
]
