"""Border modes (``border=``): numpy.pad's meanings, for the backward methods (sampling outside
the source) and the forward ones (the mesh extended past the image, as far as the canvas
needs)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from helpers import run_demo, smooth_handles, turned_handles
from scipy import ndimage

import glmls
from glmls.core.mesh import MeshLattice
from glmls.imaging.frame import Frame, border_margin, encloses
from glmls.imaging.options import PipelineOptions
from glmls.imaging.pipeline import WarpPipeline

#: numpy.pad's names -> scipy.ndimage's for the same rule.
SCIPY_MODES = {
    "edge": "nearest",
    "symmetric": "reflect",
    "reflect": "mirror",
    "wrap": "grid-wrap",
}
MODES = tuple(SCIPY_MODES)
SHAPE = (48, 64)


def textured(shape, channels=3, seed=7):
    """A smooth-ish uint8 image with every value in 20..235 (never the background 0)."""
    rng = np.random.default_rng(seed)
    small = rng.uniform(20, 235, (shape[0] // 4 + 1, shape[1] // 4 + 1, channels))
    return np.repeat(np.repeat(small, 4, 0), 4, 1)[: shape[0], : shape[1]].round().astype(np.uint8)


def rgba_coordinates(shape):
    """uint8 RGBA: R = x, G = y, B = 7, A = 255 (images under 256 px): the fused path."""
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    return np.dstack([xx, yy, np.full_like(xx, 7), np.full_like(xx, 255)]).astype(np.uint8)


def pull_in(shape, factor=0.75, turn=0.0):
    """Handles near the corners pulled towards the centre (the image border moves in)."""
    return turned_handles(shape, factor, turn)


def padded_index(i, n, mode):
    """numpy.pad's rule: the source index at index ``i`` (any int array) of a length-n axis."""
    reach = int(np.abs(i).max()) + n + 1
    table = np.pad(np.arange(n), reach, mode=mode)
    return table[np.asarray(i) + reach]


@pytest.mark.parametrize("mode", MODES)
def test_backward_linear_equals_scipy_map_coordinates(gl, mode):
    """Each mode samples outside the source as scipy.ndimage.map_coordinates does with the
    same rule, on the same coordinate map: within one grey level at 8 bits."""
    image = textured(SHAPE)
    p, q = pull_in(SHAPE, 0.7, turn=0.3)
    with glmls.MLS(p, q, shape=SHAPE) as m:
        out = m.warp(image, method="backward", interpolation="linear", border=mode)
        xy = m.coordinate_map(SHAPE, border=mode)
    assert (xy[..., 0] < -0.5).any() and (xy[..., 1] > SHAPE[0] - 0.5).any()  # far outside
    expected = np.stack(
        [
            ndimage.map_coordinates(
                image[..., k].astype(np.float64),
                [xy[..., 1], xy[..., 0]],
                order=1,
                mode=SCIPY_MODES[mode],
            )
            for k in range(3)
        ],
        axis=-1,
    )
    np.testing.assert_allclose(out, expected, atol=1.0 + 1e-6)


def test_backward_constant_keeps_the_background_outside(gl):
    image = textured(SHAPE)
    p, q = pull_in(SHAPE, 0.7, turn=0.3)
    with glmls.MLS(p, q, shape=SHAPE) as m:
        out = m.warp(image, method="backward", interpolation="linear", background=0)
        xy = m.coordinate_map(SHAPE)
    inside = (
        (xy[..., 0] >= -0.5)
        & (xy[..., 0] <= SHAPE[1] - 0.5)
        & (xy[..., 1] >= -0.5)
        & (xy[..., 1] <= SHAPE[0] - 0.5)
    )
    assert (~inside).sum() > 100
    assert (out[~inside] == 0).all()
    expected = ndimage.map_coordinates(
        image[..., 0].astype(np.float64), [xy[..., 1], xy[..., 0]], order=1, mode="nearest"
    )
    # uint8 rounding (0.5) plus the GPU's 8-bit filter weights (up to 255 / 256 on NVIDIA)
    np.testing.assert_allclose(out[..., 0][inside], expected[inside], atol=1.5)


