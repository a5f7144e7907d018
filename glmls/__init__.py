"""glmls: image deformation by Moving Least Squares on the GPU, with error analysis.

Conventions: points are ``(x, y)`` = (column, row) float arrays of shape (N, 2); pixel centres
sit at integer coordinates; f(v) = v M + T with row vectors.

The package is layered, each layer importing only those before it: ``core`` (numpy: settings,
the weight registry, handles, the mesh lattice, the float64 ``reference``), ``gl`` (contexts,
shaders, bindings, resources), ``engine`` (the MLS kernel and its passes), ``imaging`` (the
construction of deformed images), ``mls`` (the :class:`MLS` facade), then ``analysis``,
``files``, ``app`` (the window) and ``cli``.
"""

from . import data
from .analysis import colormaps
from .analysis.canvas import Canvas
from .analysis.colormaps import VIRIDIS, apply_colormap, color_limits, colorbar, linear_colormap
from .analysis.construction import ConstructionErrors, construction_errors
from .analysis.construction_ranking import rank_constructions
from .analysis.field import error_field
from .analysis.foldovers import Foldovers, foldovers
from .analysis.jobs import run_jobs
from .analysis.pictures import (
    render_construction_errors,
    render_field,
    render_handles,
    render_mesh,
    render_triangle_errors,
    render_triangulation,
)
from .analysis.report import AnalysisReport, report
from .analysis.stats import error_stats
from .analysis.study import StudyResult, study
from .analysis.triangles import ANGLE_MEASURES, TriangleErrors, triangle_errors
from .core import reference
from .core.config import RADIUS_WEIGHTS, TRANSFORMS, WEIGHTS, MLSConfig
from .core.handleset import HANDLE_KINDS, HandleSet
from .core.segments import polyline_segments
from .errors import (
    BorderWarning,
    ContextError,
    DegenerateHandlesError,
    GLUnavailableError,
    ReleasedError,
)
from .files.images import imread, imwrite
from .gl.context import GLContext, get_context
from .imaging.adaptive import AdaptiveMesh
from .imaging.frame import Bounds
from .imaging.pipeline import WarpPipeline
from .imaging.source import BORDERS, INTERPOLATIONS, METHODS
from .mls import MLS, warp
from .version import __version__

__all__ = [
    "ANGLE_MEASURES",
    "BORDERS",
    "HANDLE_KINDS",
    "INTERPOLATIONS",
    "METHODS",
    "MLS",
    "RADIUS_WEIGHTS",
    "TRANSFORMS",
    "VIRIDIS",
    "WEIGHTS",
    "AdaptiveMesh",
    "AnalysisReport",
    "BorderWarning",
    "Bounds",
    "Canvas",
    "ConstructionErrors",
    "ContextError",
    "DegenerateHandlesError",
    "Foldovers",
    "GLContext",
    "GLUnavailableError",
    "HandleSet",
    "MLSConfig",
    "ReleasedError",
    "StudyResult",
    "TriangleErrors",
    "WarpPipeline",
    "__version__",
    "apply_colormap",
    "color_limits",
    "colorbar",
    "colormaps",
    "construction_errors",
    "data",
    "error_field",
    "error_stats",
    "foldovers",
    "get_context",
    "imread",
    "imwrite",
    "linear_colormap",
    "polyline_segments",
    "rank_constructions",
    "reference",
    "render_construction_errors",
    "render_field",
    "render_handles",
    "render_mesh",
    "render_triangle_errors",
    "render_triangulation",
    "report",
    "run_jobs",
    "study",
    "triangle_errors",
    "warp",
]
