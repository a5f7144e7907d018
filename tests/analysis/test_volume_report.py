"""volume_report and the slice pictures of a volume."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from PIL import Image

import glmls
from glmls.analysis import (
    ReferenceDeformation,
    cell_jacobians,
    error_stats,
    render_volume_slices,
    tetrahedron_errors,
    volume_error_field,
    volume_report,
)
from glmls.analysis.canvas import HANDLE_SOURCE_COLOR
from glmls.analysis.volume_pictures import NAN_VOXEL_COLOR
from glmls.analysis.volume_reporting import VOLUME_PICTURES
from glmls.volume import VolumeOptions

SHAPE = (10, 12, 14)
SRC = np.array([[2.0, 2, 2], [11, 2, 2], [2, 9, 2], [2, 2, 7], [11, 9, 7], [4, 6, 4], [9, 6, 4]])


def volume():
    z, y, x = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1], 0 : SHAPE[2]]
    return (100 + 80 * np.sin(x / 2.0) * np.cos(y / 3.0) * np.cos(z / 4.0)).astype(np.uint8)


def crossing():
    dst = SRC.copy()
    dst[5], dst[6] = SRC[6], SRC[5]  # two handles swap places: folds between them
    return ReferenceDeformation(SRC, dst, transform="affine", shape=SHAPE)


def test_the_report_holds_the_analyses_and_their_statistics(gl, tmp_path):
    m = crossing()
    found = volume_report(volume(), m, grid=2, jacobian_grid=1, out_dir=tmp_path / "out")
    field = volume_error_field(m, SHAPE, grid=2)
    assert_array_equal(found.field, field)
    summary = found.summary
    assert summary["error_field"] == error_stats(field) | {"unit": "voxel^2"}
    cells = cell_jacobians(m, SHAPE, grid=1)
    assert summary["jacobians"] == cells.stats() and summary["jacobians"]["folds"] > 0
    assert_array_equal(found.jacobians.mask, cells.mask)
    tetrahedra = tetrahedron_errors(m, SRC)  # the handles as reference points
    assert summary["tetrahedra"] == tetrahedra.stats()
    assert summary["volume"] == {
        "depth": 10,
        "height": 12,
        "width": 14,
        "channels": 1,
        "nan_voxels": 0,
        "infinite_voxels": 0,
    }
    assert summary["analysis"]["grid"] == 2 and summary["analysis"]["jacobian_grid"] == 1
    assert summary["analysis"]["slices"] == {"z": 5, "y": 6, "x": 7}
    assert summary["configuration"]["transform"] == "affine"
    assert summary["configuration"]["src"] == SRC.tolist()
    assert summary["deformed"] is False and found.deformed is None  # no m.warp
    names = {"input_handles", "error_field", "error_field_colorbar", "jacobian_det"}
    assert names | {"jacobian_det_colorbar", "folds"} == set(found.images)
    written = json.loads((tmp_path / "out" / "report.json").read_text())
    assert written["jacobians"]["folds"] == summary["jacobians"]["folds"]
    for name, picture in found.images.items():
        assert_array_equal(np.asarray(Image.open(tmp_path / "out" / f"{name}.png")), picture)


def test_a_given_deformed_volume_is_drawn_and_reference_points_used(gl):
    m = ReferenceDeformation(SRC, SRC + [1.0, 0, 0], shape=SHAPE)
    points = SRC[:5] + 0.5
    found = volume_report(volume(), m, points, grid=3, deformed=volume()[:, :, ::-1])
    assert found.summary["deformed"] is True and "deformed" in found.images
    assert found.images["deformed"].shape == found.images["input_handles"].shape
    assert list(found.images) == list(VOLUME_PICTURES)  # what the command line checks first
    assert found.summary["analysis"]["reference_points"] == "given"
    assert found.tetrahedra is not None and len(found.tetrahedra.points) == 5
    assert found.summary["jacobians"]["folds"] == 0


def test_nan_and_infinite_voxels_are_counted_and_drawn_apart(gl):
    finite = volume().astype(np.float32)
    values = finite.copy()
    values[5, 1, 12] = values[0, 0, 0] = np.nan  # outside a scan's field of view
    values[5, 10, 1] = np.inf
    values[:, 11, 13] = np.nan  # a whole column along z: NaN on the projection too
    m = crossing()
    found = volume_report(values, m, grid=3)
    assert found.summary["volume"]["nan_voxels"] == 12
    assert found.summary["volume"]["infinite_voxels"] == 1
    assert_array_equal(found.field, volume_error_field(m, SHAPE, grid=3))  # not the voxels'
    picture = found.images["input_handles"]  # 20 pixels a voxel, the z slice at z = 5
    at = lambda x, y: picture[20 * y + 10, 20 * x + 10].tolist()  # noqa: E731
    assert at(12, 1) == at(13, 11) == list(NAN_VOXEL_COLOR)
    assert at(1, 10) == [255, 255, 255]
    lo, hi = float(np.nanmin(finite)), float(np.nanmax(finite))  # the finite voxels' scale
    grey = round((float(values[5, 3, 3]) - lo) / (hi - lo) * 255)
    assert at(3, 3) == [grey] * 3
    projection = picture[20 * 12 + 6 :, 20 * 14 + 6 :]
    assert projection[20 * 11 + 10, 20 * 13 + 10].tolist() == list(NAN_VOXEL_COLOR)
    top = np.fmax.reduce(values, axis=0)[1, 6]  # the finite voxels' maximum along z
    assert projection[30, 130].tolist() == [round((float(top) - lo) / (hi - lo) * 255)] * 3


def test_coplanar_handles_leave_the_tetrahedra_out_but_given_points_must_form_them(gl):
    flat = SRC.copy()
    flat[:, 2] = 3.0
    m = ReferenceDeformation(flat, flat + [0.0, 1, 0], shape=SHAPE)
    found = volume_report(volume(), m, grid=4)
    assert found.tetrahedra is None and "one plane" in found.summary["tetrahedra"]["skipped"]
    with pytest.raises(ValueError, match="one plane"):
        volume_report(volume(), m, np.unique(flat, axis=0), grid=4)


def test_the_users_tetrahedra_over_the_handles_are_checked_not_left_out(gl):
    m = ReferenceDeformation(SRC, SRC + 1.0, shape=SHAPE)
    with pytest.raises(ValueError, match=r"tetrahedra\[1\] is \[0, 1, 2, 9\]"):
        volume_report(volume(), m, grid=4, tetrahedra=[[0, 1, 2, 3], [0, 1, 2, 9]])
    found = volume_report(volume(), m, grid=4, tetrahedra=[[0, 1, 2, 3]], warp=False)
    assert found.summary["tetrahedra"]["tetrahedra"] == 1


def test_the_users_tetrahedra_index_the_handles_as_they_are_repeats_included(gl):
    src = np.concatenate([SRC[:1], SRC])  # the first handle twice
    m = ReferenceDeformation(src, src + [1.0, 0, 0], shape=SHAPE)
    found = volume_report(volume(), m, grid=4, tetrahedra=[[1, 2, 3, 4], [4, 5, 6, 7]], warp=False)
    assert_array_equal(found.tetrahedra.points, src)
    kept = found.tetrahedra.simplices
    assert_array_equal(found.tetrahedra.points[kept], src[[[1, 2, 3, 4], [4, 5, 6, 7]]])


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"volume": np.zeros((4, 4))}, ValueError, "D, H, W"),
        ({"volume": np.zeros((4, 4, 4), complex)}, TypeError, "real numbers"),
        ({"volume": np.full((4, 4, 4), np.nan)}, ValueError, "no finite value"),
        ({"grid": 0}, ValueError, "grid"),
        ({"jacobian_grid": -1}, ValueError, "jacobian_grid"),
        ({"angle": "radians"}, ValueError, "angle"),
        ({"slices": (1, 2)}, ValueError, "slices"),
        ({"slices": (10, 0, 0)}, ValueError, "slices"),
        ({"deformed": np.zeros((3, 3, 3), np.uint8)}, ValueError, r"deformed has shape \(3, 3"),
        ({"warp_options": {"method": "backward"}}, TypeError, "warp_options must be a glmls"),
        ({"warp": "no"}, TypeError, "warp must be True or False, got 'no'"),
        (
            {"warp_options": VolumeOptions(output_shape=(4, 4, 4))},
            ValueError,
            r"warp_options.output_shape is \(4, 4, 4\); .* output_shape \(10, 12, 14\)",
        ),
        ({"warp_options": VolumeOptions(origin=(1, 0, 0))}, ValueError, "warp_options.origin"),
        ({"warp_options": VolumeOptions(spacing=(2, 1, 1))}, ValueError, "warp_options.spacing"),
    ],
)
def test_bad_arguments_raise_before_the_work(kwargs, error, message):
    arguments = {"volume": volume()} | kwargs
    with pytest.raises(error, match=message):
        volume_report(arguments.pop("volume"), crossing(), **arguments)


def test_the_slice_layout():
    z, y, x = np.mgrid[0:4, 0:5, 0:6]
    values = (10 * x + 50 * y + 100 * z).astype(np.uint8)  # every voxel its own grey
    picture = render_volume_slices(values, slices=(1, 2, 3), scale=1)
    # views: z slice (5, 6) | x slice (5, 4) / y slice (4, 6) | projection along z (5, 6)
    gap = 6
    assert picture.shape == (5 + gap + 5, 6 + gap + 6, 3)
    assert_array_equal(picture[:5, :6, 0], values[1])
    assert_array_equal(picture[:5, 6 + gap : 6 + gap + 4, 0], values[:, :, 3].T)
    assert_array_equal(picture[5 + gap : 5 + gap + 4, :6, 0], values[:, 2])
    assert_array_equal(picture[5 + gap :, 6 + gap :, 0], values.max(axis=0))
    low = render_volume_slices(values, slices=(1, 2, 3), scale=1, projection="min")
    assert_array_equal(low[5 + gap :, 6 + gap :, 0], values.min(axis=0))
    scaled = render_volume_slices(values, slices=(1, 2, 3), scale=3)
    assert scaled.shape == (3 * 10 + gap, 3 * 12 + gap, 3)
    assert_array_equal(scaled[: 3 * 5 : 3, : 3 * 6 : 3, 0], values[1])


def test_a_volume_one_voxel_thick_is_drawn_at_a_size_that_fits_its_other_sides():
    values = (np.arange(12 * 16).reshape(1, 12, 16) % 251).astype(np.uint8)
    picture = render_volume_slices(values)
    gap = 6
    # the thin side alone would ask for 192 pixels a voxel: views of 12 x 192 by 16 x 192
    assert max(picture.shape[:2]) <= 2 * 1024 + gap
    scale = (picture.shape[1] - gap) // (2 * 16)
    assert scale * 16 <= 1024 and scale * 12 >= 192
    assert_array_equal(picture[: 12 * scale : scale, : 16 * scale : scale, 0], values[0])
    assert_array_equal(picture[: 12 * scale : scale, 16 * scale + gap, 0], values[0, :, 8])


def test_anisotropic_voxels_are_drawn_in_their_proportions(gl):
    """Slices 3 units apart along z and 1 along y and x: the views across z are 3 times as
    long there, each voxel where the cubic picture put it, and handles (in voxels) on them."""
    values = (np.arange(4 * 5 * 6).reshape(4, 5, 6) * 2).astype(np.uint8)
    picture = render_volume_slices(values, slices=(1, 2, 3), scale=2, spacing=(3.0, 1.0, 1.0))
    gap = 6
    # z slice (10, 12) | x slice (10, 24) / y slice (24, 12) | projection (10, 12)
    assert picture.shape == (10 + gap + 24, 12 + gap + 24, 3)
    assert_array_equal(picture[:10:2, :12:2, 0], values[1])
    assert_array_equal(picture[:10:2, 12 + gap : 12 + gap + 24 : 6, 0], values[:, :, 3].T)
    assert_array_equal(picture[10 + gap : 10 + gap + 24 : 6, :12:2, 0], values[:, 2])
    cubic = render_volume_slices(values, slices=(1, 2, 3), scale=2, spacing=(2.5, 2.5, 2.5))
    assert_array_equal(cubic, render_volume_slices(values, slices=(1, 2, 3), scale=2))
    # a handle at z = 3 sits on the y slice 3 x 6 + 2.5 picture rows down, column 2 x 2 + 0.5
    src = np.array([[2.0, 2, 3]])
    drawn = render_volume_slices(
        np.zeros((4, 5, 6), np.uint8), src=src, dst=src, slices=(3, 2, 3), scale=2,
        spacing=(3, 1, 1),
    )  # fmt: skip
    assert drawn[10 + gap + 20, 4, :].tolist() == list(HANDLE_SOURCE_COLOR)
    with pytest.raises(ValueError, match="spacing must be three"):
        render_volume_slices(values, spacing=(1.0, 0.0, 1.0))
    with pytest.raises(TypeError, match="spacing must be three"):
        render_volume_slices(values, spacing=(1.0, "1", 1.0))


def test_a_constant_volume_is_drawn_from_0_to_its_value_not_black():
    values = np.full((4, 5, 6), 700, np.uint16)
    picture = render_volume_slices(values, scale=1)
    assert (picture[:5, :6] == 255).all()  # the z slice
    assert (picture[5 + 6 :, 6 + 6 :] == 255).all()  # the projection
    # a deformed volume drawn at the input's limits: its background (0) black beside it
    lower = values.copy()
    lower[0] = 0
    drawn = render_volume_slices(lower, vmin=700.0, vmax=700.0, slices=(2, 2, 2), scale=1)
    assert (drawn[5 + 6, :6] == 0).all() and (drawn[5 + 6 + 1, :6] == 255).all()
    assert (render_volume_slices(np.zeros((4, 5, 6)), scale=1)[:5, :6] == 0).all()


def test_a_field_is_coloured_and_a_mask_tinted():
    field = np.zeros((4, 5, 6))
    field[2, 1, 1] = 1.0
    picture = render_volume_slices(field, cmap="linear", slices=(2, 0, 0), scale=1)
    assert picture[1, 1].tolist() == [220, 0, 0] and picture[0, 0].tolist() == [255, 255, 255]
    mask = np.zeros((4, 5, 6), bool)
    mask[2, 3, 4] = True
    tinted = render_volume_slices(np.zeros((4, 5, 6)), mask=mask, slices=(2, 0, 0), scale=1)
    assert tinted[3, 4, 0] > 100 and tinted[3, 4, 1] < 50 and tinted[0, 0].tolist() == [0] * 3


def test_handles_are_drawn_on_the_slices_near_them(gl):
    values = np.zeros((20, 20, 20), np.uint8)
    src = np.array([[5.0, 5, 10], [15, 15, 2]])
    picture = render_volume_slices(
        values, src=src, dst=src + [2.0, 0, 0], slices=(10, 10, 10), near=2, scale=4
    )
    at = lambda point: picture[int(point[1] * 4 + 1.5), int(point[0] * 4 + 1.5)]  # noqa: E731
    assert at(src[0]).tolist() == list(HANDLE_SOURCE_COLOR)  # within 2 of z = 10
    assert at(src[1]).tolist() == [0, 0, 0]  # z = 2: not on the z slice
    projection = picture[80 + 6 :, 80 + 6 :]  # every handle on the projection
    assert projection[15 * 4 + 1, 15 * 4 + 1].tolist() == list(HANDLE_SOURCE_COLOR)


def test_bad_pictures_raise():
    with pytest.raises(ValueError, match="volume must be"):
        render_volume_slices(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="mask"):
        render_volume_slices(np.zeros((4, 4, 4)), mask=np.zeros((4, 4), bool))
    with pytest.raises(ValueError, match="scale"):
        render_volume_slices(np.zeros((4, 4, 4)), scale=0)
    with pytest.raises(ValueError, match="projection"):
        render_volume_slices(np.zeros((4, 4, 4)), projection="mean")
    # a scale beyond the largest picture was numpy's MemoryError (43.7 TiB at 10**6)
    for scale, side in ((10**6, 4000000), (4097, 16388)):
        with pytest.raises(ValueError, match=rf"^scale {scale} makes a view {side} pixels on a"):
            render_volume_slices(np.zeros((4, 4, 4)), scale=scale)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        render_volume_slices(np.zeros((4, 4, 4)), src=[[1, 1]], dst=[[1, 1]])


def test_glmls_analysis_exports_the_3d_names():
    for name in ("volume_report", "VolumeReport", "cell_jacobians", "tetrahedron_errors"):
        assert name in glmls.analysis.__all__


def test_on_the_gpu_the_report_matches_the_reference_and_warps_the_volume(gl):
    pytest.importorskip("glmls.volume")
    dst = SRC.copy()
    dst[5], dst[6] = SRC[6], SRC[5]
    with glmls.MLS(SRC, dst, transform="affine", shape=SHAPE, ctx=gl) as m:
        found = volume_report(volume(), m, grid=2)
        warped = m.warp(volume())
    assert_array_equal(found.deformed, warped)
    assert found.summary["deformed"] is True and "deformed" in found.images
    exact = volume_report(volume(), crossing(), grid=2)
    for key in ("mean", "median", "max"):
        assert found.summary["error_field"][key] == pytest.approx(
            exact.summary["error_field"][key], rel=1e-4
        )
    # float32 on the GPU: a cell whose det J is within rounding of 0 may go either way
    assert abs(found.jacobians.count - exact.jacobians.count) <= 2
    assert found.jacobians.count > 0
    assert_array_equal(found.tetrahedra.inverted, exact.tetrahedra.inverted)


def test_the_report_names_the_radius_it_evaluated_with(gl):
    """A radius weight given no radius: the analysed volume's diagonal, in the handles' units
    with a spacing; a given radius as given; None for a weight without one."""
    dst = SRC + 0.5
    spacing = (2.0, 1.0, 0.5)
    made = ReferenceDeformation(SRC, dst, weight="gaussian", shape=SHAPE, spacing=spacing)
    summary = volume_report(volume(), made, grid=4, jacobian_grid=4).summary
    diagonal = float(np.sqrt(20.0**2 + 12.0**2 + 7.0**2))  # (D dz, H dy, W dx) = (20, 12, 7)
    assert summary["configuration"]["radius_used"] == pytest.approx(diagonal)
    given = ReferenceDeformation(SRC, dst, weight="gaussian", radius=9.0, shape=SHAPE)
    assert volume_report(volume(), given, grid=4).summary["configuration"]["radius_used"] == 9.0
    idw = ReferenceDeformation(SRC, dst, shape=SHAPE)
    assert volume_report(volume(), idw, grid=4).summary["configuration"]["radius_used"] is None


def test_a_glmls_volume_is_named_with_its_data(tmp_path):
    glmls.write_volume(tmp_path / "v.npy", np.zeros((6, 7, 8), np.uint8))
    src = np.array([[1.0, 1, 1], [6, 1, 1], [1, 5, 1], [1, 1, 4], [6, 5, 4]])
    m = glmls.analysis.ReferenceDeformation(src, src + 0.5)
    with pytest.raises(TypeError, match=r"glmls\.Volume.*\.data"):
        glmls.analysis.volume_report(glmls.read_volume(tmp_path / "v.npy"), m)


def test_the_error_colorbar_names_voxels_for_unit_spacing():
    """E_MLS is in square voxels where a voxel is 1 x 1 x 1, given as spacing or not (as
    ``glmls analyze`` says), in square handle units otherwise."""
    from glmls.analysis import colormaps

    m = crossing()
    for spacing, unit in (((1.0, 1.0, 1.0), "voxel"), ((2.0, 1.0, 1.0), "unit")):
        found = volume_report(volume(), m, grid=4, spacing=spacing)
        lo, hi = found.summary["analysis"]["error_field_limits"]
        expected = colormaps.colorbar("viridis", lo, hi, length=256, label=f"E_MLS ({unit}^2)")
        assert_array_equal(found.images["error_field_colorbar"], expected)


def test_a_volume_of_a_dtype_the_gpu_does_not_warp_is_warped_as_float32(gl):
    pytest.importorskip("glmls.volume")
    dst = SRC.copy()
    dst[5] += [1.0, 0.5, 0.0]
    values = volume().astype(np.int16) - 100  # negative values too
    stages = []
    with glmls.MLS(SRC, dst, shape=SHAPE, ctx=gl) as m:
        found = volume_report(values, m, grid=2, on_stage=stages.append)
        warped = m.warp(values.astype(np.float32))
    assert "warp" in stages and found.deformed.dtype == np.float32
    assert_array_equal(found.deformed, warped)


def test_a_bool_mask_is_analysed_and_warped_as_its_0_and_1_in_float32(gl):
    pytest.importorskip("glmls.volume")
    dst = SRC.copy()
    dst[5] += [1.0, 0.5, 0.0]
    mask = volume() > 120
    with glmls.MLS(SRC, dst, shape=SHAPE, ctx=gl) as m:
        found = volume_report(mask, m, grid=2)
        numbers = volume_report(mask.astype(np.float32), m, grid=2)
    assert found.deformed.dtype == np.float32
    assert_array_equal(found.deformed, numbers.deformed)
    for name, picture in numbers.images.items():
        assert_array_equal(found.images[name], picture, err_msg=name)


def test_a_plain_function_is_a_type_error_saying_what_the_report_needs():
    with pytest.raises(TypeError, match=r"m must be a glmls.MLS .*got function, without src"):
        volume_report(volume(), lambda p: p)


class Warping:
    """The crossing deformation, its warp recording the options it is called with."""

    def __init__(self):
        self.inner, self.calls = crossing(), []
        self.src, self.dst, self.matrices = self.inner.src, self.inner.dst, self.inner.matrices

    def __call__(self, points):
        return self.inner(points)

    def warp(self, volume, **options):
        self.calls.append(options)
        return volume[:, :, ::-1]


def test_the_summary_says_how_the_deformed_volume_was_made():
    m = Warping()
    found = volume_report(volume(), m, grid=3)
    assert m.calls == [{}]  # the defaults: any warp(volume) takes them
    assert found.summary["warp"] == {
        "method": "quads",
        "interpolation": "nearest",
        "grid": 1,
        "border": "constant",
        "background": 0.0,
        "output_shape": [10, 12, 14],
        "origin": [0.0, 0.0, 0.0],
        "spacing": [1.0, 1.0, 1.0],
    }
    options = VolumeOptions(method="backward", interpolation="linear", border="wrap")
    found = volume_report(volume(), m, grid=3, warp_options=options, spacing=(2, 1, 1))
    assert m.calls[-1] == {
        "method": "backward", "interpolation": "linear", "border": "wrap", "spacing": (2, 1, 1)
    }  # fmt: skip
    warp = json.loads(found.to_json())["warp"]
    assert (warp["method"], warp["interpolation"], warp["border"]) == ("backward", "linear", "wrap")
    assert warp["grid"] == 2 and warp["spacing"] == [2.0, 1.0, 1.0]  # backward's own step
    given = volume()[:, ::-1]
    assert volume_report(volume(), m, grid=3, deformed=given).summary["warp"] is None
    recorded = volume_report(volume(), m, grid=3, deformed=given, warp_options=options)
    assert recorded.summary["warp"]["method"] == "backward"
    assert volume_report(volume(), crossing(), grid=3).summary["warp"] is None  # none made