@pytest.mark.parametrize("mode", ["edge", "wrap", "reflect", "symmetric"])
def test_backward_shows_no_pixel_of_a_collapsed_plane_but_its_point(gl, mode):
    """Every target at one point: f is constant (float64 M = 0), so only that pixel has a
    preimage. float32 leaves M at noise (~1e-8), and Newton from the other pixels runs out
    to ~1e7 px, where float32's steps of s (what a residual is accepted within) are pixels:
    a preimage past the coordinates glmls takes (1e6 px) is none, batched or not."""
    image = np.full((64, 80), 200, np.uint8)
    p = np.array([[10.0, 10], [70, 10], [40, 50], [15, 55]])
    q = np.tile([[40.0, 30]], (4, 1))
    with glmls.MLS(p, q, transform="affine", shape=image.shape, ctx=gl) as m:
        out = m.warp(image, method="backward", border=mode)
    assert np.argwhere(out != 0).tolist() == [[30, 40]]
    batch = glmls.warp_batch(np.stack([image] * 2), [p] * 2, [q] * 2, method="backward",
                             border=mode, transform="affine")  # fmt: skip
    np.testing.assert_array_equal(batch, [out, out])


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("method", ["backward", "backward-swap"])
def test_backward_nearest_takes_the_padded_pixel(gl, mode, method):
    """Nearest: the pixel containing s, by numpy.pad's rule outside (float32 image: exact)."""
    image = textured(SHAPE, channels=1)[..., 0].astype(np.float32)
    p, q = pull_in(SHAPE, 0.7, turn=0.3)
    with glmls.MLS(p, q, shape=SHAPE) as m:
        out = m.warp(image, method=method, border=mode)
        xy = m.coordinate_map(SHAPE, method=method, border=mode)
    col = np.floor(xy[..., 0].astype(np.float64) + 0.5).astype(int)
    row = np.floor(xy[..., 1].astype(np.float64) + 0.5).astype(int)
    expected = image[padded_index(row, SHAPE[0], mode), padded_index(col, SHAPE[1], mode)]
    # a point within float32 noise of a pixel edge may round either way
    frac = np.abs(np.stack([xy[..., 0], xy[..., 1]]) % 1.0 - 0.5).min(axis=0)
    differ = out != expected
    assert (frac[differ] < 1e-3).all()
    assert differ.mean() < 0.01


OPTIONS = {
    "compute scan": PipelineOptions(),
    "rasterizer": PipelineOptions(compute_quads=False),
    "bands": PipelineOptions(band_bytes=4096),
    "no fast pass": PipelineOptions(fast_embedded=False),
}


@pytest.mark.parametrize("path", list(OPTIONS))
@pytest.mark.parametrize("mode", MODES)
def test_forward_quads_pulled_in_cover_every_pixel_from_the_padded_source(gl, path, mode):
    """The border pulled in: with a border mode no pixel keeps the background, and every
    pixel's colour is the padded source's at (about) f's inverse there."""
    shape = (40, 56)
    image = rgba_coordinates(shape)
    p, q = pull_in(shape, 0.6, turn=0.2)
    pipe = WarpPipeline(gl, options=OPTIONS[path])
    try:
        with glmls.MLS(p, q, shape=shape) as m:
            plain = pipe.warp(m, image, grid=2)
            out = pipe.warp(m, image, grid=2, border=mode)
            xy = m.coordinate_map(shape, border=mode)
    finally:
        pipe.release()
    assert (plain[..., 3] == 0).sum() > 200  # the constant border leaves slivers
    assert (out[..., 3] == 255).all() and (out[..., 2] == 7).all()  # every pixel covered
    for axis, n in ((0, shape[1]), (1, shape[0])):
        s = xy[..., axis].astype(np.float64)
        got = out[..., axis].astype(int)
        near = np.stack(
            [padded_index(np.floor(s + 0.5).astype(int) + d, n, mode) for d in (-1, 0, 1)]
        )
        assert (near == got).any(axis=0).all(), f"{mode}: a pixel from the wrong source"


