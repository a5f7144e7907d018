"""glmls: image deformation by Moving Least Squares on the GPU, with error analysis.

Conventions: points are ``(x, y)`` = (column, row) float arrays of shape (N, 2); pixel centres
sit at integer coordinates; f(v) = v M + T with row vectors.
"""

from .analysis import TriangleErrors, error_field, error_stats, triangle_errors
from .colormaps import VIRIDIS, apply_colormap, color_limits, colorbar, linear_colormap
from .config import RADIUS_WEIGHTS, TRANSFORMS, WEIGHTS, MLSConfig
from .context import GLContext, get_context
from .errors import DegenerateHandlesError, GLUnavailableError, ReleasedError
from .io import imread, imwrite
from .mls import MLS
from .pipeline import INTERPOLATIONS, METHODS, WarpPipeline
from .render import (
    Canvas,
    render_field,
    render_handles,
    render_mesh,
    render_triangle_errors,
    render_triangulation,
)
from .report import AnalysisReport, report
from .warp import Foldovers, foldovers, warp

__version__ = "0.1.0"

__all__ = [
    "INTERPOLATIONS",
    "METHODS",
    "MLS",
    "RADIUS_WEIGHTS",
    "TRANSFORMS",
    "VIRIDIS",
    "WEIGHTS",
    "AnalysisReport",
    "Canvas",
    "DegenerateHandlesError",
    "Foldovers",
    "GLContext",
    "GLUnavailableError",
    "MLSConfig",
    "ReleasedError",
    "TriangleErrors",
    "WarpPipeline",
    "__version__",
    "apply_colormap",
    "color_limits",
    "colorbar",
    "error_field",
    "error_stats",
    "foldovers",
    "get_context",
    "imread",
    "imwrite",
    "linear_colormap",
    "render_field",
    "render_handles",
    "render_mesh",
    "render_triangle_errors",
    "render_triangulation",
    "report",
    "triangle_errors",
    "warp",
]
