"""The fold rule of the forward methods: where deformed cells overlap, the FIRST cell in
row-major scan order of the source (smaller row, then column) shows, as the paper's marked
pixels keep their colour, in every path of ``quads`` (the compute scan's fused fast, fused,
nearest and interpolated fills, the GL rasterizer, in one band or several) and in ``splat``.
Each is checked against the float64 reference mesh."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import (
    SENTINEL,
    coordinate_image,
    cross,
    folded_case,
    folding_handles,
    reference_mesh,
    smooth_handles,
)

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice

TOL = 0.01  # px: pixel centres closer to an edge may go either way in float32


def containing_cells(f, shape, tol=TOL):
    """For each pixel centre of ``shape``, (first, last): the smallest and largest row-major
    index of the cells of the deformed mesh ``f`` (rows, columns, 2) one of whose triangles
    contains it by more than ``tol`` (-1: none)."""
    height, width = shape
    corners = [f[:-1, :-1], f[:-1, 1:], f[1:, 1:], f[1:, :-1]]
    cells = corners[0].shape[0] * corners[0].shape[1]
    first = np.full(height * width, cells, np.int64)
    last = np.full(height * width, -1, np.int64)
    for tri in ((0, 1, 2), (0, 2, 3)):
        pts = np.stack([corners[k].reshape(-1, 2) for k in tri], axis=1)  # (cells, 3, 2)
        lo = np.maximum(np.ceil(pts.min(axis=1)), 0).astype(np.int64)
        hi = np.minimum(np.floor(pts.max(axis=1)), [width - 1, height - 1]).astype(np.int64)
        nx, ny = np.maximum(hi - lo + 1, 0).T
        which = np.repeat(np.arange(cells), nx * ny)
        local = np.arange(len(which)) - np.repeat(np.cumsum(nx * ny) - nx * ny, nx * ny)
        u = np.stack([lo[which, 0] + local % nx[which], lo[which, 1] + local // nx[which]], -1)
        inside = _inside(pts[which], u.astype(float), tol)
        pixel = u[inside, 1] * width + u[inside, 0]
        np.minimum.at(first, pixel, which[inside])
        np.maximum.at(last, pixel, which[inside])
    first[first == cells] = -1
    return first.reshape(shape), last.reshape(shape)


def _inside(tri, u, tol):
    """Is u inside triangle tri (either orientation) by more than tol? (n, 3, 2), (n, 2)."""
    area = cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    sign = np.where(area < 0, -1.0, 1.0)
    ok = area != 0
    for i in range(3):
        a, b = tri[:, i], tri[:, (i + 1) % 3]
        e = b - a
        length = np.hypot(e[:, 0], e[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            ok &= sign * cross(e, u - a) / length > tol
    return ok


def shown_cells(out, shape, grid, *, linear=False):
    """Row-major index of the cell each output pixel of a coordinate image shows (-1: the
    background): nearest shows a pixel of the cell, linear the interpolated source point."""
    columns = MeshLattice.corners(shape, grid).cells[0]
    if linear:
        covered = out[..., 0] >= 0
        pixel = np.clip(np.floor(out[..., :2] + 0.5), 0, [shape[1] - 1, shape[0] - 1])
    else:
        covered = out[..., 0] != SENTINEL
        pixel = out[..., :2].astype(np.int64)
    cell = pixel.astype(np.int64) // grid
    return np.where(covered, cell[..., 1] * columns + cell[..., 0], -1)


def check_first_rule(cells, f, shape):
    """Every covered pixel strictly inside some cell shows the first such cell, or an earlier
    one within rounding of the pixel: never a later one; and the case is a real test (many
    pixels that a later cell covers too)."""
    first, last = containing_cells(f, shape, TOL)
    loose, _ = containing_cells(f, shape, -TOL)  # the first cell within rounding
    strict = first >= 0
    assert (cells[strict] >= 0).all(), "a pixel inside a cell was not covered"
    assert (cells[strict] <= first[strict]).all(), "a later cell shows where cells fold"
    assert (cells[strict] >= loose[strict]).all()
    assert (strict & (last > first)).sum() > 100


PATHS = [
    ("fused fast", {}, np.uint8, "nearest"),
    ("fused", {"fast_embedded": False}, np.uint8, "nearest"),
    ("nearest", {}, np.uint16, "nearest"),
    ("interpolated", {}, np.float32, "linear"),
    (None, {"compute_quads": False}, np.uint16, "nearest"),  # the GL rasterizer
    (None, {"compute_quads": False, "band_bytes": 4096}, np.uint16, "nearest"),  # in bands
    (None, {"compute_quads": False}, np.float32, "linear"),
]


@pytest.mark.parametrize("grid", [1, 3])
@pytest.mark.parametrize("path, options, dtype, interpolation", PATHS)
def test_quads_show_the_first_cell_where_the_map_folds(
    gl, pipeline, grid, path, options, dtype, interpolation
):
    shape = (90, 120)
    p, q = folding_handles(shape)
    img = coordinate_image(*shape).astype(dtype)  # x, y < 256: uint8 holds them
    linear = interpolation == "linear"
    pipe = pipeline(**options)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape, grid=grid).count > 0
        background = -1 if linear else (255 if dtype == np.uint8 else SENTINEL)
        out = pipe.warp(m, img, grid=grid, interpolation=interpolation, background=background)
        f = reference_mesh(m, shape, grid)
    assert pipe.cells.last_path == path
    if dtype == np.uint8:
        # widened first: NumPy >= 2.5 refuses a uint8 result that cannot hold SENTINEL
        out = np.where(out == 255, SENTINEL, out.astype(np.int64))
    check_first_rule(shown_cells(out, shape, grid, linear=linear), f, shape)


def test_rasterizer_and_compute_scan_agree_on_folds(gl, pipeline):
    """One rule, two ways: drawn in reverse order by the GL rasterizer, atomicMax of the keys
    in the compute scan."""
    shape, p, q = folded_case()
    img = coordinate_image(*shape)
    raster = pipeline(compute_quads=False)
    with glmls.MLS(p, q, ctx=gl) as m:
        for grid in (1, 2):
            scan = m.warp(img, grid=grid, background=SENTINEL)
            drawn = raster.warp(m, img, grid=grid, background=SENTINEL)
            assert (scan == drawn).all(axis=-1).mean() > 0.99


def test_the_first_rule_changes_nothing_where_the_map_does_not_fold(gl, rng, pipeline):
    """Fold-free maps: each pixel shows the one cell containing it, in every path."""
    shape = (64, 80)
    p, q = smooth_handles(shape, rng)
    img = coordinate_image(*shape)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape).count == 0
        f = reference_mesh(m, shape)
        first, last = containing_cells(f, shape)
        assert (first == last).all()
        for options in ({}, {"compute_quads": False}):
            out = pipeline(**options).warp(m, img, background=SENTINEL)
            cells = shown_cells(out, shape, 1)
            inside = first >= 0
            assert (cells[inside] == first[inside]).all()


def test_splat_shows_the_first_source_pixel_landing_on_a_pixel(gl):
    shape = (90, 120)
    p, q = folding_handles(shape)
    img = coordinate_image(*shape)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        out = m.warp(img, method="splat", background=SENTINEL)
        centres = MeshLattice.centres(shape).points().reshape(-1, 2)
        f, _, _ = reference.mls(p, q, centres, m.config, shape=shape)
    target = np.floor(f + 0.5).astype(np.int64)
    keep = (target >= 0).all(axis=1) & (target < [shape[1], shape[0]]).all(axis=1)
    pixel = target[keep, 1] * shape[1] + target[keep, 0]
    source = np.nonzero(keep)[0]  # row-major source index, increasing
    first = np.full(shape[0] * shape[1], -1)
    pixels, index = np.unique(pixel, return_index=True)
    first[pixels] = source[index]
    counts = np.bincount(pixel, minlength=first.size)
    shown = np.where(out[..., 0] != SENTINEL, out[..., 1].astype(int) * shape[1] + out[..., 0], -1)
    many = counts > 1  # pixels more than one source pixel lands on
    assert many.sum() > 100
    assert (shown.ravel()[many] == first[many]).mean() > 0.98  # but rounding ties
