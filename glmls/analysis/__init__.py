"""The numerical analysis of a deformation (section 5 of the paper) and its pictures.

- the MLS error field (eq. 7) and its statistics (eqs. 8, 9): :func:`error_field`,
  :func:`error_stats`;
- reference triangles (eqs. 10, 11): :func:`triangle_errors`;
- the construction error of a deformed image against f: :func:`construction_errors`,
  :func:`rank_constructions`; fold-overs of the mesh: :func:`foldovers`;
- everything at once: :func:`report`; the automatic choice of a configuration: :func:`tune`,
  and over an image set: :func:`study`, in worker processes or on Dask: :func:`run_jobs`;
- pictures drawn on the GPU: :class:`Canvas`, the ``render_*`` functions and the colour maps;
- in 3D, for volumes and (N, 3) handles: the error field :func:`volume_error_field`,
  reference tetrahedra :func:`tetrahedron_errors`, det J and folds per cell
  :func:`cell_jacobians`, pictures :func:`render_volume_slices`, everything at once
  :func:`volume_report`; :class:`ReferenceDeformation` computes f in float64 on the CPU.
"""

from .canvas import Canvas
from .colormaps import (
    LEAST_SPANS,
    VIRIDIS,
    apply_colormap,
    color_limits,
    colorbar,
    linear_colormap,
    picture_limits,
)
from .construction import ConstructionErrors, construction_errors
from .construction_ranking import rank_constructions
from .field import error_field
from .folding import Foldovers, foldovers
from .jacobians import CellJacobians, cell_jacobians
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
from .tetrahedra import (
    SLIVER_QUALITY,
    TetrahedronErrors,
    delaunay3,
    tetrahedron_errors,
    tetrahedron_quality,
)
from .triangles import ANGLE_MEASURES, TriangleErrors, triangle_errors
from .tuning import TuneResult, tune
from .volume_field import ReferenceDeformation, volume_error_field
from .volume_pictures import render_volume_slices
from .volume_reporting import VolumeReport, volume_report

__all__ = [
    "ANGLE_MEASURES",
    "LEAST_SPANS",
    "SLIVER_QUALITY",
    "VIRIDIS",
    "AnalysisReport",
    "Canvas",
    "CellJacobians",
    "ConstructionErrors",
    "Foldovers",
    "ReferenceDeformation",
    "StudyResult",
    "TetrahedronErrors",
    "TriangleErrors",
    "TuneResult",
    "VolumeReport",
    "apply_colormap",
    "cell_jacobians",
    "color_limits",
    "colorbar",
    "construction_errors",
    "delaunay3",
    "error_field",
    "error_stats",
    "foldovers",
    "linear_colormap",
    "picture_limits",
    "rank_constructions",
    "render_construction_errors",
    "render_field",
    "render_handles",
    "render_mesh",
    "render_triangle_errors",
    "render_triangulation",
    "render_volume_slices",
    "report",
    "run_jobs",
    "study",
    "tetrahedron_errors",
    "tetrahedron_quality",
    "triangle_errors",
    "tune",
    "volume_error_field",
    "volume_report",
]
