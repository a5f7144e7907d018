"""The numerical analysis of a deformation (section 5 of the paper) and its pictures.

- the MLS error field (eq. 7) and its statistics (eqs. 8, 9): :func:`error_field`,
  :func:`error_stats`;
- reference triangles (eqs. 10, 11): :func:`triangle_errors`;
- the construction error of a deformed image against f: :func:`construction_errors`,
  :func:`rank_constructions`; fold-overs of the mesh: :func:`foldovers`;
- everything at once: :func:`report`; the automatic choice of a configuration: :func:`tune`,
  and over an image set: :func:`study`, in worker processes or on Dask: :func:`run_jobs`;
- pictures drawn on the GPU: :class:`Canvas`, the ``render_*`` functions and the colour maps.
"""

from .canvas import Canvas
from .colormaps import VIRIDIS, apply_colormap, color_limits, colorbar, linear_colormap
from .construction import ConstructionErrors, construction_errors
from .construction_ranking import rank_constructions
from .field import error_field
from .folding import Foldovers, foldovers
from .jobs import run_jobs
from .pictures import (
    render_construction_errors,
    render_field,
    render_handles,
    render_mesh,
    render_triangle_errors,
    render_triangulation,
)
from .reporting import AnalysisReport, report
from .stats import error_stats
from .studies import StudyResult, study
from .triangles import ANGLE_MEASURES, TriangleErrors, triangle_errors
from .tuning import TuneResult, tune

__all__ = [
    "ANGLE_MEASURES",
    "VIRIDIS",
    "AnalysisReport",
    "Canvas",
    "ConstructionErrors",
    "Foldovers",
    "StudyResult",
    "TriangleErrors",
    "TuneResult",
    "apply_colormap",
    "color_limits",
    "colorbar",
    "construction_errors",
    "error_field",
    "error_stats",
    "foldovers",
    "linear_colormap",
    "rank_constructions",
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
    "tune",
]
