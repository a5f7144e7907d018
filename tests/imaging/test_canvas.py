"""The output canvas (``output_shape``, ``origin``) and ``MLS.bounds``: nothing of the deformed
image cut off."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SENTINEL, coordinate_image, reference_mesh, turned_handles

import glmls
from glmls.core.mesh import MeshLattice
from glmls.imaging.frame import Bounds, make_frame
from glmls.imaging.pipeline import WarpPipeline


def push_out(shape, factor=1.3, turn=0.25):
    """Handles pushed away from the centre and turned: the image grows on every side."""
    return turned_handles(shape, factor, turn, inset=0.15)


def seen(out, shape):
    """Which source pixels appear in a warped coordinate image (background SENTINEL)."""
    covered = out[..., 0] != SENTINEL
    hit = np.zeros(shape, bool)
    hit[out[..., 1][covered].astype(int), out[..., 0][covered].astype(int)] = True
    return hit


def similarity(shape, scale, turn, shift=(0.0, 0.0)):
    """Handles all moved by one similarity (scale about the centre, turn, shift): the
    similarity (and affine) MLS is that similarity everywhere."""
    p, _ = push_out(shape, 1.0, 0.0)
    c = np.array([(shape[1] - 1) / 2, (shape[0] - 1) / 2])
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    return p, (p - c) @ rot.T * scale + c + shift


@pytest.mark.parametrize(
    "shape, scale, turn, shift",
    [
        ((40, 60), 1.5, 0.0, (3.0, -7.0)),
        ((64, 48), 1.5, 0.7, (0.0, 0.0)),
        ((30, 30), 2.0, 2.5, (-9.0, 4.0)),
    ],
)
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_bounds_show_every_source_pixel(gl, shape, scale, turn, shift, method):
    """A map that enlarges every pixel square past sqrt(2) px (each then holds a pixel
    centre, whatever its turn): with the bounds' canvas every source pixel appears."""
    image = coordinate_image(*shape)
    p, q = similarity(shape, scale, turn, shift)
    with glmls.MLS(p, q, shape=shape, transform="similarity") as m:
        cut = m.warp(image, method=method, background=SENTINEL)
        b = m.bounds(shape)
        whole = m.warp(
            image, method=method, background=SENTINEL, output_shape=b.output_shape, origin=b.origin
        )
    assert not seen(cut, shape).all()  # the input's frame cuts some off
    assert seen(whole, shape).all()  # every source pixel appears
    assert whole.shape[:2] == b.output_shape
    covered = whole[..., 0] != SENTINEL
    # and the canvas is at most the pixel the box touches larger than what shows
    rows, cols = covered.any(axis=1), covered.any(axis=0)
    for edge in (rows[:2], rows[-2:], cols[:2], cols[-2:]):
        assert edge.any()


@pytest.mark.parametrize(
    "shape, factor, turn", [((40, 60), 1.3, 0.25), ((64, 48), 1.6, -0.6), ((30, 30), 1.2, 1.2)]
)
@pytest.mark.parametrize("method", ["quads", "splat", "backward"])
def test_bounds_cut_nothing_off(gl, shape, factor, turn, method):
    """Any map that pushes the image out: the bounds' canvas shows what a canvas three times
    as large shows, and that one shows nothing outside it."""
    image = coordinate_image(*shape)
    p, q = push_out(shape, factor, turn)
    with glmls.MLS(p, q, shape=shape) as m:
        b = m.bounds(shape)
        whole = m.warp(
            image, method=method, background=SENTINEL, output_shape=b.output_shape, origin=b.origin
        )
        (h, w), (x0, y0) = b.output_shape, b.origin
        big = m.warp(
            image,
            method=method,
            background=SENTINEL,
            output_shape=(3 * h, 3 * w),
            origin=(x0 - w, y0 - h),
        )
    assert b.x0 < -3 and b.y0 < -3 and b.x1 > shape[1] + 2 and b.y1 > shape[0] + 2
    # float32 rounding of f(v) - origin may tip a point on a pixel edge the other way
    differ = (big[h : 2 * h, w : 2 * w] != whole).any(axis=-1)
    assert differ.sum() <= 2
    big[h : 2 * h, w : 2 * w] = SENTINEL
    assert (big == SENTINEL).all()


