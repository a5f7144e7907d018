"""Hostile inputs to the 3D surface: each is refused with a ValueError or TypeError naming
the bad value, or gives the documented result; never an error from deep inside, a huge
allocation or a silent wrong answer."""

from __future__ import annotations

import re

import numpy as np
import pytest

import glmls
from glmls import analysis
from glmls.analysis.volume_pictures import NAN_VOXEL_COLOR
from glmls.errors import InputFileError

SRC = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0], [0, 0, 7], [7, 7, 7]])
DST = SRC + [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 0, 0]]


@pytest.fixture
def mls3(gl):
    m = glmls.MLS(SRC, DST, ctx=gl)
    yield m
    m.release()


@pytest.fixture
def volume():
    return (np.random.default_rng(1).random((6, 7, 8)) * 250).astype(np.uint8)


def test_the_error_field_of_an_mls_without_handles_is_zero(gl):
    with glmls.MLS(np.zeros((0, 3)), np.zeros((0, 3)), ctx=gl) as m:
        field = analysis.volume_error_field(m, (3, 4, 5))
    assert field.shape == (3, 4, 5)
    assert (field == 0).all()


@pytest.mark.parametrize("shape", [(2.5, 3, 3), (3, 3.5, 3, 1), (True, 3, 3)])
@pytest.mark.parametrize("analyse", [analysis.volume_error_field, analysis.cell_jacobians])
def test_the_3d_analyses_refuse_a_shape_that_is_not_integers(mls3, analyse, shape):
    with pytest.raises(TypeError, match=r"shape must be \(D, H, W\) integers"):
        analyse(mls3, shape)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_an_output_shape_beyond_memory_is_refused_before_its_array_is_made(mls3, volume, method):
    huge = (10**6, 10**6, 10**6)  # 1e18 voxels: no allocation (nor list of slabs) may be tried
    with pytest.raises(ValueError, match="more than this machine's memory"):
        mls3.warp(volume, method=method, output_shape=huge)
    with pytest.raises(ValueError, match="more than this machine's memory"):
        mls3.coordinate_map(volume.shape, output_shape=huge)


@pytest.mark.parametrize(
    "layout",
    [
        np.asfortranarray,
        lambda v: v[::-1, :, ::-1].copy()[::-1, :, ::-1],  # negative strides
        lambda v: v.astype(">u2").astype(">u2"),  # big-endian
        lambda v: np.frombuffer(v.tobytes(), v.dtype).reshape(v.shape),  # read-only
    ],
)
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_any_memory_layout_gives_the_c_ordered_volume_s_result(mls3, volume, layout, method):
    given = layout(volume)
    kept = given.copy()
    expected = mls3.warp(np.ascontiguousarray(volume, given.dtype.newbyteorder("=")), method=method)
    first, second = mls3.warp(given, method=method), mls3.warp(given, method=method)
    np.testing.assert_array_equal(first, expected)
    np.testing.assert_array_equal(second, first)
    np.testing.assert_array_equal(given, kept)  # not modified in place


@pytest.mark.parametrize("dtype", [np.complex128, object, "U3", "datetime64[s]"])
def test_a_volume_of_no_real_numbers_is_refused_and_no_file_is_written(tmp_path, dtype):
    data = np.zeros((2, 3, 4), dtype)
    with pytest.raises(
        TypeError, match=f"a volume holds real numbers .*got dtype {re.escape(str(data.dtype))}"
    ):
        glmls.Volume(data)
    for suffix in (".nii", ".npy", ".tif"):
        with pytest.raises(TypeError, match="a volume holds real numbers"):
            glmls.write_volume(tmp_path / f"out{suffix}", data)
    assert not list(tmp_path.iterdir())


def test_reading_a_npy_of_complex_numbers_names_the_file(tmp_path):
    path = tmp_path / "complex.npy"
    np.save(path, np.zeros((2, 3, 4), np.complex64))
    with pytest.raises(InputFileError, match=r"complex\.npy: a volume holds real numbers"):
        glmls.read_volume(path)


