"""The adaptive build's cell test and children's prediction on the GPU
(``adaptive/test.comp.glsl`` with ``adaptive/quartic.glsl``, through
:class:`glmls.imaging.adaptive.cells.GPUCells`) against their float64 references
:func:`glmls.imaging.adaptive.patch.estimate_cells` and ``predict_cells``, cell by cell, on
every level of real builds; and the pieces they rest on: f's displacements kept on the GPU,
buffers grown with their contents."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import folded_case, jittered_moves, stretched_handles

import glmls
from glmls.analysis.guarantee import guarantee_handles
from glmls.core.mesh import MeshLattice
from glmls.engine import passes
from glmls.gl.dispatch import LOCAL_SIZE
from glmls.gl.resources import Resources
from glmls.imaging.adaptive import cells as adaptive_cells
from glmls.imaging.adaptive.cells import GPUCells, smooth_reach
from glmls.imaging.adaptive.mesh import ROOT_STEP, build_adaptive
from glmls.imaging.adaptive.patch import NODES, TESTS, estimate_cells, predict_cells

SHAPE = (160, 192)

# The GPU works in float32 on f - v about each cell's centre: the errors agree within 0.5 %
# (measured up to 0.2 % on W2's nearly folded 1/4 px cells) plus 1e-5 px, the stretches
# within 1e-4 (measured 1e-5).
RTOL_ERROR, ATOL_ERROR, RTOL_STRETCH = 5e-3, 1e-5, 1e-4


def compare_levels(gl, m, shape, tolerance):
    """Build the mesh with the GPU's test and prediction, checking every level's cells
    against the float64 references on the same f (and the prediction's choice of cells:
    those that split, with no handle near, against the handles' distances); the levels
    compared (their cells), the mesh, and the cells each level predicted."""
    resources = Resources(gl)
    try:
        cells = GPUCells(gl, resources, m.kernel, shape, tolerance)
        fx: list[np.ndarray] = []
        fy: list[np.ndarray] = []
        levels = []
        predicted: list[int] = []

        def evaluate(points):
            f = cells.evaluate(points)
            fx.append(f[:, 0])
            fy.append(f[:, 1])
            return f

        def check(got, want, where):
            finite = np.isfinite(want[where])
            np.testing.assert_array_equal(np.isfinite(got[where]), finite)
            np.testing.assert_allclose(
                got[where][finite], want[where][finite], rtol=RTOL_ERROR, atol=ATOL_ERROR
            )

        def test(nodes, tests, width, height, centres, whole):
            error, stretch, child_error, child_stretch = cells.test(
                nodes, tests, width, height, centres, whole
            )
            f = np.concatenate(fx), np.concatenate(fy)
            want_error, want_stretch = estimate_cells(*f, nodes, tests, width, height)
            # a cell that splits untested is not tested: inf, and a stretch of 0
            assert np.isinf(error[whole]).all() and (stretch[whole] == 0).all()
            check(error, want_error, ~whole)
            np.testing.assert_allclose(stretch[~whole], want_stretch[~whole], rtol=RTOL_STRETCH)
            want_child, want_child_stretch = predict_cells(*f, nodes, tests, width, height)
            # predicted where the cell splits and no handle is within smooth_reach
            # children's sides of a child's centre (clear of float32's rounding at both)
            handles = m.kernel.sources
            near = np.hypot(*(centres[:, None] - handles[None]).transpose(2, 0, 1)).min(1)
            reach = (smooth_reach(m.kernel) + np.sqrt(0.5)) * np.maximum(width, height) / 2
            splits = whole | (want_error > tolerance * (1 + 1e-3))
            stays = ~whole & (want_error < tolerance * (1 - 1e-3))
            clear = near > reach * (1 + 1e-4)
            # a cell within float32's rounding of the tolerance splits where the GPU's test
            # says it does: its children are then predicted as on the host
            borderline = ~whole & ~splits & ~stays & clear & np.isfinite(child_error).any(1)
            far = (splits & clear) | borderline
            assert np.isinf(child_error[stays | (near < reach * (1 - 1e-4))]).all()
            check(child_error, want_child, far)
            np.testing.assert_allclose(
                child_stretch[far], want_child_stretch[far], rtol=RTOL_STRETCH
            )
            levels.append(len(nodes))
            predicted.append(int(far.sum()))
            want_child[~far] = np.inf  # the build goes on as the GPU's would
            near_tolerance = ~whole & ~splits & ~stays
            want_error[near_tolerance] = error[near_tolerance]
            return want_error, want_stretch, want_child, want_child_stretch

        lattice = MeshLattice.corners(shape, ROOT_STEP)
        mesh = build_adaptive(evaluate, lattice, tolerance, test=test)
        assert sum(predicted) > 0  # some cells far enough from the handles
        assert cells.count == sum(len(f) for f in fx)
        return levels, mesh, predicted
    finally:
        resources.release()


@pytest.mark.parametrize("case", ["stretched", "random", "folded", "cusp"])
def test_the_gpu_cell_test_matches_the_float64_reference(gl, rng, case):
    shape, options = SHAPE, {}
    if case == "stretched":
        p, q = stretched_handles(shape)
    elif case in ("random", "cusp"):
        p, q = jittered_moves(shape, rng)
        if case == "cusp":  # idw alpha < 1: the prediction keeps CUSP_REACH from handles
            options = {"alpha": 0.6}
    else:
        shape, p, q = folded_case()
    with glmls.MLS(p, q, shape=shape, ctx=gl, **options) as m:
        levels, mesh, _ = compare_levels(gl, m, shape, 0.05)
    # the cases reach small cells (several levels), and "folded" has folding leaves
    assert len(levels) >= 3
    if case == "folded":
        assert np.isinf(mesh.estimate).any()


def test_the_prediction_covers_a_list_of_several_work_groups(gl, rng):
    """The prediction pass runs one invocation per listed cell, in as many work groups as the
    test pass found it needs (an indirect dispatch): a level listing many groups' worth of
    cells has each predicted as the float64 reference predicts it."""
    shape = (448, 512)
    p, q = jittered_moves(shape, rng)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        _, _, predicted = compare_levels(gl, m, shape, 0.05)
    assert max(predicted) > 2 * LOCAL_SIZE


def test_the_warp_builds_the_mesh_the_reference_test_builds(gl, rng):
    """The pipeline (the GPU's test) and the float64 test split the same cells here: no
    cell's error is within the GPU's rounding of the tolerance but one, which the reference
    build splits as the GPU does (:func:`compare_levels`)."""
    p, q = jittered_moves(SHAPE, rng)
    with glmls.MLS(p, q, shape=SHAPE, ctx=gl) as m:
        _, want, _ = compare_levels(gl, m, SHAPE, 0.05)
        got = m.mesh(SHAPE, tolerance=0.05)
    np.testing.assert_array_equal(got.leaves, want.leaves)
    np.testing.assert_array_equal(got.triangles, want.triangles)
    finite = np.isfinite(want.estimate)
    np.testing.assert_array_equal(np.isfinite(got.estimate), finite)
    np.testing.assert_allclose(
        got.estimate[finite], want.estimate[finite], rtol=RTOL_ERROR, atol=ATOL_ERROR
    )


def test_cells_with_a_vertex_where_f_is_not_finite_have_an_infinite_error(gl, rng, monkeypatch):
    real = passes.evaluate_points

    def broken(kernel, points, **options):
        f, m = real(kernel, points, **options)
        f[5] = np.nan  # the 6th point of every call
        return f, m

    monkeypatch.setattr(adaptive_cells, "evaluate_points", broken)
    p, q = jittered_moves(SHAPE, rng)
    resources = Resources(gl)
    try:
        with glmls.MLS(p, q, shape=SHAPE, ctx=gl) as m:
            cells = GPUCells(gl, resources, m.kernel, SHAPE, 0.05)
            # a 7 x 7 lattice of points far from the handles (point 5 broken), and the nine
            # cells whose 5 x 5 grids it holds: their children predicted, but for those
            # that touch point 5
            lattice = np.stack(np.meshgrid(np.arange(7.0), np.arange(7.0)), -1).reshape(-1, 2)
            f = cells.evaluate(1000 + 2 * lattice)
            rows, cols = np.divmod(np.arange(9), 3)
            ids = np.array(
                [
                    [7 * (a + r) + b + c for r, c in NODES + TESTS]
                    for a, b in zip(rows, cols, strict=True)
                ]
            )
            nodes, tests = ids[:, :9], ids[:, 9:]
            size = np.full(9, 8.0)
            centres = 1000 + 2 * np.stack([cols + 2, rows + 2], -1).astype(float)
            # tested (their own error), then split untested (their children predicted)
            error, *_ = cells.test(nodes, tests, size, size, centres, np.zeros(9, bool))
            *_, child_error, _ = cells.test(nodes, tests, size, size, centres, size > 0)
    finally:
        resources.release()
    assert np.isnan(f[5]).all()
    touched = (nodes == 5).any(axis=1) | (tests == 5).any(axis=1)
    assert touched.any() and not touched.all()
    assert np.isinf(error[touched]).all() and np.isfinite(error[~touched]).all()
    assert np.isinf(child_error[touched]).all() and np.isfinite(child_error[~touched]).all()
    want, _ = estimate_cells(f[:, 0], f[:, 1], nodes, tests, size, size)
    assert np.isinf(want[touched]).all()


def test_evaluate_points_keeps_the_displacements_on_the_gpu(gl, rng):
    p, q = jittered_moves(SHAPE, rng)
    points = rng.uniform(0, 150, (100, 2))
    resources = Resources(gl)
    try:
        with glmls.MLS(p, q, shape=SHAPE, ctx=gl) as m, gl.use():
            store = resources.buffer("kept", 1024 + 100 * 8)
            store.write(b"\x07" * 1024)
            f, _ = passes.evaluate_points(m.kernel, points, with_matrix=False, keep=(store, 1024))
            kept = np.frombuffer(store.read(size=100 * 8, offset=1024), np.float32)
            before = store.read(size=1024)
            scale = m.kernel.scaling.scale
            for wrong in (1028, 1032):  # not at a point's place; past the buffer's end
                with pytest.raises(ValueError, match="do not fit"):
                    passes.evaluate_points(m.kernel, points, with_matrix=False, keep=(store, wrong))
            assert gl.mgl.error == "GL_NO_ERROR"
    finally:
        resources.release()
    assert before == b"\x07" * 1024  # nothing before the offset is touched
    displacements = kept.reshape(-1, 2).astype(np.float64)
    np.testing.assert_allclose(points + displacements * scale, f, rtol=0, atol=1e-12)


def test_a_grown_buffer_keeps_what_it_held(gl):
    resources = Resources(gl)
    try:
        with gl.use():
            small = resources.grown("b", 64, keep=0)
            small.write(bytes(range(64)))
            old_size = small.size
            same = resources.grown("b", 32, keep=64)
            assert same is small
            big = resources.grown("b", 100, keep=48)
            assert big.size >= 2 * old_size  # doubles, so few copies over many steps
            assert big.read(size=48) == bytes(range(48))
    finally:
        resources.release()


@pytest.mark.parametrize(
    ("options", "smooth"),
    [
        ({}, True),
        ({"alpha": 0.6, "interpolating": True}, True),
        ({"alpha": 2.0}, True),
        ({"alpha": 2.5}, False),  # f turns sharply between the handles' regions
        ({"weight": "gaussian", "radius": 30.0, "bins": False, "interpolating": True}, True),
        ({"weight": "gaussian", "bins": False, "interpolating": True, "alpha": 3.0}, False),
        ({"weight": "gaussian", "radius": 30.0, "bins": False}, True),
        ({"weight": "gaussian", "radius": 30.0, "bins": True}, False),  # cut: f jumps
        ({"weight": "cressman", "radius": 40.0}, False),  # f bends where a reach ends
        ({"weight": "shepard", "radius": 40.0}, False),
        ({"weight": "linear", "radius": 40.0}, False),
        ({"segments": True}, False),
    ],
)
def test_children_are_predicted_only_where_f_is_smooth(gl, rng, options, smooth):
    """The prediction is trusted for idw and the uncut gaussian without segment handles,
    with a power of at most MAX_SMOOTH_ALPHA; elsewhere every child of a split cell is
    tested (its predicted error is infinite)."""
    p, q = jittered_moves(SHAPE, rng)
    options = dict(options)
    if options.pop("segments", False):
        segment = np.array([[[40.0, 80.0], [150.0, 90.0]]])
        options.update(src_segments=segment, dst_segments=segment + [[[0.0, 6.0], [4.0, -3.0]]])
    resources = Resources(gl)
    try:
        with glmls.MLS(p, q, shape=SHAPE, ctx=gl, **options) as m:
            cells = GPUCells(gl, resources, m.kernel, SHAPE, 0.05)
            assert adaptive_cells.smooth_weight(m.kernel) is smooth
            assert cells.predicts is smooth
            # a cell far from every handle, on an affine f: its children exact
            error = far_cell_children(cells, 8.0)
            assert bool(np.isfinite(error).all()) is smooth  # else every child tested
    finally:
        resources.release()


def far_cell_children(cells: GPUCells, side: float) -> np.ndarray:
    """The children's predicted errors (1, 4) of a split cell of ``side`` px at (1000, 1000),
    far from every handle, tested by ``cells`` from its 5 x 5 grid."""
    lattice = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(25, 2)
    cells.evaluate(1000 + side / 4 * lattice)
    place = np.array([5 * r + c for r, c in NODES + TESTS])
    nodes, tests = place[None, :9], place[None, 9:]
    size, centres = np.full(1, side), np.full((1, 2), 1000.0 + side / 2)
    _, _, error, _ = cells.test(nodes, tests, size, size, centres, np.ones(1, bool))
    return error


@pytest.mark.parametrize(
    ("options", "reach"),
    [
        ({}, adaptive_cells.SMOOTH_REACH),
        ({"alpha": 1.5}, adaptive_cells.SMOOTH_REACH),
        ({"alpha": 0.6}, adaptive_cells.CUSP_REACH),  # a cusp at each handle
        ({"alpha": 0.6, "weight": "gaussian", "radius": 30.0, "bins": False}, 1.0),
        ({"alpha": 0.6, "weight": "gaussian", "radius": 30.0, "interpolating": True}, 2.0),
    ],
)
def test_the_prediction_keeps_further_from_the_handles_where_f_has_a_cusp(rng, options, reach):
    p, q = jittered_moves(SHAPE, rng)
    with glmls.MLS(p, q, shape=SHAPE, **options) as m:
        assert adaptive_cells.smooth_reach(m.kernel) == reach
    assert adaptive_cells.SMOOTH_REACH < adaptive_cells.CUSP_REACH


@pytest.mark.parametrize(("radius", "predicted"), [(12.0, False), (60.0, True)])
def test_the_gaussian_predicts_only_children_smaller_than_its_turns(gl, radius, predicted):
    """Where the gaussian's radius is small against the distance between neighbouring
    handles, f turns from one's transformation to the other's within a few pixels: a 16 px
    child is tested, whatever its prediction (R = 12 against handles 70-150 px apart), and
    predicted where R is large (60)."""
    p, q = guarantee_handles("smooth").values()
    options = {"weight": "gaussian", "radius": radius, "bins": False}
    resources = Resources(gl)
    try:
        with glmls.MLS(p, q, shape=SHAPE, ctx=gl, **options) as m:
            cells = GPUCells(gl, resources, m.kernel, SHAPE, 0.05)
            assert cells.predicts
            side = adaptive_cells.predicted_side(m.kernel, SHAPE)
            assert (side >= 16.0) is predicted
            # a 32 px cell far from every handle: its children nearly exact
            assert bool(np.isfinite(far_cell_children(cells, 32.0)).all()) is predicted
    finally:
        resources.release()