def test_bounds_match_the_float64_reference(gl, rng):
    shape = (37, 53)
    p, q = push_out(shape, 1.4, 0.5)
    with glmls.MLS(p, q, shape=shape) as m:
        for grid in (1, 4, 7):
            b = m.bounds(shape, grid=grid)
            f = reference_mesh(m, shape, grid).reshape(-1, 2)
            expected = [*f.min(axis=0), *f.max(axis=0)]
            np.testing.assert_allclose([b.x0, b.y0, b.x1, b.y1], expected, atol=2e-3)


def test_bounds_of_the_identity_are_the_image(gl):
    with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2))) as m:
        b = m.bounds((20, 30))
    assert (b.x0, b.y0, b.x1, b.y1) == pytest.approx((-0.5, -0.5, 29.5, 19.5), abs=1e-4)
    assert b.origin == (0.0, 0.0) and b.output_shape == (20, 30)


def test_bounds_in_bands_equal_one_band(gl):
    shape = (90, 70)
    p, q = push_out(shape)
    pipe = WarpPipeline(gl, options=glmls.imaging.options.PipelineOptions(band_bytes=2048))
    try:
        with glmls.MLS(p, q, shape=shape) as m:
            assert pipe.bounds(m, shape) == m.bounds(shape)
    finally:
        pipe.release()


def test_bounds_canvas_rounding():
    b = Bounds(-3.2, 0.5000001, 10.5, 7.0)
    assert b.origin == (-3.0, 1.0)  # pixel -3 holds x -3.2; float32 noise past 0.5 ignored
    assert b.output_shape == (7, 14)  # pixels -3 .. 10 and 1 .. 7
    assert b.frame.shape == (7, 14) and b.frame.origin == (-3.0, 1.0)
    tiny = Bounds(0.2, 0.2, 0.4, 0.4)  # inside one pixel
    assert tiny.output_shape == (1, 1) and tiny.origin == (0.0, 0.0)
    wide = Bounds(-0.51, -0.5, 3.51, 1.5)  # just into pixels -1 and 4
    assert wide.origin == (-1.0, 0.0) and wide.output_shape == (2, 6)


def test_a_canvas_beyond_the_coordinate_range_is_refused():
    widest = Bounds(-0.5, -0.5, 1e6 - 0.5, 1.5)  # pixels 0 .. 999999: sides up to 1e6
    assert widest.output_shape == (2, 1_000_000)
    assert Bounds(999999.4, 0, 999999.45, 1).output_shape == (2, 1)
    for box in (
        (0, 0, 1e308, 10),
        (-1e308, -1e308, 1e308, 1e308),
        (-0.5, -0.5, 1e6 + 0.5, 1.5),  # one pixel wider
        (1e6 + 0.6, 0, 1e6 + 0.7, 1),  # one pixel, beyond the origin's range
    ):
        b = Bounds(*box)
        with pytest.raises(ValueError, match=r"Bounds\(x0=.* beyond glmls's coordinate range"):
            _ = b.output_shape
        with pytest.raises(ValueError, match="coordinate range"):
            _ = b.frame


def test_coordinate_map_on_a_canvas(gl):
    shape = (30, 40)
    p, q = push_out(shape)
    with glmls.MLS(p, q, shape=shape) as m:
        full = m.coordinate_map(shape, output_shape=(60, 80), origin=(-20, -15))
        part = m.coordinate_map(shape)
        f = m(full.reshape(-1, 2)).reshape(full.shape)
    np.testing.assert_allclose(full[15:45, 20:60], part, atol=1e-3)  # Newton's noise
    rows, cols = np.mgrid[0:60, 0:80]
    np.testing.assert_allclose(f, np.stack([cols - 20, rows - 15], -1), atol=0.06)


