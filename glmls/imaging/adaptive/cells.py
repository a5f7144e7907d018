"""The adaptive build's evaluations and cell tests on the GPU: f at each level's new points
(``mls/points.comp.glsl``), kept on the GPU as well, in the order the build numbers its
vertices, so that the cells' test (``adaptive/test.comp.glsl``) reads f where it is,
one invocation per cell, instead of numpy gathering and combining 25 values per cell. Where f
is smooth, that pass also lists the cells that split, and a second pass predicts their
children from their grids (``adaptive/quartic.glsl``): one round trip per level. The
host gets back four floats per cell and child;
:func:`glmls.imaging.adaptive.patch.estimate_cells` and
:func:`~glmls.imaging.adaptive.patch.predict_cells` are the float64 references.
"""

from __future__ import annotations

import math

import numpy as np

from ...engine.kernel import MLSKernel
from ...engine.passes import evaluate_points
from ...gl import bindings
from ...gl.context import GLContext
from ...gl.dispatch import run_1d, set_uniforms
from ...gl.resources import Resources
from ...gl.tables import TABLE_WIDTH, table_rows
from .patch import SAFETY, error_bound

__all__ = [
    "CUSP_REACH",
    "MAX_SMOOTH_ALPHA",
    "PAIR_REACH",
    "SEGMENT_STEP",
    "SMOOTH_REACH",
    "TURN_WIDTHS",
    "GPUCells",
    "known_points",
    "predicted_side",
    "smooth_reach",
    "smooth_weight",
]

#: uint32 words per cell in the test's input table: 9 node ids, 16 test ids, width, height,
#: flags (bit 0: the cell splits untested), the centre's x and y (scaled), 2 unused: whole
#: texels of 4 (the shader's CELL_WORDS, defined from here).
_CELL_WORDS = 32
#: The prediction's indirect dispatch before the test lists any cell: (x, y, z) work groups
#: (0, 0, 1), then the list's length, 0.
_NO_GROUPS = np.array([0, 0, 1, 0], np.uint32).tobytes()

#: A split cell's children are predicted only where no point handle is within this many
#: children's sides of a child's centre: f is not smooth at a handle (its Jacobian there
#: depends on the direction it is approached from), and the quartic through the cell's grid
#: cannot see that. (Measured over five maps at 0.02, 0.05 and 0.25 px, idw alpha 1, 1.5
#: and 2, similarity, affine and the gaussian: 1 side gave the same leaves and errors as 2
#: sides, within 0.96x the tolerance, and a fifth as many evaluations of f near W1's
#: handles; 1/2 side let errors up to 1.28x the tolerance through.)
SMOOTH_REACH = 1.0
#: ... and this many where the power (idw's, or the interpolating factor's) is below 1: f
#: has a cusp at the handles there (at 1 side, an alpha 0.6 map's errors reached 1.9x the
#: tolerance).
CUSP_REACH = 2.0
#: ... nor where idw's power (or the interpolating factor's) is above this: f then turns
#: sharply between the handles' regions, away from them too (at alpha 3 a leaf accepted on
#: its prediction 36 px from the nearest handle missed by 1.27x the tolerance; alpha 2
#: kept every map's errors within the full test's).
MAX_SMOOTH_ALPHA = 2.0
#: Pixels: the test also measures the patches along the segment handles at points at most
#: this far apart (:func:`known_points`): f has a crease all along each.
SEGMENT_STEP = 1.0
#: Pixels: above :data:`MAX_SMOOTH_ALPHA`, the test also measures the patches along the
#: segments between point handles closer than this (:func:`known_points`), the largest
#: leaf's side (8 px mended the one pixel found as well; at alpha 2.5 and 3 the guarantee's
#: maps got 3-19 % more leaves).
PAIR_REACH = 16.0
#: The gaussian's children are predicted only where their side is at most this many times
#: R^2 / D, D the distance between the farthest two neighbouring handles
#: (:func:`predicted_side`): the ratio of two handles' weights changes by e^(2 D x / R^2)
#: along the line through them, so that f turns from one's transformation to the other's
#: within about R^2 / (2 D) px, sharply where R is small against D (a gaussian's far tail),
#: a turn the quartic through a parent's grid cannot see. (Measured over five maps, R = 5 to
#: 30 px, at 0.02 and 0.25 px: 8 px leaves accepted on their prediction erred by 1.85x the
#: tolerance at R^2 / D = 1, 16 px ones by 1.09x at 3.3; at 2, every map kept the errors of
#: the full test.)
TURN_WIDTHS = 2.0


