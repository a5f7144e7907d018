"""Hostile input to the public 2D surface: each gets a ValueError/TypeError naming the bad
value, or a documented result; never an error from deep inside, a NaN, or a silent wrong
answer. The images are tiny: GL runs on the CPU in the tests."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls import reference
from glmls.analysis.canvas import as_rgb8
from glmls.core.config import check_result_bytes
from glmls.core.mesh import as_shape

SRC = np.array([[0.0, 0], [7, 0], [0, 5], [7, 5]])
DST = SRC + [[1, 0], [0, 1], [0, 0], [1, 1]]
REF = np.array([[1.0, 1], [5, 1], [1, 4], [6, 4], [3, 2]])


@pytest.fixture
def image() -> np.ndarray:
    return np.random.default_rng(3).integers(1, 255, (6, 8), dtype=np.uint8)


# -- shapes beyond the coordinate range ---------------------------------------------------


@pytest.mark.parametrize("shape", [(2**40, 5), (5, 1_000_001), (10**12, 10**12, 3)])
def test_a_shape_beyond_the_coordinate_range_is_refused(shape):
    with pytest.raises(ValueError, match=r"shape must have H, W <= 1e\+06"):
        as_shape(shape)


def test_an_mls_of_a_huge_shape_is_refused_not_imprecise(gl):
    # the image box entered f's float32 scaling: with shape (2**40, 5), f missed the float64
    # reference by more than a pixel at points next to the handles
    with pytest.raises(ValueError, match=r"shape must have H, W <= 1e\+06.*1099511627776"):
        glmls.MLS(SRC, DST, shape=(2**40, 5))
    with glmls.MLS(SRC, DST, shape=(1_000_000, 5)) as m:  # the limit itself works
        f, _, _ = reference.mls(SRC, DST, REF, m.config, shape=m.shape)
        assert_allclose(m(REF), f, atol=0.1)


# -- results beyond the machine's memory ----------------------------------------------------

HUGE = (10**6, 10**6)  # 10**12 pixels: terabytes on any machine


def small_memory(monkeypatch, nbytes: int) -> None:
    """Make this machine's memory ``nbytes`` for the result checks."""
    monkeypatch.setattr(glmls.core.config, "physical_memory", lambda: nbytes)


def test_check_result_bytes_says_both_sizes(monkeypatch):
    small_memory(monkeypatch, 2**30)
    check_result_bytes("what", 2**30)  # the memory itself fits
    text = r"what needs 1,073,741,825 bytes \(1\.0 GiB\), more than .* 1,073,741,824 bytes"
    with pytest.raises(ValueError, match=text):
        check_result_bytes("what", 2**30 + 1)
    monkeypatch.setattr(glmls.core.config, "physical_memory", lambda: None)
    check_result_bytes("what", 2**80)  # nothing known, nothing checked


def test_physical_memory_is_this_machines():
    memory = glmls.core.config.physical_memory()
    assert memory is None or memory > 2**26


RESULTS = {
    "mesh": lambda m, shape: m.mesh(shape),
    "mesh-grid": lambda m, shape: m.mesh(shape, grid=4),
    "mesh-tolerance": lambda m, shape: m.mesh(shape, tolerance=0.5),
    "error_field": lambda m, shape: m.error_field(shape),
    "error_field-grid": lambda m, shape: m.error_field(shape, grid=4),
    "error_field-tolerance": lambda m, shape: m.error_field(shape, tolerance=0.5),
    "analysis.error_field": lambda m, shape: glmls.analysis.error_field(m, shape, grid=8),
    "foldovers": lambda m, shape: glmls.analysis.foldovers(m, shape),
    "foldovers-grid": lambda m, shape: glmls.analysis.foldovers(m, shape, grid=16),
}


@pytest.mark.parametrize("call", RESULTS.values(), ids=RESULTS.keys())
def test_a_result_beyond_the_memory_is_refused_up_front(gl, monkeypatch, call):
    # a terabyte shape was numpy's MemoryError (mesh, foldovers) or an endless GL dispatch
    # (error_field at grid 4); one beyond a small machine's memory was allocated, and swapped
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        with pytest.raises(ValueError, match=r"needs [\d,]+ bytes .* more than this machine's"):
            call(m, HUGE)
        small_memory(monkeypatch, 2**20)
        with pytest.raises(ValueError, match=r"of shape \(2000, 3000\).* more than this"):
            call(m, (2000, 3000))
        small_memory(monkeypatch, 2**30)
        assert call(m, (20, 30)) is not None  # what fits is computed