def test_canvas_larger_than_the_image_with_every_method(gl):
    image = coordinate_image(16, 20)
    with glmls.MLS([[8.0, 8.0]], [[10.0, 7.0]], shape=image.shape) as m:  # shift (2, -1)
        for method in glmls.METHODS:
            out = m.warp(
                image, method=method, output_shape=(30, 40), origin=(-5, -3), background=SENTINEL
            )
            rows, cols = np.mgrid[0:30, 0:40]
            sx, sy = cols - 5 - 2, rows - 3 + 1
            inside = (sx >= 0) & (sx < 20) & (sy >= 0) & (sy < 16)
            np.testing.assert_array_equal(out[..., 0][inside], sx[inside], err_msg=method)
            np.testing.assert_array_equal(out[..., 1][inside], sy[inside], err_msg=method)
            assert (out[..., 0][~inside] == SENTINEL).all(), method


@pytest.mark.parametrize(
    "output_shape, origin, error, match",
    [
        ((0, 10), None, ValueError, "output_shape"),
        ((10, -1), None, ValueError, "output_shape"),
        ((10,), None, ValueError, "output_shape"),
        ((10, 2.5), None, TypeError, "output_shape"),
        ((10, True), None, TypeError, "output_shape"),
        ((10.0, 10), None, TypeError, "output_shape"),
        ("10x10", None, TypeError, "output_shape"),
        (7, None, TypeError, "output_shape"),
        ((10, 1 << 30), None, ValueError, "GL limit"),
        (None, (np.nan, 0), ValueError, "origin"),
        (None, (0, 1e9), ValueError, "origin"),
        (None, (1, 2, 3), ValueError, "origin"),
        (None, ("a", 0), TypeError, "origin"),
        (None, (True, 0), TypeError, "origin"),
        (None, (1j, 0), TypeError, "origin"),
        (None, 5.0, TypeError, "origin"),
    ],
)
def test_bad_canvas(gl, output_shape, origin, error, match):
    with glmls.MLS([[1.0, 1.0]], [[2.0, 2.0]]) as m:
        with pytest.raises(error, match=match):
            m.warp(np.zeros((4, 4), np.uint8), output_shape=output_shape, origin=origin)
        with pytest.raises(error, match=match):
            m.coordinate_map((4, 4), output_shape=output_shape, origin=origin)


def test_canvas_accepts_numpy_values():
    frame = make_frame(np.array([5, 6]), (np.float32(1.5), np.int64(-2)), (3, 3), 100)
    assert frame.shape == (5, 6) and frame.origin == (1.5, -2.0)
    assert make_frame(np.array([5, 6], np.uint16), None, (3, 3), 100).shape == (5, 6)
    assert make_frame((np.array(5), 6), np.array([0.5, 1], np.float16), (3, 3), 100).shape == (5, 6)


def test_lattice_margin():
    lattice = MeshLattice.corners((10, 7), 3, margin=6)
    # with a margin the lattice is regular to its end, past the margin's (12.5, 15.5): its
    # pixel domain reaches there too
    assert lattice.padded_shape == (24, 21) and lattice.offset == (-6, -6)
    assert lattice.origin == (-6.5, -6.5) and lattice.last == (14.5, 17.5)
    assert lattice.dims == (8, 9)
    xs, ys = lattice.axes
    np.testing.assert_array_equal(xs, [-6.5, -3.5, -0.5, 2.5, 5.5, 8.5, 11.5, 14.5])
    assert MeshLattice.corners((10, 7), 3).last == (6.5, 9.5)  # no margin: the image's corner
    assert lattice.pixel_uniforms() == {
        "u_grid": 3,
        "u_lattice_size": (21, 24),
        "u_lattice_offset": (-6, -6),
    }
    ring = lattice.boundary()
    assert len(ring) == 2 * (8 - 1) + 2 * (9 - 1)
    assert len({tuple(r) for r in ring}) == len(ring)
    on_edge = np.isin(ring[:, 0], xs[[0, -1]]) | np.isin(ring[:, 1], ys[[0, -1]])
    assert on_edge.all()
    cells = np.zeros(lattice.cells[::-1], bool)
    cells[2, 2] = True  # the cell from (-0.5, -0.5): the image's pixels 0..2
    mask = lattice.cell_mask(cells)
    assert mask.shape == (10, 7) and mask[:3, :3].all() and mask.sum() == 9
    centres = MeshLattice.centres((4, 5), margin=2)
    assert centres.origin == (-2.0, -2.0) and centres.last == (6.0, 5.0)
    assert centres.dims == (9, 8)
    refused = ((-1, ValueError), (1.5, TypeError), (True, TypeError), (1 << 30, ValueError))
    for bad, error in refused:
        with pytest.raises(error, match="margin"):
            MeshLattice.corners((4, 4), 1, margin=bad)