def test_a_mesh_face_index_beyond_int64_is_named_as_given():
    vertices = [[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]
    faces = np.array([[0, 1, 2**63]], np.uint64)
    with pytest.raises(
        ValueError,
        match=r"faces must index vertices 0\.\.2; face 0 is \[0, 1, 9223372036854775808\]",
    ):
        glmls.Mesh(vertices, faces)


@pytest.mark.parametrize("index", [np.inf, -np.inf, np.nan, 1.5])
def test_a_float_mesh_face_that_is_no_whole_finite_number_is_no_index(index):
    vertices = [[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]
    with pytest.raises(TypeError, match="faces must be integer vertex indices, got dtype float64"):
        glmls.Mesh(vertices, [[0.0, 1.0, index]])


@pytest.mark.parametrize("flag", [1, "yes", None])
def test_the_3d_inverse_names_a_return_valid_that_is_not_a_bool(mls3, flag):
    with pytest.raises(TypeError, match=f"return_valid must be True or False, got {flag!r}"):
        mls3.inverse(DST, return_valid=flag)
    s, valid = mls3.inverse(DST, return_valid=np.True_)
    assert s.shape == (5, 3) and valid.all()
    np.testing.assert_allclose(s, SRC, atol=1e-3)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("value", [2.0**1000, -(2.0**130)])
def test_float64_values_beyond_float32_are_warped_not_made_inf(mls3, method, value):
    """They were refused (before that, made inf); the warp divides them by a power of two
    (values float32 holds exactly then: others come back rounded to its 24 bits)."""
    volume = np.full((4, 5, 6), value)
    out = mls3.warp(volume, method=method, background=value)
    np.testing.assert_array_equal(out, volume)  # a constant volume and background


def test_float64_infinities_stay_what_they_are(mls3):
    volume = np.zeros((4, 5, 6))
    volume[2, 2, 2] = np.inf
    out = mls3.warp(volume, interpolation="nearest")
    assert np.isinf(out).sum() == 1


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("background", [1e39, (-1e300,)])
def test_a_background_beyond_float32_is_refused_not_made_inf(mls3, method, dtype, background):
    """Beside values within float32's range (here 0): float32 cannot hold both."""
    volume = np.zeros((4, 5, 6), dtype)
    with pytest.raises(ValueError, match=r"background .* is beyond float32's range"):
        mls3.warp(volume, method=method, background=background)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_an_integer_volume_s_background_is_one_of_its_values(mls3, method, dtype):
    """1.5 has no uint8 or uint16 value without a rounding rule the caller did not choose."""
    volume = np.zeros((4, 5, 6), dtype)
    for fraction in (1.5, 0.4, (2.5,)):
        with pytest.raises(ValueError, match=rf"is not a value of {np.dtype(dtype)}"):
            mls3.warp(volume, method=method, background=fraction)
    assert (mls3.warp(volume, method=method, background=3.0) >= 0).all()


@pytest.mark.parametrize("background", [np.inf, -np.inf, np.nan])
def test_a_background_of_inf_or_nan_is_what_uncovered_voxels_hold(gl, background):
    with glmls.MLS(SRC, SRC + [2.0, 0, 0], ctx=gl) as m:  # the first 2 columns uncovered
        out = m.warp(np.zeros((4, 5, 6), np.float32), background=background)
    np.testing.assert_array_equal(out[..., :2], np.float32(background))
    assert (out[..., 2:] == 0).all()


class _Mesh:
    """A mesh object with its own vertex normals, as a trimesh.Trimesh has."""

    def __init__(self, normals):
        self.vertices = np.array([[0.0, 0, 0], [4, 0, 0], [0, 4, 0]])
        self.faces = np.array([[0, 1, 2]])
        self.vertex_normals = normals


def test_a_mesh_s_own_normals_of_any_scale_give_the_unit_normals(mls3):
    unit = mls3.deform(_Mesh(np.tile([0.0, 0, 1], (3, 1)))).normals
    for scale in (1e-300, 1e300):  # float32 would make them 0 or inf
        normals = mls3.deform(_Mesh(np.tile([0.0, 0, scale], (3, 1)))).normals
        np.testing.assert_allclose(normals, unit, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(unit, axis=1), 1.0, atol=1e-6)


@pytest.mark.parametrize(
    ("normals", "error", "message"),
    [
        (np.full((3, 3), np.nan), ValueError, r"vertex_normals must be finite; row 0"),
        (np.ones((3, 3), np.complex128), TypeError, "vertex_normals must be real numbers"),
    ],
)
def test_a_mesh_s_own_normals_must_be_finite_real_numbers(mls3, normals, error, message):
    with pytest.raises(error, match=message):
        mls3.deform(_Mesh(normals))


@pytest.mark.parametrize(
    ("vertices", "error", "message"),
    [
        (np.ones((3, 3), np.complex128), TypeError, "vertices must be real numbers, got dtype"),
        ("abc", TypeError, "vertices must be real numbers, got dtype <U3"),
        (np.ones((3, 3), bool), TypeError, "vertices must be real numbers, got dtype bool"),
        ([[0, 0, 0], [1, 0]], ValueError, "rows of 3 numbers each"),
    ],
)
def test_a_mesh_s_vertices_must_be_real_numbers(tmp_path, vertices, error, message):
    with pytest.raises(error, match=message):
        glmls.Mesh(vertices, [[0, 1, 2]])
    with pytest.raises(error, match=message):
        glmls.write_mesh(tmp_path / "out.ply", vertices, faces=[[0, 1, 2]])
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"eps": 0}, ValueError, "eps must be a finite positive number, got 0"),
        ({"min_quality": 1}, ValueError, r"min_quality must be a finite number in \[0, 1\), got 1"),
        ({"warp": "no"}, TypeError, "warp must be True or False, got 'no'"),
        ({"near": -1}, ValueError, r"near must be a finite number >= 0 \(voxels\), got -1"),
        ({"near": float("nan")}, ValueError, "near must be a finite number >= 0"),
    ],
)
def test_volume_report_refuses_bad_options_even_where_the_handles_form_no_tetrahedron(
    gl, options, error, message
):
    # four coplanar handles: no tetrahedron, which the report leaves out (and must not take
    # the bad option's error for)
    src = np.array([[1.0, 1, 2], [5, 1, 2], [1, 5, 2], [5, 5, 2]])
    with glmls.MLS(src, src + [0.5, 0, 0], ctx=gl) as m:
        with pytest.raises(error, match=message):
            analysis.volume_report(np.zeros((4, 6, 7), np.uint8), m, **options)