# -- warp_batch takes the images glmls.warp takes ----------------------------------------


@pytest.mark.parametrize("stacked", [True, False])
def test_warp_batch_takes_big_endian_images_as_warp_does(gl, image, stacked):
    images = np.stack([image, image[::-1]]).astype(np.uint16) * 200
    big = images.astype(">u2")
    src, dst = np.stack([SRC, SRC]), np.stack([DST, DST])
    expected = glmls.warp_batch(images, src, dst)
    out = glmls.warp_batch(big if stacked else list(big), src, dst)
    assert_array_equal(np.asarray(out), expected)
    assert_array_equal(expected[0], glmls.warp(big[0], SRC, DST))


# -- analysis -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, method",
    [
        (lambda m: glmls.analysis.error_field(m, (6, 8)), "error_field"),
        (lambda m: glmls.analysis.foldovers(m, (6, 8)), "mesh"),
    ],
)
@pytest.mark.parametrize("m", ["m", None, np.zeros((4, 2))])
def test_analysis_names_an_m_that_is_not_an_mls(call, method, m):
    expected = f"m must be a glmls.MLS .*{method}.*got {type(m).__name__}"
    with pytest.raises(TypeError, match=expected):
        call(m)


def test_error_stats_of_values_near_the_float64_limit_are_finite():
    big = np.finfo(np.float64).max
    stats = glmls.analysis.error_stats([big, big])
    assert stats["median"] == stats["mean"] == stats["max"] == big
    assert glmls.analysis.error_stats([1.0, 2.0, 3.0, 10.0])["median"] == 2.5


def test_tune_names_handles_that_are_none(gl):
    with pytest.raises(ValueError, match="tune needs at least one handle"):
        glmls.analysis.tune((6, 8), np.zeros((0, 2)), np.zeros((0, 2)), REF, trials=1)


# -- files --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "limit, error, text",
    [("a", TypeError, "max_pixels must be an integer"), (True, TypeError, "got True"),
     (1.5, TypeError, "got 1.5"), (0, ValueError, "max_pixels must be an integer >= 1, got 0"),
     (-5, ValueError, "got -5")],
)  # fmt: skip
def test_imread_names_a_bad_max_pixels_not_the_file(tmp_path, image, limit, error, text):
    path = tmp_path / "a.png"
    glmls.imwrite(path, image)
    with pytest.raises(error, match=text):
        glmls.imread(path, max_pixels=limit)  # was "corrupt or truncated PNG" for "a"
    assert_array_equal(glmls.imread(path, max_pixels=np.int64(48)), image)


# -- values -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "values, error, text",
    [((0, 0, np.nan, 1), ValueError, "x1 must be a finite number"),
     ((0, np.inf, 1, 1), ValueError, "y0 must be a finite number"),
     (("a", 0, 1, 1), TypeError, "x0 must be a finite number, got 'a'"),
     ((0, 0, 1, True), TypeError, "y1 must be a finite number, got True"),
     ((0, 0, None, 1), TypeError, "x1 must be a finite number, got None")],
)  # fmt: skip
def test_bounds_names_a_value_that_is_not_a_finite_number(values, error, text):
    with pytest.raises(error, match=text):
        glmls.Bounds(*values)


@pytest.mark.parametrize(
    "values, text",
    [((5, 0, 1, 3), r"Bounds x1 must be >= x0 .*got x0=5\.0, x1=1\.0"),
     ((0, 2.5, 1, -2.5), r"Bounds y1 must be >= y0 .*got y0=2\.5, y1=-2\.5")],
)  # fmt: skip
def test_an_inverted_bounds_is_a_value_error_naming_the_values(values, text):
    with pytest.raises(ValueError, match=text):
        glmls.Bounds(*values)
    assert glmls.Bounds(1.5, 2, 1.5, 2).output_shape == (1, 1)  # a single point


def test_bounds_of_numpy_numbers():
    assert glmls.Bounds(np.float32(-0.5), np.int64(-1), 5.5, np.float64(3.5)).output_shape == (
        5,
        6,
    )