def smooth_weight(kernel: MLSKernel) -> bool:
    """Whether ``kernel``'s f is smooth away from its point handles: idw, or the gaussian
    where no cut makes its weight 0 (no bins), with a power (idw's, or the interpolating
    factor's) of at most :data:`MAX_SMOOTH_ALPHA`; not the weights with a radius (f bends
    sharply where a handle's reach ends) nor with segment handles."""
    config = kernel.config
    support = config.weight_entry.support
    if kernel.segments or support == "radius":
        return False
    power = _power(kernel)
    if power is not None and power > MAX_SMOOTH_ALPHA:
        return False
    return support == "everywhere" or kernel.bins is None


def smooth_reach(kernel: MLSKernel) -> float:
    """How far from a point handle (children's sides from a child's centre) the children
    of ``kernel``'s cells are predicted: :data:`CUSP_REACH` where f has a cusp at the
    handles (a power, idw's or the interpolating factor's, below 1), else
    :data:`SMOOTH_REACH`."""
    power = _power(kernel)
    return CUSP_REACH if power is not None and power < 1.0 else SMOOTH_REACH


def predicted_side(kernel: MLSKernel, shape: tuple[int, int]) -> float:
    """The largest child (its side, pixels) that :class:`GPUCells` predicts for
    ``kernel``'s f on an image of ``shape``: for the gaussian, :data:`TURN_WIDTHS` times
    R^2 / D, D the longest edge of the source handles' Delaunay triangulation (the farthest
    two whose regions meet: f turns between them within about R^2 / (2 D) px); infinite
    for the other weights, and for fewer than two distinct handles."""
    config = kernel.config
    sources = np.asarray(kernel.sources, np.float64)
    if config.weight != "gaussian" or len(np.unique(sources, axis=0)) < 2:
        return math.inf
    radius = config.resolve_radius(shape)
    return TURN_WIDTHS * radius * radius / _farthest_neighbours(sources)


def _farthest_neighbours(points: np.ndarray) -> float:
    """The longest edge of the Delaunay triangulation of ``points`` ((N, 2), at least two
    distinct); the diagonal of their bounding box (no shorter) where qhull finds none
    (fewer than three, or all on one line)."""
    from scipy.spatial import Delaunay, QhullError  # here: scipy.spatial imports slowly

    try:
        simplices = Delaunay(points, qhull_options="QJ").simplices
    except (QhullError, ValueError):
        return float(np.hypot(*np.ptp(points, axis=0)))
    edges = np.concatenate([simplices[:, [0, 1]], simplices[:, [1, 2]], simplices[:, [2, 0]]])
    return float(np.hypot(*(points[edges[:, 0]] - points[edges[:, 1]]).T).max())


def known_points(kernel: MLSKernel, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray] | None:
    """Where the build's test also measures each cell's patch, f there (evaluated once, as
    the GPU has it, for an image of ``shape``): the points that
    :func:`glmls.imaging.adaptive.mesh.build_adaptive`'s ``known`` takes, where f bends more
    sharply than a cell's 16 test points may show. Along the segment handles
    (:data:`SEGMENT_STEP` apart), whatever the weight: f has a crease along each (a segment's
    weight grows as 1 / d at idw alpha 1, where a point's grows as 1 / d^2; the guarantee's
    segment map erred by up to 1.85x the tolerance, at alpha 0.6, 1 and 2). Where the power
    (idw's, or the interpolating factor's) is below 1, the point handles: f has a cusp at
    each (alpha 0.6: 1.53x in 16 px leaves holding one). Above :data:`MAX_SMOOTH_ALPHA`, the
    quarter points of the segments between point handles closer than :data:`PAIR_REACH`: f
    turns from one's transformation to the other's within a pixel or two there (alpha 3:
    1.38x, a 2 px leaf between two handles 3.5 px apart). None where there is none."""
    power = _power(kernel)
    sources = kernel.sources
    parts = [sources] if power is not None and power < 1.0 else []
    parts += _along(kernel.segment_sources, SEGMENT_STEP)
    if power is not None and power > MAX_SMOOTH_ALPHA and len(sources) > 1:
        from scipy.spatial import cKDTree  # here: scipy.spatial takes ~0.3 s to import

        pairs = cKDTree(sources).query_pairs(PAIR_REACH, output_type="ndarray")
        a, b = sources[pairs[:, 0]], sources[pairs[:, 1]]
        parts += [a + t * (b - a) for t in (0.25, 0.5, 0.75)]
    points = np.concatenate(parts) if parts else np.zeros((0, 2))
    if len(points) == 0:
        return None
    values, _ = evaluate_points(kernel, points, with_matrix=False, shape=shape)
    return points, values