@pytest.mark.parametrize("mode", MODES)
def test_forward_linear_and_splat_fill_from_the_padded_source(gl, mode):
    image = textured(SHAPE)
    p, q = pull_in(SHAPE, 0.6)
    with glmls.MLS(p, q, shape=SHAPE) as m:
        linear = m.warp(image, interpolation="linear", grid=4, border=mode)
        splat = m.warp(image, method="splat", border=mode)
        plain = m.warp(image, method="splat")
    assert (linear.min(axis=2) >= 20).all()  # no background: covered everywhere
    # splat leaves gaps, but the ring past the image is filled too
    assert (splat.max(axis=2) > 0).sum() > (plain.max(axis=2) > 0).sum() + 300
    colours = {tuple(c) for c in image.reshape(-1, 3)}
    found = splat.reshape(-1, 3)
    assert all(tuple(c) in colours for c in found[found.max(axis=1) > 0])


@pytest.mark.parametrize("mode", ("constant", *MODES))
@pytest.mark.parametrize("method", glmls.METHODS)
def test_identity_with_a_canvas_is_numpy_pad(gl, mode, method):
    """No handles (the identity): the canvas at ``origin`` shows numpy.pad's extension of
    the image, far past it too."""
    image = textured((12, 9))
    origin, shape = (-30, 5), (40, 50)
    with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2)), shape=image.shape) as m:
        out = m.warp(image, method=method, border=mode, output_shape=shape, origin=origin)
    reach = 80
    if mode == "constant":
        padded = np.pad(image, ((reach, reach), (reach, reach), (0, 0)))
    else:
        padded = np.pad(image, ((reach, reach), (reach, reach), (0, 0)), mode=mode)
    top, left = origin[1] + reach, origin[0] + reach
    np.testing.assert_array_equal(out, padded[top : top + shape[0], left : left + shape[1]])


def test_translation_with_a_fractional_origin(gl):
    """One handle translates by (3, -2); origin (0.5, 0): output pixel (i, j) shows the
    point (i + 0.5, j), the source point (i - 2.5, j + 2): nearest rounds up at .5."""
    image = textured((20, 24), channels=1)[..., 0].astype(np.float32)
    with glmls.MLS([[5.0, 5.0]], [[8.0, 3.0]], shape=image.shape) as m:
        out = m.warp(image, method="backward", border="wrap", origin=(0.25, 0.0))
    rows, cols = np.mgrid[0:20, 0:24]
    expected = image[(rows + 2) % 20, np.floor(cols + 0.25 - 3 + 0.5).astype(int) % 24]
    np.testing.assert_array_equal(out, expected)


def test_margin_follows_the_deformation(gl):
    shape = (40, 56)
    frame = Frame(shape)
    with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2)), shape=shape) as identity:
        lattice = MeshLattice.corners(shape, 4)
        assert border_margin(identity.kernel, lattice, frame) == 0
        far = Frame((10, 10), (-100.0, 0.0))  # the canvas 100 px left of the image
        margin = border_margin(identity.kernel, lattice, far)
        assert margin % 4 == 0 and 100 <= margin <= 140
    for factor, least in ((0.9, 2), (0.6, 8)):
        p, q = pull_in(shape, factor)
        with glmls.MLS(p, q, shape=shape) as m:
            margin = border_margin(m.kernel, lattice, frame)
            assert margin % 4 == 0 and margin >= least
            ring = lattice.with_margin(margin).boundary()
            low, high = frame.centre_box(0.25)
            assert encloses(m(ring), low, high)


def test_encloses():
    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10.0]])
    assert encloses(square, np.array([2, 2.0]), np.array([8, 8.0]))
    assert encloses(square[::-1], np.array([2, 2.0]), np.array([8, 8.0]))  # either turn
    assert not encloses(square, np.array([2, 2.0]), np.array([12, 8.0]))  # crosses
    assert not encloses(square, np.array([20, 20.0]), np.array([30, 30.0]))  # outside
    assert not encloses(square + [[0, 0], [0, 0], [np.nan, 0], [0, 0]], np.zeros(2), np.ones(2))