def test_coordinate_map_names_a_residual_that_is_not_a_bool(gl):
    with glmls.MLS(SRC, DST) as m:
        with pytest.raises(TypeError, match="residual must be True or False, got 'yes'"):
            m.coordinate_map((6, 8), residual="yes")
        xy, res = m.coordinate_map((6, 8), residual=np.True_)
    assert xy.shape == (6, 8, 2) and res.shape == (6, 8)


@pytest.mark.parametrize("m", ["m", None])
def test_report_names_an_m_that_is_not_an_mls(image, m):
    with pytest.raises(TypeError, match=f"m must be a glmls.MLS .*got {type(m).__name__}"):
        glmls.analysis.report(image, m, REF)


def test_size_messages_say_which_side_is_which(gl):
    # the command line's warnings say W x H ("the 16385 x 1 image"); these said H x W
    limit = gl.limits["max_texture_size"]
    with pytest.raises(ValueError, match=f"image {limit + 1} pixels wide and 1 high exceeds"):
        glmls.warp(np.ones((1, limit + 1), np.uint8), [[0, 0]], [[1, 0]])
    with pytest.raises(ValueError, match="image 8 pixels wide and 1 high has none"):
        glmls.warp(np.ones((1, 8), np.uint8), [[0, 0]], [[1, 0]], method="paper-quads")


@pytest.mark.parametrize(
    "picture",
    [np.full((4, 5), 65535, np.uint16), np.full((4, 5, 1), 255, np.uint8),
     np.dstack([np.full((4, 5), 1.0), np.zeros((4, 5))]), np.full((4, 5, 4), 65535, np.uint16)],
)  # fmt: skip
def test_pictures_take_every_image_imread_gives(picture):
    # uint16 (16-bit PNG, TIFF) and grey + alpha were refused: glmls analyze and tune failed
    # with a traceback on them, tune after the whole tuning
    assert_array_equal(as_rgb8(picture), np.full((4, 5, 3), 255, np.uint8))
    assert as_rgb8(np.full((2, 2), 257 * 7, np.uint16))[0, 0].tolist() == [7, 7, 7]


def test_a_report_of_a_16_bit_image(gl, image):
    with glmls.MLS(SRC, DST) as m:
        report = glmls.analysis.report(image.astype(np.uint16) * 257, m, REF, construction=False)
        same = glmls.analysis.report(image, m, REF, construction=False)
    assert_array_equal(report.images["deformed"], same.images["deformed"])


@pytest.mark.parametrize("low, high", [(0.0, 255.0), (-1.0, 1.0), (1000.0, 3000.0)])
def test_a_report_of_a_float_image_of_any_range(gl, image, low, high):
    # a float TIFF of 0 to 255 was clipped to [0, 1]: pictures white, the construction error
    # ~1e-16 of a white image, and no word of it; now scaled from its least to its greatest
    # value, recorded in the summary, the same report as its uint8 self
    floats = low + image.astype(np.float64) * ((high - low) / 255.0)
    floats[0, 0], floats[-1, -1] = low, high
    eight = np.round((floats - low) * (255.0 / (high - low))).astype(np.uint8)
    with glmls.MLS(SRC, DST) as m:
        report = glmls.analysis.report(floats.astype(np.float32), m, REF)
        same = glmls.analysis.report(eight, m, REF)
    assert report.summary["image"]["intensities"] == [low, high]
    assert "intensities" not in same.summary["image"]
    assert report.summary["construction"] == same.summary["construction"]
    for name, picture in same.images.items():
        assert_array_equal(report.images[name], picture)
    assert_array_equal(as_rgb8(np.full((2, 3), -4.0))[..., 0], np.zeros((2, 3), np.uint8))
    assert_array_equal(as_rgb8(np.full((2, 3), 4.0))[..., 0], np.full((2, 3), 255, np.uint8))


def test_inverse_names_a_return_valid_that_is_not_a_bool(gl):
    with glmls.MLS(SRC, DST) as m:
        with pytest.raises(TypeError, match="return_valid must be True or False, got 1"):
            m.inverse(REF, return_valid=1)
        s, valid = m.inverse(REF, return_valid=np.True_)
    assert s.shape == (5, 2) and valid.all()


