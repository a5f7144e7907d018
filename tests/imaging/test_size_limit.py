"""Images exactly as large as the GL limit in one dimension (the pipeline's ``max_image_size``,
the smaller of GL_MAX_TEXTURE_SIZE and GL_MAX_VIEWPORT_DIMS, queried from the context: 16384
on llvmpipe): the mesh of pixel corners has one vertex more than that along the side. Every
method, grid, interpolation, border mode and canvas gives what it gives at smaller sizes, the
identity the input exactly; one pixel more is refused before any work. Thin images only (a few
rows or columns), so that the file stays fast on llvmpipe; ``limit - 1`` is the control."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SENTINEL, coordinate_image, reference_mesh
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice
from glmls.imaging.frame import Frame, border_margin
from glmls.imaging.pipeline import WarpPipeline

NO_HANDLES = np.zeros((0, 2))
#: (rows, columns) with None for the limit: a row, a column, a band of three each way.
THIN = [(1, None), (None, 1), (3, None), (None, 3)]
#: Every method and the grids it takes.
METHOD_GRIDS = [
    (method, grid)
    for method in glmls.METHODS
    for grid in (1, 4)
    if not (method == "paper-quads" and grid != 1)
]


@pytest.fixture(scope="module")
def limit(gl) -> int:
    """The largest image side the context warps (queried, never assumed)."""
    return WarpPipeline.of(gl).max_image_size


def sized(spec, limit, less=0):
    """The shape ``spec`` with None replaced by ``limit - less``."""
    return tuple(limit - less if n is None else n for n in spec)


def ramp(shape):
    """uint8 pixels that differ along the long side (no two neighbours equal)."""
    return (np.arange(shape[0] * shape[1]) % 251).astype(np.uint8).reshape(shape)


def _takes(method, shape):
    """paper-quads fills squares of four adjacent pixel centres: an image of one row or
    column has none, at any size (not a limit of the GL)."""
    return method != "paper-quads" or min(shape) > 1


@pytest.mark.parametrize("less", [0, 1], ids=["limit", "limit-1"])
@pytest.mark.parametrize("spec", THIN, ids=str)
@pytest.mark.parametrize(("method", "grid"), METHOD_GRIDS)
def test_identity_gives_the_input_exactly(gl, limit, method, grid, spec, less):
    shape = sized(spec, limit, less)
    image = ramp(shape)
    if not _takes(method, shape):  # refused, never an image of background
        with pytest.raises(ValueError, match="squares of four adjacent pixel centres"):
            glmls.warp(image, NO_HANDLES, NO_HANDLES, method=method, grid=grid, ctx=gl)
        return
    out = glmls.warp(image, NO_HANDLES, NO_HANDLES, method=method, grid=grid, ctx=gl)
    assert_array_equal(out, image)


@pytest.mark.parametrize("spec", [(3, None), (None, 3)], ids=str)
@pytest.mark.parametrize(
    "options",
    [
        {"method": "quads", "interpolation": "linear"},
        {"method": "quads", "grid": 4, "interpolation": "linear"},
        {"method": "backward", "interpolation": "linear"},
        {"method": "paper-quads", "interpolation": "linear"},
        {"method": "quads", "tolerance": 0.05},
    ],
    ids=str,
)
def test_identity_linear_and_adaptive(gl, limit, spec, options):
    image = np.dstack([ramp(sized(spec, limit))] * 3)  # RGB: the fused paths' texels too
    out = glmls.warp(image, NO_HANDLES, NO_HANDLES, ctx=gl, **options)
    assert_array_equal(out, image)


@pytest.mark.parametrize("spec", [(3, None), (None, 3)], ids=str)
@pytest.mark.parametrize("grid", [3, 4])
@pytest.mark.parametrize("path", ["compute scan", "rasterizer", "batch"])
def test_linear_identity_of_a_float_image_at_the_limit(gl, limit, pipeline, spec, grid, path):
    """Linear quads of a float32 image, which the GL filters in float: a source point off
    by a rounding at the limit's magnitude (0.001 px at 16384, 0.002 px at 32768) shows
    where the ramp jumps from 250 to 0, as a quarter of a level here (and as one level of
    an 8-bit image on a GPU whose filter rounds its weights to 1/256). The fills take the
    offset in the cell, a few pixels, and add the cell's exact corner."""
    shape = sized(spec, limit)
    image = ramp(shape).astype(np.float32)
    options = {"grid": grid, "interpolation": "linear"}
    if path == "batch":
        images = np.stack([image, image[::-1]])  # the GPU's batched fill
        # one handle that stays, at the centre of the scaled coordinates: f is the identity
        centre = np.array([[[(shape[1] - 1) / 2, (shape[0] - 1) / 2]]] * 2)
        out = glmls.warp_batch(images, centre, centre, **options)
        assert_allclose(out, images, rtol=0, atol=1e-3)
        return
    pipe = pipeline(compute_quads=path == "compute scan")
    with glmls.MLS(NO_HANDLES, NO_HANDLES, shape=shape, ctx=gl) as m:
        out = pipe.warp(m, image, **options)
    assert pipe.cells.last_path == ("interpolated" if path == "compute scan" else None)
    # a bilinear weight below 1e-6 (float32 noise of an offset of a few pixels) is no error
    assert_allclose(out, image, rtol=0, atol=1e-3)