def test_every_canvas_pixel_is_covered_for_smooth_maps(gl, rng):
    shape = (50, 70)
    image = textured(shape)
    for _ in range(4):
        p, q = smooth_handles(shape, rng, displacement=12)
        with glmls.MLS(p, q, shape=shape) as m:
            for mode in MODES:
                out = m.warp(image, border=mode, grid=3)
                assert (out.min(axis=2) >= 20).all(), mode


@pytest.mark.parametrize("bad", ["mirror", "Edge", "", None, 3])
def test_unknown_border_lists_the_choices(gl, bad):
    with glmls.MLS([[1.0, 1.0]], [[2.0, 2.0]]) as m:
        for call in (
            lambda: m.warp(np.zeros((4, 4), np.uint8), border=bad),
            lambda: m.coordinate_map((4, 4), border=bad),
        ):
            # a string that is no border is a ValueError; no string at all a TypeError
            with pytest.raises(
                ValueError if isinstance(bad, str) else TypeError,
                match=r"border.*constant, edge, symmetric, reflect, wrap",
            ):
                call()


def test_the_borders_demo_runs(tmp_path):
    out = tmp_path / "borders.png"
    done = run_demo("borders", "--out", str(out), "--scale", "0.2")
    assert done.returncode == 0, done.stderr
    assert "border edge: 0 pixels left" in done.stdout
    assert "border symmetric: 0 pixels left" in done.stdout
    assert glmls.imread(out).ndim == 3


def test_a_canvas_out_of_reach_warns_and_never_hangs(gl):
    """A canvas a million pixels from the image: the mesh may not grow that far (it would
    take hours); the forward methods say so and leave the background, the backward ones
    sample by the rule (Newton needs no mesh there)."""
    image = np.full((64, 64), 7, np.uint8)
    far = {"output_shape": (10, 10), "origin": (-1e6, 0.0)}
    with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2))) as m:
        with pytest.warns(glmls.BorderWarning, match="does not cover the whole canvas"):
            out = m.warp(image, border="edge", **far)
        assert (out == 0).all()
        out = m.warp(image, border="edge", method="backward", **far)
        assert (out == 7).all()


def test_the_margin_is_searched_once_per_upload(gl, monkeypatch):
    """A warp and the labels that follow its mesh take one margin search (f on the mesh's
    border rings) between them; new handles search again, and a canvas the mesh cannot
    cover warns at every warp, not only at the first."""
    from glmls.batch import margins
    from glmls.imaging import frame as frames

    calls = []
    search = frames.search_margins

    def counted(evaluate, count, lattice, *args, **keywords):
        calls.extend([lattice.grid] * count)
        return search(evaluate, count, lattice, *args, **keywords)

    monkeypatch.setattr(frames, "search_margins", counted)
    monkeypatch.setattr(margins, "search_margins", counted)  # the batch's, every image at once
    image = np.zeros((40, 40), np.uint8)
    src = np.array([[5.0, 5.0], [34.0, 5.0], [20.0, 34.0]])
    dst = src + [[3.0, 3.0], [-3.0, 3.0], [0.0, -3.0]]  # pulls the frame in: a margin
    batch = glmls.warp_batch(image[None], src[None], dst[None], keypoints=[src], border="edge")
    assert calls == [1]
    np.testing.assert_allclose(batch.keypoints[0], dst, atol=0.01)  # the mesh, not f
    with glmls.MLS(src, dst) as m:
        first = m.warp(image, border="edge", grid=4)
        assert m.warp(image, border="edge", grid=4) is not first
        assert calls == [1, 4]
        m.set_handles(src, src)
        m.warp(image, border="edge", grid=4)
        assert calls == [1, 4, 4]
    far = {"output_shape": (10, 10), "origin": (-1e6, 0.0)}
    with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2))) as m:
        for _ in range(2):
            with pytest.warns(glmls.BorderWarning, match="does not cover the whole canvas"):
                m.warp(image, border="edge", **far)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("mode", ["edge", "wrap", "reflect"])