def _along(segments: np.ndarray, step: float) -> list[np.ndarray]:
    """Points along each of ``segments`` ((S, 2, 2) end points), both ends and at most
    ``step`` apart."""
    points = []
    for a, b in segments:
        count = max(1, math.ceil(np.hypot(*(b - a)) / step))
        points.append(a + np.linspace(0.0, 1.0, count + 1)[:, None] * (b - a))
    return points


def _power(kernel: MLSKernel) -> float | None:
    """The power of the distance in ``kernel``'s weight, alpha, where it has one (idw's, or
    the interpolating factor's 1 / d^(2 alpha)); None otherwise."""
    config = kernel.config
    return config.alpha if config.weight == "idw" or config.interpolating else None


class GPUCells:
    """:func:`glmls.imaging.adaptive.mesh.build_adaptive`'s ``evaluate`` and ``test`` for one
    build to ``tolerance`` pixels, with ``kernel``'s f for an image of ``shape``, the GPU
    objects ``resources``'s (the buffers ``adaptive-f``, ``adaptive-tests``,
    ``adaptive-split`` and ``adaptive-handles``, the tables ``adaptive-f`` and
    ``adaptive-cells``)."""

    def __init__(
        self,
        gl: GLContext,
        resources: Resources,
        kernel: MLSKernel,
        shape: tuple[int, int],
        tolerance: float,
    ) -> None:
        self._gl = gl
        self._resources = resources
        self._kernel = kernel
        self._shape = shape
        self._tolerance = tolerance
        #: vertices evaluated so far: the next one's id
        self.count = 0
        self._tabled = 0  # of them, those in the table the test reads
        self._bad: list[np.ndarray] = []  # ids of vertices where f is not finite
        #: Whether :meth:`test` predicts split cells' children (f is smooth away from the
        #: handles).
        self.predicts = smooth_weight(kernel)
        #: The largest child :meth:`test` predicts (its side, pixels): the others are tested.
        self.largest_predicted = predicted_side(kernel, shape) if self.predicts else 0.0
        self._handles = 0
        if self.predicts:
            sources = kernel.scaling.to_gpu(np.asarray(kernel.sources, np.float64))
            self._handles = len(sources)
            with gl.use():
                buffer = resources.buffer("adaptive-handles", max(sources.nbytes, 8))
                buffer.write(sources)

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """f at ``points`` ((K, 2) float64), (K, 2) float64; they get the next K ids."""
        n = len(points)
        at = self.count * 8
        # whole rows of the table that the test copies f into (gl.tables.Tables.copy)
        room = table_rows(self.count + n) * TABLE_WIDTH * 8
        with self._gl.use():
            store = self._resources.grown("adaptive-f", room, keep=at)
            f, _ = evaluate_points(
                self._kernel, points, with_matrix=False, shape=self._shape, keep=(store, at)
            )
        if not np.isfinite(f).all():  # one flat pass; rows (axis=1) cost ~10x as much
            self._bad.append(self.count + np.flatnonzero(~np.isfinite(f).all(axis=1)))
        self.count += n
        return f

    def test(
        self,
        nodes: np.ndarray,
        tests: np.ndarray,
        width: np.ndarray,
        height: np.ndarray,
        centres: np.ndarray,
        whole: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(error, stretch) of each cell, (K,), as
        :func:`~glmls.imaging.adaptive.patch.estimate_cells` (ids among those
        :meth:`evaluate` gave; inf and 0 for a cell that splits untested: ``whole``, (K,)
        bool, not tested), and of its four children, (K, 4), as
        :func:`~glmls.imaging.adaptive.patch.predict_cells` where the cell splits (its
        error is above the tolerance, or it is ``whole``) and
        :attr:`predicts`, and no point handle is within :func:`smooth_reach` children's
        sides of a child's centre (``centres`` (K, 2): the cells' centres, pixels) and the
        child's side is at most :attr:`largest_predicted`; an infinite error elsewhere.
        One round trip: the test (and the prediction's pass), then one read."""
        count = len(nodes)
        children = np.full((count, 4), np.inf), np.zeros((count, 4))
        if count == 0:
            return np.zeros(0), np.zeros(0), *children
        result = self._run(nodes, tests, width, height, centres, whole)
        bad = self._touch_bad(nodes, tests)
        error = error_bound(result[:, 0, 0], result[:, 0, 1])
        error[bad] = np.inf
        if self.predicts:
            child = result[:, 1:]
            small = np.maximum(width, height) / 2 <= self.largest_predicted
            predicted = (child[..., 3] > 0.5) & ~bad[:, None] & small[:, None]
            bound = error_bound(child[..., 0].ravel(), child[..., 1].ravel()).reshape(-1, 4)
            children = np.where(predicted, bound, np.inf), np.where(predicted, child[..., 2], 0.0)
        return error, result[:, 0, 2], *children

    def _run(self, nodes, tests, width, height, centres, whole) -> np.ndarray:
        """The test (and prediction) over the cells, (K, 1 or 5, 4) float64: what it wrote."""
        count = len(nodes)
        cells = np.empty((count, _CELL_WORDS), np.uint32)
        cells[:, :9] = nodes
        cells[:, 9:25] = tests
        cells[:, 25] = np.asarray(width, np.float32).view(np.uint32)
        cells[:, 26] = np.asarray(height, np.float32).view(np.uint32)
        cells[:, 27] = whole
        cells[:, 28:30] = self._kernel.scaling.to_gpu(centres).view(np.uint32)
        cells[:, 30:] = 0
        per_cell = 5 if self.predicts else 1
        gl, resources = self._gl, self._resources
        size = count * per_cell * 16
        shader = "adaptive/test.comp.glsl"
        defines = {"CELL_WORDS": _CELL_WORDS, "ADAPTIVE_SAFETY": SAFETY}
        scale = {"u_scale": float(self._kernel.scaling.scale)}
        max_groups = gl.limits["max_work_groups_x"]
        with gl.use():
            tables = resources.tables
            tables.write("adaptive-cells", cells.reshape(-1, 4), bindings.ADAPTIVE_CELLS.index)
            # f at the points evaluated since the last test, into the table
            f = resources.cached("adaptive-f")
            tables.copy("adaptive-f", f, (self._tabled, self.count), 2, bindings.ADAPTIVE_F.index)
            self._tabled = self.count
            out = resources.buffer("adaptive-tests", size)
            out.bind_to_storage_buffer(bindings.ADAPTIVE_TESTS.index)
            if not self.predicts:
                program = gl.compute(shader, defines | {"ADAPTIVE_PREDICT": 0})
                set_uniforms(program, scale)
                run_1d(program, count, max_groups=max_groups)
            else:
                # the prediction's work groups (x, y, z), the list's length, the list
                listed = resources.buffer("adaptive-split", 4 * (count + 4))
                listed.write(_NO_GROUPS)
                listed.bind_to_storage_buffer(bindings.ADAPTIVE_SPLIT.index)
                handles = resources.cached("adaptive-handles")
                handles.bind_to_storage_buffer(bindings.ADAPTIVE_HANDLES.index)
                program = gl.compute(shader, defines | {"ADAPTIVE_PREDICT": 1})
                values = {
                    "u_tolerance": self._tolerance,
                    # the reach is from a child's centre, side / sqrt(2) from the cell's
                    "u_reach": smooth_reach(self._kernel) + math.sqrt(0.5),
                    "u_handles": self._handles,
                }
                set_uniforms(program, scale | values)
                run_1d(program, count, max_groups=max_groups)
                gl.mgl.memory_barrier()  # the list, its size and the tests' zeros first
                program = gl.compute(shader, defines | {"ADAPTIVE_PREDICT": 2})
                set_uniforms(program, scale)
                program.run_indirect(listed)  # one invocation per listed cell
            gl.mgl.memory_barrier()
            result = np.frombuffer(out.read(size=size), np.float32)
        return result.reshape(count, per_cell, 4).astype(np.float64)

    def _touch_bad(self, nodes: np.ndarray, tests: np.ndarray) -> np.ndarray:
        """Which cells have a vertex where f is not finite, (K,) bool."""
        if not self._bad:
            return np.zeros(len(nodes), bool)
        bad = np.zeros(self.count, bool)
        bad[np.concatenate(self._bad)] = True
        return bad[nodes].any(axis=1) | bad[tests].any(axis=1)