def _padded(image, origin, shape, mode):
    """numpy.pad's extension of ``image`` seen through the canvas ``shape`` at ``origin``."""
    reach = 16
    pad = ((reach, reach), (reach, reach))
    padded = np.pad(image, pad) if mode == "constant" else np.pad(image, pad, mode=mode)
    top, left = origin[1] + reach, origin[0] + reach
    return padded[top : top + shape[0], left : left + shape[1]]


@pytest.mark.parametrize(
    ("method", "grid", "mode"),
    [(method, grid, "reflect") for method, grid in METHOD_GRIDS]
    + [("quads", 1, mode) for mode in ("constant", "edge", "symmetric", "wrap")],
)
def test_a_canvas_at_the_limit_with_a_border_mode_is_numpy_pad(gl, limit, method, grid, mode):
    """The identity on a canvas as wide as the limit, shifted past the image's left end: the
    forward methods' mesh then reaches past the image (more vertices than the limit)."""
    image = ramp((3, limit))
    origin, shape = (-5, -1), (4, limit)
    out = glmls.warp(
        image,
        NO_HANDLES,
        NO_HANDLES,
        method=method,
        grid=grid,
        border=mode,
        output_shape=shape,
        origin=origin,
        ctx=gl,
    )
    assert_array_equal(out, _padded(image, origin, shape, mode))


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_column_at_the_limit_with_a_border_mode(gl, limit, method):
    """The same down a column: the mesh's rows in bands no taller than a texture."""
    image = ramp((limit, 2))
    origin, shape = (-1, -7), (limit, 4)
    out = glmls.warp(
        image,
        NO_HANDLES,
        NO_HANDLES,
        method=method,
        border="edge",
        output_shape=shape,
        origin=origin,
        ctx=gl,
    )
    assert_array_equal(out, _padded(image, origin, shape, "edge"))


def test_an_image_on_a_canvas_as_large_as_the_limit(gl, limit):
    image = ramp((3, 40))
    out = glmls.warp(image, NO_HANDLES, NO_HANDLES, output_shape=(3, limit), ctx=gl)
    assert_array_equal(out[:, :40], image)
    assert not out[:, 40:].any()


def along(shape):
    """Handles beside a thin image, moved along its long side only: f keeps each pixel in
    its row (column), stretches and squeezes it along the side by up to ~0.5 %."""
    height, width = shape
    long = max(height, width)
    t = np.array([0.1, 0.35, 0.6, 0.85]) * long
    off = np.array([-50.0, 60.0, -40.0, 55.0])
    move = np.array([30.0, -25.0, 35.0, -20.0])
    if width >= height:
        p = np.stack([t, off], axis=1)
        q = p + np.stack([move, np.zeros(4)], axis=1)
    else:
        p = np.stack([off, t], axis=1)
        q = p + np.stack([np.zeros(4), move], axis=1)
    return p, q