def test_volume_slices_draw_nan_voxels_apart_and_infinite_ones_at_the_ends():
    volume = np.zeros((3, 4, 5), np.float32)
    volume[1, 2, 3] = np.nan
    volume[1, 0, 0], volume[1, 0, 1], volume[1, 0, 2] = np.inf, -np.inf, 2.0
    picture = analysis.render_volume_slices(volume, slices=(1, 0, 0), scale=1)
    assert picture[2, 3].tolist() == list(NAN_VOXEL_COLOR)
    assert picture[0, :3].tolist() == [[255] * 3, [0] * 3, [255] * 3]  # 0 to 2, the finite


@pytest.mark.parametrize(
    ("shape", "spacing"),
    [((10**7, 5, 5), None), ((2**40, 5, 5), None), ((10, 10, 10), (2e5, 1, 1))],
)
def test_an_mls_of_a_volume_beyond_the_coordinate_range_is_refused(gl, shape, spacing):
    """As a 2D MLS refuses an image beyond ±1e6 px: the volume's extent enters f's float32
    scaling, and with shape (1e7, 5, 5) f missed the float64 reference by 0.03 voxel next to
    the handles (with 2**40, an error about the handles)."""
    with pytest.raises(ValueError, match=r"shape.*extent.*1e\+06"):
        glmls.MLS(SRC, DST, shape=shape, spacing=spacing, ctx=gl)
    with glmls.MLS(SRC, DST, shape=(10**6, 5, 5), ctx=gl) as m:  # the limit itself works
        f, _, _ = glmls.reference.mls(SRC, DST, SRC[:2] + 0.5, m.config)
        assert np.abs(m(SRC[:2] + 0.5) - f).max() < 1e-3