def test_bounds_refuse_shapes_past_the_gl_limit(gl):
    with glmls.MLS([[1.0, 1.0]], [[2.0, 2.0]]) as m:
        limit = WarpPipeline.of(gl).max_image_size
        with pytest.raises(ValueError, match="GL texture size limit"):
            m.bounds((limit + 1, 4))
        with pytest.raises(ValueError, match="shape"):
            m.bounds((0, 4))


@pytest.mark.parametrize("border", ["edge", "symmetric", "reflect", "wrap"])
@pytest.mark.parametrize("batched", [False, True])
def test_border_cells_do_not_depend_on_the_canvas(gl, border, batched):
    """The quads' mesh past the image (a margin that grows with the canvas's overhang) is the
    same regular lattice whatever its margin, so a wider canvas cropped back to the image's
    frame shows what the image's own frame shows, where the grid does not divide its sides."""
    rng = np.random.default_rng(0)
    height, width = 23, 27
    image = rng.uniform(0, 255, (height, width)).astype(np.float32)
    src = np.array([[0.0, 0], [width - 1, 0], [0, height - 1], [width - 1, height - 1], [10, 8]])
    centre = np.array([(width - 1) / 2, (height - 1) / 2])
    dst = centre + 0.75 * (src - centre) + rng.uniform(-1, 1, src.shape)
    options = {"transform": "affine", "method": "quads", "interpolation": "linear"}
    options |= {"border": border, "grid": 5, "ctx": gl}
    wide = {"output_shape": (height + 16, width + 16), "origin": (-8.0, -8.0)}
    if batched:
        own = glmls.warp_batch([image], [src], [dst], **options)[0]
        crop = glmls.warp_batch([image], [src], [dst], **options, **wide)[0]
    else:
        own = glmls.warp(image, src, dst, **options)
        crop = glmls.warp(image, src, dst, **options, **wide)
    crop = crop[8 : 8 + height, 8 : 8 + width]
    assert np.abs(own - crop).max() < 0.01  # float32 rounding of the cells' own points


@pytest.mark.parametrize("method", sorted(glmls.METHODS))
def test_two_canvases_show_the_same_pixels_where_they_overlap(gl, method):
    """A canvas over part of another shows its pixels: bit for bit with nearest sampling;
    with linear sampling to float32's rounding of the source points, which each canvas
    places relative to its own origin (a level of a 16-bit image, 1e-5 of a float one)."""
    rng = np.random.default_rng(5)
    image = rng.integers(0, 60000, (40, 50), dtype=np.uint16)
    floats = rng.uniform(0.0, 1.0, (40, 50)).astype(np.float32)
    p = rng.uniform(0, 40, (7, 2))
    q = p + rng.normal(0.0, 2.0, (7, 2))
    with glmls.MLS(p, q) as m:
        for source, linear_tolerance in ((image, 1), (floats, 1e-5)):
            for interpolation, tolerance in (("nearest", 0), ("linear", linear_tolerance)):
                options = {"method": method, "interpolation": interpolation, "border": "reflect"}
                whole = m.warp(source, output_shape=(60, 70), origin=(-5, -5), **options)
                part = m.warp(source, output_shape=(20, 30), origin=(7, 3), **options)
                gap = np.abs(whole[8:28, 12:42].astype(np.float64) - part)
                assert gap.max() <= tolerance, (interpolation, source.dtype, gap.max())