@pytest.mark.parametrize("less", [0, 1], ids=["limit", "limit-1"])
@pytest.mark.parametrize("spec", [(3, None), (None, 3)], ids=str)
@pytest.mark.parametrize(
    ("method", "options"),
    [
        ("quads", {}),
        ("quads", {"grid": 4}),
        ("quads", {"tolerance": 0.05}),
        ("splat", {}),
        ("backward", {}),
        ("backward", {"grid": 4}),
        ("paper-quads", {}),
    ],
    ids=str,
)
def test_a_map_agrees_with_the_float64_reference(gl, limit, spec, less, method, options):
    """|f(s) - u| for the source pixel s each output pixel u shows (f in float64), within
    the bounds tests/imaging/test_methods.py holds at 96 x 128."""
    shape = sized(spec, limit, less)
    p, q = along(shape)
    image = coordinate_image(*shape)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        out = m.warp(image, method=method, background=SENTINEL, **options)
    covered = out[..., 0] != SENTINEL
    # paper-quads' squares of pixel centres reach the image's outer centres only up to
    # float32 noise: of three rows (columns) the middle one is inside
    inside = covered[1:-1, 1:-1] if method == "paper-quads" else covered
    assert inside.mean() > 0.97
    s = out[covered][:, :2].astype(float)
    u = np.argwhere(covered)[:, ::-1].astype(float)
    f, _, _ = reference.mls(p, q, s, m.config, shape=shape)
    d = np.linalg.norm(f - u, axis=1)
    assert np.median(d) < 0.45
    assert np.percentile(d, 99) < 0.8


@pytest.mark.parametrize("spec", [(3, None), (None, 3)], ids=str)
@pytest.mark.parametrize("grid", [1, 4])
def test_coordinate_map_is_f_inverse(gl, limit, spec, grid):
    shape = sized(spec, limit)
    p, q = along(shape)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        xy, res = m.coordinate_map(shape, grid=grid, residual=True)
    u = np.stack(np.meshgrid(np.arange(shape[1]), np.arange(shape[0])), -1).reshape(-1, 2)
    inside = np.isfinite(res.ravel())
    assert inside.mean() > 0.99  # the few pixels whose preimage is off the image
    f, _, _ = reference.mls(p, q, xy.reshape(-1, 2)[inside].astype(float), m.config, shape=shape)
    # Newton stops at 1e-3 px; float32 resolves coordinates of the limit's size to 2^-23 of
    # them (1e-3 px at 16384)
    ulp = limit * 2.0**-22
    assert_allclose(f, u[inside], rtol=0, atol=2e-3 + ulp)
    with glmls.MLS(NO_HANDLES, NO_HANDLES, shape=shape, ctx=gl) as identity:
        xy = identity.coordinate_map(shape, grid=grid)
    assert_allclose(xy.reshape(-1, 2), u, rtol=0, atol=ulp)


@pytest.mark.parametrize("spec", [(3, None), (None, 3)], ids=str)
def test_mesh_bounds_and_error_field(gl, limit, spec):
    shape = sized(spec, limit)
    p, q = along(shape)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        vertices, deformed = m.mesh(shape)
        coarse = m.mesh(shape, grid=4)[1]
        bounds = m.bounds(shape)
        field = m.error_field(shape)
        coarse_field = m.error_field(shape, grid=4)
    assert vertices.shape == deformed.shape == (shape[0] + 1, shape[1] + 1, 2)
    assert_allclose(deformed, reference_mesh(m, shape), rtol=0, atol=4e-3)
    assert_allclose(coarse, reference_mesh(m, shape, 4), rtol=0, atol=4e-3)
    low, high = deformed.reshape(-1, 2).min(axis=0), deformed.reshape(-1, 2).max(axis=0)
    assert_allclose([bounds.x0, bounds.y0], low, atol=1e-3)
    assert_allclose([bounds.x1, bounds.y1], high, atol=1e-3)
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    centres = np.stack([xx.ravel(), yy.ravel()], 1).astype(float)
    expected = reference.mls_error(p, q, centres, m.config, shape=shape).reshape(shape)
    assert field.shape == coarse_field.shape == shape
    assert_allclose(field, expected, rtol=1e-4, atol=1e-4)
    assert_allclose(coarse_field, expected, rtol=0.02, atol=1e-2)  # interpolated