def test_an_mls_settings_are_read_only(gl):
    """f is fixed by the handles and the configuration it was made with: assigning another
    ``config``, ``shape``, ``spacing`` or inverse ``grid`` is refused, not taken by the repr
    and the inverse's first guess while the GPU keeps the old f."""
    src3 = np.array([[0.0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]])
    with glmls.MLS(SRC, DST, shape=(6, 8)) as m, glmls.MLS(src3, src3 + 1, shape=(4, 5, 6)) as m3:
        before = m(REF)
        for name, value in [
            ("config", glmls.MLSConfig(transform="affine", alpha=2.0)),
            ("shape", (3, 3)),
            ("spacing", (1.0, 1.0, 2.0)),
        ]:
            for mls in (m, m3):
                with pytest.raises(AttributeError, match=name):
                    setattr(mls, name, value)
        inverse = m.inverse
        with pytest.raises(AttributeError, match="grid"):
            inverse.grid = 0
        assert m.config == glmls.MLSConfig() and m.shape == (6, 8) and m.spacing is None
        assert m3.shape == (4, 5, 6) and inverse.grid == 1
        assert_array_equal(m(REF), before)
        assert "alpha=1.0" in repr(m)


# -- a wrong dtype is both a TypeError and a ValueError -----------------------------------

_BATCH = np.zeros((2, 6, 8), np.uint8)
_HANDLES = np.stack([SRC, SRC])


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: glmls.warp(np.zeros((6, 8), np.int64), SRC, DST), "image"),
        (lambda: glmls.warp(np.zeros((6, 8), np.uint8), SRC.astype(bool), DST), "src"),
        (lambda: glmls.warp_batch(_BATCH.astype(np.int32), _HANDLES, _HANDLES), r"images\[0\]"),
        (lambda: glmls.warp_batch(_BATCH, [SRC, [["a", "b"]] * 4], _HANDLES), r"src\[1\]"),
        (
            lambda: glmls.warp_batch(_BATCH, _HANDLES, _HANDLES, masks=_BATCH.astype(np.float32)),
            r"masks\[0\]",
        ),
        (
            lambda: glmls.warp_batch(
                _BATCH, _HANDLES, _HANDLES, keypoints=np.ones((2, 1, 2), bool)
            ),
            r"keypoints\[0\]",
        ),
        (lambda: glmls.augment.Augment("grid")(_BATCH.astype(complex)), r"images\[0\]"),
        (lambda: glmls.MLS(np.zeros((4, 3), bool), np.zeros((4, 3))), "src"),
    ],
)
def test_a_wrong_dtype_is_a_value_error_and_a_type_error(gl, call, name):
    """Bad input is a ValueError, as glmls's other checks give; a wrong dtype is a TypeError
    too, as numpy and scikit-image report one: ``glmls.DtypeError`` is both, naming the item."""
    with pytest.raises(glmls.DtypeError, match=rf"^{name} (has|must|dtype)") as caught:
        call()
    assert isinstance(caught.value, ValueError) and isinstance(caught.value, TypeError)


# -- NaN and infinite pixels of a float image ---------------------------------------------

FLOAT_IMAGE = np.random.default_rng(5).random((20, 24)).astype(np.float32)
BAD_PIXEL = (9, 11)
BENT_SRC = np.array([[3.0, 3], [20, 4], [4, 16], [19, 15], [11, 9]])
BENT_DST = BENT_SRC + [[0, 0], [0.5, 0.3], [-0.4, 0.2], [0, 0], [0.7, -0.6]]


def warped_with(value: float, **options) -> np.ndarray:
    image = FLOAT_IMAGE.copy()
    image[BAD_PIXEL] = value
    return glmls.warp(image, BENT_SRC, BENT_DST, **options)


@pytest.mark.parametrize("method", ["quads", "splat", "backward", "backward-swap", "paper-quads"])
@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_nan_or_infinite_pixel_reaches_only_the_pixels_that_sample_it(
    gl, method, interpolation, bad
):
    options = {"method": method, "interpolation": interpolation, "border": "edge"}
    out = warped_with(bad, **options)
    # the pixels that depend on the bad one: those that change with its (finite) value
    low, high = warped_with(0.0, **options), warped_with(1e6, **options)
    depends = low != high
    assert depends.any()
    spoilt = ~np.isfinite(out)
    # each pixel that weighs it is NaN or infinite, and no other: a pixel that gives it weight
    # 0 in its stencil (a sample on its row or column) leaves it out
    assert_array_equal(spoilt, depends)
    assert_array_equal(out[~spoilt], low[~spoilt])  # and every other pixel is untouched
    if interpolation == "nearest" or method == "splat":
        assert_array_equal(out[depends], bad)  # a copied value stays what it was