@pytest.mark.parametrize("slabs", [5, {"slab_bytes": 4096}, "small"])
def test_slabs_that_are_no_slab_options_are_a_type_error_naming_them(mls3, volume, slabs):
    with pytest.raises(TypeError, match=r"slabs must be a glmls\.volume\.SlabOptions, got"):
        mls3.warp(volume, slabs=slabs)


def test_bounds_and_coordinate_map_take_a_volume_s_shape_with_its_channels(mls3):
    """As 2D takes ``image.shape``: (D, H, W, C) is the volume's (D, H, W); the volume
    itself passed as a shape is named by its shape, not printed voxel by voxel."""
    channels = np.zeros((6, 7, 8, 2), np.float32)
    assert mls3.bounds(channels.shape) == mls3.bounds((6, 7, 8))
    points, _, covered = mls3.coordinate_map(channels.shape)
    expected, _, expected_covered = mls3.coordinate_map((6, 7, 8))
    np.testing.assert_array_equal(points, expected)
    np.testing.assert_array_equal(covered, expected_covered)
    with pytest.raises(ValueError, match=r"got an array of shape \(6, 7, 8, 2\)$"):
        mls3.bounds(channels)
    with pytest.raises(ValueError, match=r"\(D, H, W\) integers, got \(6, 7, 8, 5\)"):
        mls3.bounds((6, 7, 8, 5))


def test_a_backward_slice_beyond_the_gl_buffer_limit_is_warped_in_rows(mls3, volume, monkeypatch):
    """The GL limit bounds each storage buffer: an output slice of the backward method is
    whole where its largest buffer (the slopes, 48 bytes a voxel) fits, not only where its
    buffers' sum does (as 1500 x 1500 slices did under llvmpipe's 128 MiB), and built in
    boxes of rows where it does not, to the same voxels and source points."""
    canvas = {"output_shape": (3, 20, 20), "origin": (-6.0, -6.0, 1.0)}
    expected = mls3.warp(volume, method="backward", **canvas)
    points, _, covered = mls3.coordinate_map(volume.shape, **canvas)
    limits = type(mls3.kernel.gl).limits.fget
    slice_bytes = 20 * 20 * 48
    for limit in (slice_bytes, slice_bytes - 1):  # whole slices, then two boxes of 10 rows
        monkeypatch.setattr(
            type(mls3.kernel.gl),
            "limits",
            property(lambda gl, limit=limit: limits(gl) | {"max_ssbo_size": limit}),
        )
        out = mls3.warp(volume, method="backward", **canvas)
        np.testing.assert_array_equal(out, expected, err_msg=str(limit))
        limited_points, _, limited_covered = mls3.coordinate_map(volume.shape, **canvas)
        np.testing.assert_array_equal(limited_points, points, err_msg=str(limit))
        np.testing.assert_array_equal(limited_covered, covered, err_msg=str(limit))
    monkeypatch.setattr(
        type(mls3.kernel.gl), "limits", property(lambda gl: limits(gl) | {"max_ssbo_size": 40})
    )
    with pytest.raises(ValueError, match="a row of 20 output voxels needs 960 bytes"):
        mls3.warp(volume, method="backward", **canvas)