# one handle 60 px above a 37 x 53 image pulled onto its middle: the plane above folds over
# the image, whose own deformed border still encloses the input's frame
PULLED_SRC = np.array([[26.0, -60.0], [0.0, 36.0], [52.0, 36.0], [0.0, 0.0], [52.0, 0.0]])
PULLED_DST = PULLED_SRC.copy()
PULLED_DST[0] = [26.0, 18.0]


@pytest.mark.parametrize("border", ["edge", "wrap", "symmetric"])
@pytest.mark.parametrize(("method", "grid"), [("quads", 1), ("quads", 4), ("backward", 1)])
def test_the_plane_pulled_over_the_canvas_shows_on_every_canvas(gl, border, method, grid):
    """With a border mode the cells beyond the image that f folds over the canvas come
    before the image's in scan order and show on it (the paper's rule on the plane the
    border extends): on the input's frame as on a canvas three times as large, whose own
    margin reaches them. The mesh reaches past the handles that pull the plane over the
    canvas (glmls.imaging.frame.pulled_margins), though the input's frame needs no margin
    for its own border: without them it would show the image's cells on ~370 of its 1,961
    pixels."""
    h, w = 37, 53
    index = np.arange(h * w, dtype=np.uint16).reshape(h, w)  # each pixel its own index
    options = {"border": border, "method": method, "grid": grid}
    with glmls.MLS(PULLED_SRC, PULLED_DST, shape=(h, w), ctx=gl) as m:
        frame = m.warp(index, **options)
        large = m.warp(index, output_shape=(3 * h, 3 * w), origin=(-w, -h), **options)
    np.testing.assert_array_equal(frame, large[h : 2 * h, w : 2 * w])
    if method == "quads":
        batch = glmls.warp_batch(index[None], PULLED_SRC[None], PULLED_DST[None], **options)
        np.testing.assert_array_equal(batch[0], frame)


def test_pulled_margins_per_map():
    """Twice the distance past the image of the handles beyond it whose targets lie over the
    canvas's box (grown by that distance); 0 for a map without one, whatever its count."""
    from glmls.imaging.frame import pulled_margins

    low, high = np.array([0.0, 0.0]), np.array([52.0, 36.0])
    inside = (np.array([[5.0, 5.0]]), np.array([[60.0, 60.0]]))
    pulled = (PULLED_SRC, PULLED_DST)  # 60 px above (59.5 past the pixels' edge), onto it
    away = (np.array([[26.0, -60.0]]), np.array([[26.0, -200.0]]))  # pulled further out
    near = (np.array([[-10.0, 5.0]]), np.array([[-8.0, 5.0]]))  # beside the box, within 9.5
    empty = (np.zeros((0, 2)), np.zeros((0, 2)))
    found = pulled_margins([inside, pulled, away, near, empty], (37, 53), low, high)
    np.testing.assert_allclose(found, [0.0, 119.0, 0.0, 19.0, 0.0])


def test_the_pulled_plane_shows_with_targets_far_from_their_sources(gl):
    """Every target moved by T = (40000, 30000) and the canvas with them: the same map moved
    by T (MLSKernel.offset), whose kernel holds the targets moved back by T; the pulled
    plane shows there as near the sources (the kernel's targets are already less T: taken
    off twice, they would miss the canvas)."""
    h, w = 37, 53
    index = np.arange(h * w, dtype=np.uint16).reshape(h, w)
    src = np.concatenate([PULLED_SRC, [[-30.0, -60.0]]])
    dst = np.concatenate([PULLED_DST, [[-30.0, -60.0]]])
    far = np.array([40000.0, 30000.0])
    options = {"border": "edge", "method": "quads", "grid": 1}
    with glmls.MLS(src, dst, shape=(h, w), ctx=gl) as m:
        near = m.warp(index, **options)
    with glmls.MLS(src, dst + far, shape=(h, w), ctx=gl) as m:
        moved = m.warp(index, output_shape=(h, w), origin=tuple(far), **options)
        large = m.warp(index, output_shape=(3 * h, 3 * w), origin=tuple(far - [w, h]), **options)
    np.testing.assert_array_equal(moved, near)
    np.testing.assert_array_equal(large[h : 2 * h, w : 2 * w], near)