@pytest.mark.parametrize("method", glmls.METHODS)
def test_one_pixel_past_the_limit_is_refused_before_any_work(gl, limit, method):
    for shape in ((1, limit + 1), (limit + 1, 1)):
        with pytest.raises(ValueError, match=str(limit)):
            glmls.warp(ramp(shape), NO_HANDLES, NO_HANDLES, method=method, ctx=gl)
    with pytest.raises(ValueError, match=rf"\(1, {limit + 1}\).*{limit}"):
        glmls.warp(ramp((1, 8)), NO_HANDLES, NO_HANDLES, output_shape=(1, limit + 1), ctx=gl)
    with glmls.MLS(NO_HANDLES, NO_HANDLES, ctx=gl) as m:
        with pytest.raises(ValueError, match=str(limit)):
            m.coordinate_map((limit + 1, 2))
        with pytest.raises(ValueError, match=str(limit)):
            m.bounds((2, limit + 1))


def test_border_margin_of_a_long_thin_image(gl, limit):
    """The border modes' search for the mesh's reach past the image is sized for the
    image's own aspect: a canvas 20 px past the end of a long thin image is reached."""
    shape = (3, limit)
    with glmls.MLS(NO_HANDLES, NO_HANDLES, shape=shape, ctx=gl) as m:
        lattice = MeshLattice.corners(shape)
        margin = border_margin(m.kernel, lattice, Frame((3, 40), (limit - 20.0, 0.0)))
    assert 20 <= margin <= 64


def test_an_analysis_canvas_at_the_limit(gl, limit):
    """The pictures' canvas (renderbuffers drawn through a viewport) at the limit; one
    pixel more refused naming it."""
    image = np.dstack([ramp((3, limit))] * 3)
    with glmls.analysis.Canvas((3, limit), samples=0, ctx=gl) as canvas:
        assert_array_equal(canvas.image(image).read(), image)
    with pytest.raises(ValueError, match=rf"\(3, {limit + 1}\).*{limit}"):
        glmls.analysis.Canvas((3, limit + 1), ctx=gl)


@pytest.mark.parametrize(
    ("interpolation", "first"),
    [
        ("nearest", [0, 200, 0, 0, 0, 0, 0, 0, 200]),  # pixel k shows source pixel k - 1
        ("linear", [0, 100, 0, 0, 0, 0, 0, 100, 100]),  # source point k - 0.5
    ],
)
def test_a_mesh_wider_than_a_texture_is_scanned_as_any_other(
    gl, limit, pipeline, interpolation, first
):
    """At grid 1 the corners of an image as wide as the limit are one more than a texture's
    row: the scan reads them from the mesh buffer, not the rasterizer, whose tie rule
    differs. A translation by half a pixel puts every pixel centre on a cell's edge, where the
    tie rule decides: the pixels are those of limit - 1 and of the batch."""
    row = np.zeros((2, limit), np.uint8)
    row[:, ::7] = 200
    src = np.array([[0.0, 0.0], [100.0, 1.0]])
    dst = src + [0.5, 0.0]
    pipe = pipeline()
    with glmls.MLS(src, dst, ctx=gl) as m:
        out = pipe.warp(m, row, grid=1, interpolation=interpolation)
        assert pipe.cells.last_path is not None  # scan-converted
        shorter = pipe.warp(m, row[:, :-1], grid=1, interpolation=interpolation)
    batch = glmls.warp_batch([row], [src], [dst], grid=1, interpolation=interpolation)[0]
    assert_array_equal(out, batch)
    assert_array_equal(out[:, :1000], shorter[:, :1000])
    assert out[1, :9].tolist() == first  # pixel 0 shows source -0.5: outside
