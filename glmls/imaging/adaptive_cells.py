"""The adaptive build's evaluations and cell tests on the GPU: f at each level's new points
(``mls/points.comp.glsl``), kept on the GPU as well, in the order the build numbers its
vertices, so that the cells' test (``warp/adaptive_test.comp.glsl``) reads f where it is,
one invocation per cell, instead of numpy gathering and combining 25 values per cell. The
host gets back four floats a cell; :func:`glmls.imaging.adaptive_patch.estimate_cells` is the
float64 reference.
"""

from __future__ import annotations

import numpy as np

from ..engine.kernel import MLSKernel
from ..engine.passes import evaluate_points
from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import run_1d, set_uniforms
from ..gl.resources import Resources
from .adaptive_patch import error_bound

__all__ = ["GPUCells"]

#: uint32 words per cell in the test's input: 9 node ids, 16 test ids, width, height, 0
#: (the shader's CELL_WORDS, defined from here).
_CELL_WORDS = 28


class GPUCells:
    """:func:`glmls.imaging.adaptive.build_adaptive`'s ``evaluate`` and ``test`` for one
    build, with ``kernel``'s f for an image of ``shape``, the GPU objects ``resources``'s
    (the roles ``adaptive-f``, ``adaptive-cells`` and ``adaptive-tests``)."""

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
        count = len(nodes)
        if count == 0:
            return np.zeros(0), np.zeros(0)
        cells = np.zeros((count, _CELL_WORDS), np.uint32)
        cells[:, :9] = nodes
        cells[:, 9:25] = tests
        cells[:, 25] = np.asarray(width, np.float32).view(np.uint32)
        cells[:, 26] = np.asarray(height, np.float32).view(np.uint32)
        gl, resources = self._gl, self._resources
        with gl.use():
            source = resources.buffer("adaptive-cells", cells.nbytes)
            source.write(cells.tobytes())
            source.bind_to_storage_buffer(bindings.ADAPTIVE_CELLS.index)
            resources.cached("adaptive-f").bind_to_storage_buffer(bindings.ADAPTIVE_F.index)
            out = resources.buffer("adaptive-tests", count * 16)
            out.bind_to_storage_buffer(bindings.ADAPTIVE_TESTS.index)
            program = gl.compute("warp/adaptive_test.comp.glsl", {"CELL_WORDS": _CELL_WORDS})
            set_uniforms(program, {"u_scale": float(self._kernel.scaling.scale)})
            run_1d(program, count, max_groups=gl.limits["max_work_groups_x"])
            gl.mgl.memory_barrier()
            result = np.frombuffer(out.read(size=count * 16), np.float32).reshape(count, 4)
        result = result.astype(np.float64)
        error = error_bound(result[:, 0], result[:, 1])
        if self._bad:
            bad = np.zeros(self.count, bool)
            bad[np.concatenate(self._bad)] = True
            error[bad[nodes].any(axis=1) | bad[tests].any(axis=1)] = np.inf
        return error, result[:, 2]