@pytest.mark.parametrize("move", ["shift", "shrink"])
def test_far_maps_fill_the_canvas_by_the_rule(gl, method, mode, move):
    """A translation by six image widths and a tenfold shrink: the mesh reaches as far as
    the border's move asks (within the budget), so every pixel follows the border rule,
    as scipy.ndimage samples the source at f's exact inverse (nearest)."""
    shape = (40, 50)
    image = textured(shape, channels=1)[..., 0]
    src = np.array([[5.0, 5.0], [45.0, 5.0], [5.0, 35.0], [45.0, 35.0]])
    centre = np.array([24.3, 19.6])  # no pixel's preimage on a half-integer (a tie)
    if move == "shift":
        dst = src + [300.0, -7.0]
    else:
        dst = centre + (src - centre) * 0.1
    with glmls.MLS(src, dst, transform="affine") as m:
        out = m.warp(image, method=method, border=mode)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    if move == "shift":
        x, y = cols - 300.0, rows + 7.0
    else:
        x, y = centre[0] + (cols - centre[0]) * 10.0, centre[1] + (rows - centre[1]) * 10.0
    want = ndimage.map_coordinates(image, [y, x], order=0, mode=SCIPY_MODES[mode])
    np.testing.assert_array_equal(out, want)


def test_the_margin_search_stops_where_no_margin_helps(gl):
    """A map that collapses the plane to a point and a canvas 10^6 px off the image: the
    search ends after a step or two instead of growing the mesh to its budget (millions of
    points), and says so."""
    shape = (64, 64)
    lattice = MeshLattice.corners(shape, 1)
    src = np.array([[5.0, 5.0], [58.0, 5.0], [5.0, 58.0], [58.0, 58.0]])
    with glmls.MLS(src, np.full_like(src, 30.0), transform="affine") as collapse:
        with pytest.warns(glmls.BorderWarning, match="does not cover"):
            assert border_margin(collapse.kernel, lattice, Frame(shape)) <= 64
    with glmls.MLS(src, src + 1.0, transform="affine") as moved:
        far = Frame((10, 10), (-1e6, 0.0))
        with pytest.warns(glmls.BorderWarning, match="reaches 0 px"):
            assert border_margin(moved.kernel, lattice, far) == 0


def test_backward_beyond_the_mesh_reach_follows_the_rule(gl):
    """A similarity that shrinks a 512 x 512 image tenfold: the preimages of the canvas's
    outer pixels lie beyond the mesh that the budget allows, so Newton starts from the
    pixels themselves and must step as far as it asks; every pixel follows the border rule
    (scipy.ndimage at the exact inverse, nearest)."""
    n = 512
    image = np.random.default_rng(1).integers(1, 255, (n, n), dtype=np.uint8)
    centre = np.array([255.3, 255.6])
    src = np.array([[100.0, 100.0], [400.0, 100.0], [100.0, 400.0], [400.0, 400.0]])
    with glmls.MLS(src, centre + (src - centre) * 0.1, transform="similarity") as m:
        out = m.warp(image, method="backward", border="edge")
    rows, cols = np.mgrid[0:n, 0:n].astype(np.float64)
    at = [centre[1] + (rows - centre[1]) * 10.0, centre[0] + (cols - centre[0]) * 10.0]
    want = ndimage.map_coordinates(image, at, order=0, mode="nearest")
    np.testing.assert_array_equal(out, want)


def test_a_border_folded_in_takes_the_margin_that_covers_the_canvas(gl):
    """Two handles that swap places fold the mesh's border in: its image's box shrinks from
    margin 0 to 104 px before it grows; the search goes on to the margin (~1,000 px) whose
    border encloses the canvas, and every pixel is drawn, as by backward."""
    p = np.array([[77.51, 78.188], [93.774, 27.116], [42.418, 76.39],
                  [10.569, 72.413], [96.083, 45.563], [42.728, 31.16]])  # fmt: skip
    q = p.copy()
    q[1], q[3] = [6.536, 71.041], [93.686, 29.202]
    image = np.full((96, 128), 200, np.uint8)
    with glmls.MLS(p, q, transform="similarity", shape=image.shape, ctx=gl) as m:
        with warnings.catch_warnings():
            warnings.simplefilter("error", glmls.BorderWarning)
            out = m.warp(image, method="quads", border="edge", grid=4)
    assert (out == 200).all()
