"""The adaptive build's evaluations and cell tests on the GPU: f at each level's new points
(``mls/points.comp.glsl``), kept on the GPU as well, in the order the build numbers its
vertices, so that the cells' test (``warp/adaptive_test.comp.glsl``) reads f where it is,
one invocation per cell, instead of numpy gathering and combining 25 values per cell. The
host gets back four floats a cell; :func:`glmls.imaging.adaptive_patch.estimate_cells` is the
float64 reference. Likewise the prediction of split cells' children
(``warp/adaptive_predict.comp.glsl``, reference
:func:`glmls.imaging.adaptive_patch.predict_cells`), where f is smooth.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from ..engine.kernel import MLSKernel
from ..engine.passes import evaluate_points
from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import run_1d, set_uniforms
from ..gl.resources import Resources
from .adaptive_patch import error_bound

__all__ = ["SMOOTH_REACH", "GPUCells", "smooth_weight"]

#: uint32 words per cell in the test's input: 9 node ids, 16 test ids, width, height, 0
#: (the shader's CELL_WORDS, defined from here).
_CELL_WORDS = 28

#: A split cell's children are predicted only where no point handle is within this many
#: children's sides of a child's centre: f is not smooth at a handle (idw's weight is
#: infinite there, and f there has a cusp for alpha < 1), and the quartic through the cell's
#: grid cannot see that. (At 1 side, an alpha 0.6 map's errors reached 1.9x the tolerance.)
SMOOTH_REACH = 2.0


def smooth_weight(kernel: MLSKernel) -> bool:
    """Whether ``kernel``'s f is smooth away from its point handles: idw, or the gaussian
    where no cut makes its weight 0 (no bins); not the weights with a radius (f bends
    sharply where a handle's reach ends) nor with segment handles."""
    support = kernel.config.weight_entry.support
    if kernel.segments or support == "radius":
        return False
    return support == "everywhere" or kernel.bins is None


class GPUCells:
    """:func:`glmls.imaging.adaptive.build_adaptive`'s ``evaluate``, ``test`` and
    ``predict`` for one build, with ``kernel``'s f for an image of ``shape``, the GPU
    objects ``resources``'s (the roles ``adaptive-f``, ``adaptive-cells`` and
    ``adaptive-tests``)."""

    def __init__(
        self, gl: GLContext, resources: Resources, kernel: MLSKernel, shape: tuple[int, int]
    ) -> None:
        self._gl = gl
        self._resources = resources
        self._kernel = kernel
        self._shape = shape
        #: vertices evaluated so far: the next one's id
        self.count = 0
        self._bad: list[np.ndarray] = []  # ids of vertices where f is not finite
        #: Whether :meth:`predict` predicts (f is smooth away from the handles).
        self.predicts = smooth_weight(kernel)
        sources = kernel.sources if self.predicts else np.zeros((0, 2))
        self._handles = cKDTree(sources) if len(sources) else None

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """f at ``points`` ((K, 2) float64), (K, 2) float64; they get the next K ids."""
        n = len(points)
        at = self.count * 8
        with self._gl.use():
            store = self._resources.grown("adaptive-f", at + n * 8, keep=at)
            f, _ = evaluate_points(
                self._kernel, points, with_matrix=False, shape=self._shape, keep=(store, at)
            )
        if not np.isfinite(f).all():  # one flat pass; rows (axis=1) cost ~10x as much
            self._bad.append(self.count + np.flatnonzero(~np.isfinite(f).all(axis=1)))
        self.count += n
        return f

    def test(
        self, nodes: np.ndarray, tests: np.ndarray, width: np.ndarray, height: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(error, stretch) of each cell, as :func:`~glmls.imaging.adaptive_patch.estimate_cells`
        (ids among those :meth:`evaluate` gave)."""
        if len(nodes) == 0:
            return np.zeros(0), np.zeros(0)
        result = self._run("warp/adaptive_test.comp.glsl", nodes, tests, width, height, 1)
        error = error_bound(result[:, 0], result[:, 1])
        error[self._touch_bad(nodes, tests)] = np.inf
        return error, result[:, 2]

    def predict(
        self,
        nodes: np.ndarray,
        tests: np.ndarray,
        width: np.ndarray,
        height: np.ndarray,
        centres: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(error, stretch) of the four children of each cell, (K, 4), as
        :func:`~glmls.imaging.adaptive_patch.predict_cells` (``centres`` (K, 2): the
        cells' centres, pixels); the error is infinite where a handle is within
        :data:`SMOOTH_REACH` children's sides of a child's centre, and everywhere unless
        :attr:`predicts`."""
        count = len(nodes)
        error = np.full((count, 4), np.inf)
        stretch = np.zeros((count, 4))
        if not self.predicts or count == 0:
            return error, stretch
        side = np.maximum(width, height) / 2
        # a child's centre is side / sqrt(2) from the cell's
        reach = (SMOOTH_REACH + math.sqrt(0.5)) * side
        far = np.ones(count, bool)
        if self._handles is not None:
            distance, _ = self._handles.query(centres, distance_upper_bound=float(reach.max()))
            far = distance >= reach
        far &= ~self._touch_bad(nodes, tests)
        chosen = np.flatnonzero(far)
        if len(chosen) == 0:
            return error, stretch
        result = self._run(
            "warp/adaptive_predict.comp.glsl",
            nodes[chosen],
            tests[chosen],
            width[chosen],
            height[chosen],
            4,
        ).reshape(len(chosen), 4, 4)
        error[chosen] = error_bound(result[..., 0].ravel(), result[..., 1].ravel()).reshape(-1, 4)
        stretch[chosen] = result[..., 2]
        return error, stretch

    def _run(self, shader, nodes, tests, width, height, per_cell: int) -> np.ndarray:
        """``shader`` over the cells, (K * per_cell, 4) float64: what it wrote, ``per_cell``
        vec4 each."""
        count = len(nodes)
        cells = np.zeros((count, _CELL_WORDS), np.uint32)
        cells[:, :9] = nodes
        cells[:, 9:25] = tests
        cells[:, 25] = np.asarray(width, np.float32).view(np.uint32)
        cells[:, 26] = np.asarray(height, np.float32).view(np.uint32)
        gl, resources = self._gl, self._resources
        size = count * per_cell * 16
        with gl.use():
            source = resources.buffer("adaptive-cells", cells.nbytes)
            source.write(cells.tobytes())
            source.bind_to_storage_buffer(bindings.ADAPTIVE_CELLS.index)
            resources.cached("adaptive-f").bind_to_storage_buffer(bindings.ADAPTIVE_F.index)
            out = resources.buffer("adaptive-tests", size)
            out.bind_to_storage_buffer(bindings.ADAPTIVE_TESTS.index)
            program = gl.compute(shader, {"CELL_WORDS": _CELL_WORDS})
            set_uniforms(program, {"u_scale": float(self._kernel.scaling.scale)})
            run_1d(program, count, max_groups=gl.limits["max_work_groups_x"])
            gl.mgl.memory_barrier()
            result = np.frombuffer(out.read(size=size), np.float32)
        return result.reshape(-1, 4).astype(np.float64)

    def _touch_bad(self, nodes: np.ndarray, tests: np.ndarray) -> np.ndarray:
        """Which cells have a vertex where f is not finite, (K,) bool."""
        if not self._bad:
            return np.zeros(len(nodes), bool)
        bad = np.zeros(self.count, bool)
        bad[np.concatenate(self._bad)] = True
        return bad[nodes].any(axis=1) | bad[tests].any(axis=1)
