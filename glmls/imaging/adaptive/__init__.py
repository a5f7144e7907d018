"""The error-bounded adaptive mesh of ``quads`` (``tolerance=``): a quadtree of cells over the
corner lattice, refined where the piecewise linear mesh would miss f's inverse by more than
the tolerance, each leaf drawn as a fan of triangles whose pixels a Newton step on the leaf's
quadratic patch refines.

- :mod:`.mesh`: the quadtree and its build, level by level (:class:`AdaptiveMesh`,
  :func:`~.mesh.build_adaptive`), the options' checks;
- :mod:`.patch`: a cell's quadratic patch, its error test and the prediction of its children
  in float64 (the references of the GPU's test), and :func:`interpolate`;
- :mod:`.fans`: the leaves' fans of triangles, without cracks between neighbours;
- :mod:`.cells`: the build's evaluations of f, cell tests and predictions on the GPU;
- :mod:`.folds`: where the deformed mesh may cover a pixel more than once;
- :mod:`.scan`: the mesh drawn on the GPU (:class:`AdaptiveScan`, the pipeline's
  ``adaptive``).

Its shaders are in ``glmls/shaders/adaptive/``.
"""

from .mesh import ROOT_STEP, AdaptiveMesh, check_adaptive, check_tolerance, interpolate
from .scan import AdaptiveScan

__all__ = [
    "ROOT_STEP",
    "AdaptiveMesh",
    "AdaptiveScan",
    "check_adaptive",
    "check_tolerance",
    "interpolate",
]