@pytest.mark.parametrize("method", ["quads", "backward", "paper-quads"])
@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_the_identity_keeps_a_nan_pixel_bit_for_bit(gl, method, interpolation):
    image = FLOAT_IMAGE.copy()
    image[BAD_PIXEL] = np.nan
    image[2, 3] = np.inf
    # each pixel is sampled at its own centre: the bad pixels weigh 0 in the blends of the
    # pixels whose 2 x 2 stencil holds them, which leave them out (NaN x 0 would be NaN)
    out = glmls.warp(image, BENT_SRC, BENT_SRC, method=method, interpolation=interpolation)
    assert_array_equal(out, image)
    batch = np.stack([image, image[::-1]])
    options = {"method": method, "interpolation": interpolation}
    out = glmls.warp_batch(batch, [BENT_SRC] * 2, [BENT_SRC] * 2, **options)
    assert_array_equal(out, batch)


# -- found by feeding hostile values to the public API ------------------------------------


@pytest.mark.parametrize(
    ("n", "error"), [(2**63, ValueError), (10**9, ValueError), (1, ValueError), (2.0, TypeError)]
)
def test_linear_colormap_names_an_n_out_of_range(n, error):
    # 2**63 was numpy's IndexError from linspace; 10**9 a table of 24 GB
    with pytest.raises(error, match=rf"^n must be an integer from 2 to 65536, got {n!r}$"):
        glmls.analysis.linear_colormap(n=n)
    assert glmls.analysis.linear_colormap(n=65536).shape == (65536, 3)


@pytest.mark.parametrize(
    "call",
    [
        lambda values: glmls.analysis.picture_limits("E_MLS", values),
        lambda values: glmls.analysis.tetrahedron_quality(values.reshape(-1, 4, 3)),
    ],
    ids=["picture_limits", "tetrahedron_quality"],
)
def test_complex_values_are_refused_not_cast_to_their_real_part(call):
    # numpy's cast dropped the imaginary part with a ComplexWarning, a silent wrong answer
    values = np.arange(24.0).reshape(2, 12) + 1j
    with pytest.raises(glmls.DtypeError, match=r"must be real numbers, got dtype complex128"):
        call(values)


def test_construction_windows_beyond_the_memory_are_refused_up_front(gl, image, monkeypatch):
    # radius 10**4 asked numpy for 6 GiB of window offsets, then for the windows' 25 GiB
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        out = m.warp(image)
        for radius in (10**4, 10**6):
            with pytest.raises(ValueError, match=rf"windows of radius {radius} at 5 points needs"):
                glmls.analysis.construction_errors(image, out, m, REF, radius=radius)
        small_memory(monkeypatch, 2**20)
        with pytest.raises(ValueError, match=r"more than this machine's memory of 1,048,576"):
            glmls.analysis.construction_errors(image, out, m, REF, radius=30)
        errors = glmls.analysis.construction_errors(image, out, m, REF, radius=1)
        assert errors.values.shape == (5,)


def folded_keypoints(count: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` keypoints of a 32 x 32 image through a grid augmentation that folds."""
    keypoints = np.random.default_rng(1).random((count, 2)) * 32
    result = glmls.augment.Augment("grid", displacement=0.6, seed=3)(
        np.zeros((1, 32, 32), np.uint8), keypoints=[keypoints]
    )
    return np.asarray(result.keypoints[0]), np.asarray(result.keypoints_valid[0])


def test_many_keypoints_on_a_folded_mesh_take_bounded_memory(gl):
    # every (keypoint, row of cells) pair was gathered at once: 10**5 keypoints on a 32 x 32
    # image were numpy's MemoryError under 8 GB, 3 * 10**4 took 2.3 GiB at the peak
    tracemalloc.start()
    try:
        _, visible = folded_keypoints(30_000)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 400 * 2**20, peak
    assert 0 < visible.sum() < len(visible)  # the fold hides some, not all


def test_keypoints_tested_in_blocks_are_those_tested_at_once(gl, monkeypatch):
    at_once = folded_keypoints(3_000)
    monkeypatch.setattr(glmls.batch.covering, "COVER_BLOCK", 5_000)  # a few points a block
    in_blocks = folded_keypoints(3_000)
    assert_array_equal(in_blocks[0], at_once[0])
    assert_array_equal(in_blocks[1], at_once[1])