@pytest.mark.parametrize(
    ("args", "kind", "message"),
    [
        ((5.0, 0, 0, 1.0, 3, 3), ValueError, r"x1 must be >= x0 .*got x0=5\.0, x1=1\.0"),
        ((0, 0, 4.0, 1, 1, 2.0), ValueError, r"z1 must be >= z0"),
        ((0, 0, 0, 1, 1, np.nan), ValueError, r"VolumeBounds z1 must be a finite number"),
        ((0, "0", 0, 1, 1, 1), TypeError, r"VolumeBounds y0 must be a finite number"),
        ((0, 0, 0, 1, 1, 1, (1.0, 0.0, 1.0)), ValueError, r"spacing must be three finite"),
        ((0, 0, 0, 1, 1, 1, (1.0, 1.0)), ValueError, r"spacing must be three finite"),
        ((0, 0, 0, 1, 1, 1, 2.0), TypeError, r"spacing must be three finite"),
    ],
)
def test_a_volume_bounds_of_bad_values_is_refused_naming_them(args, kind, message):
    """As glmls.Bounds: an inverted or non-finite box, or a spacing that is not three positive
    numbers, would size a canvas of one voxel or none without a word."""
    with pytest.raises(kind, match=message):
        glmls.volume.VolumeBounds(*args)
    box = glmls.volume.VolumeBounds(np.float32(-0.5), 0, 0, np.array(3.5), 1, 1, (2, 1, 1))
    assert box.x0 == -0.5 and box.x1 == 3.5 and box.spacing == (2.0, 1.0, 1.0)


ROTATED = np.array([[1.0, 2, 1], [8, 1, 2], [2, 8, 3], [7, 7, 8], [4, 5, 6], [1, 6, 7]])


def _turned(points: np.ndarray, angle: float = 0.05) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    middle = points.mean(axis=0)
    return (points - middle) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) + middle


@pytest.mark.parametrize(
    "call",
    [
        lambda m, v, sp: m.warp(v, spacing=sp),
        lambda m, v, sp: m.warp(v, spacing=sp, method="backward"),
        lambda m, v, sp: m.coordinate_map(v.shape, spacing=sp),
        lambda m, v, sp: m.bounds(v.shape, spacing=sp),
        lambda m, v, sp: analysis.volume_error_field(m, v.shape, spacing=sp),
        lambda m, v, sp: analysis.cell_jacobians(m, v.shape, spacing=sp),
    ],
    ids=["quads", "backward", "coordinate_map", "bounds", "error_field", "jacobians"],
)
@pytest.mark.parametrize("weight", ["idw", "gaussian"])
def test_a_volume_beyond_the_coordinate_range_is_refused_at_warp_time(gl, volume, call, weight):
    """As glmls.MLS(shape=, spacing=) refuses it: an MLS made without a shape warps each
    volume of its own extent, whose voxels are f's points; 1e6 units and more of them (a
    spacing of 1e7 over 8 voxels) drifted by 0.18 voxel from the float64 reference."""
    with glmls.MLS(ROTATED, _turned(ROTATED), weight=weight, ctx=gl) as m:
        with pytest.raises(ValueError, match=r"volume \(6, 7, 8\) with spacing .*extent.*1e\+06"):
            call(m, volume, (1.0, 1.0, 1e7))


def test_a_volume_at_the_coordinate_range_is_warped_next_to_the_reference(gl):
    """The limit itself: a volume of 1e6 units (10 voxels of 1e5 along z) maps each output
    voxel to a source point whose float64 f lies within 0.05 voxel of it."""
    spacing = (1e5, 1.0, 1.0)
    with glmls.MLS(ROTATED, _turned(ROTATED), weight="gaussian", spacing=spacing, ctx=gl) as m:
        points, _, covered = m.coordinate_map((10, 10, 10))
        scale = np.array(spacing[::-1])
        z, y, x = np.nonzero(covered)
        f, _, _ = glmls.reference.mls(
            ROTATED,
            _turned(ROTATED),
            points[covered],
            m.config,
            shape=(10, 10, 10),
            spacing=spacing,
        )
    assert covered.mean() > 0.9
    assert np.abs(f / scale - np.stack([x, y, z], axis=1)).max() < 0.05


@pytest.mark.parametrize("mls", ["m", None, np.zeros((4, 3))])
@pytest.mark.parametrize(
    "call",
    [glmls.volume.warp_volume, glmls.volume.volume_bounds, glmls.volume.volume_coordinate_map],
)
def test_the_volume_functions_name_an_mls_that_is_none(volume, mls, call):
    """Not "this one has 2D handles", which a 2D MLS is told."""
    with pytest.raises(TypeError, match=rf"mls must be a glmls\.MLS .* got {type(mls).__name__}"):
        call(mls, volume if call is glmls.volume.warp_volume else volume.shape)
