"""The colour scales of the analysis pictures: a least span, so that a deformation exact but
for rounding is pictured in one colour."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.analysis import ReferenceDeformation, colormaps, volume_report


def rotation(points, angle, centre):
    """``points`` rotated by ``angle`` (radians) about ``centre`` in their first two axes."""
    c, s = np.cos(angle), np.sin(angle)
    turned = np.array(points, dtype=np.float64)
    x, y = turned[:, 0] - centre[0], turned[:, 1] - centre[1]
    turned[:, 0], turned[:, 1] = centre[0] + c * x - s * y, centre[1] + s * x + c * y
    return turned


@pytest.mark.parametrize(
    ("values", "options", "expected"),
    [
        ([2e-7, 3e-6], {"vmin": 0.0, "span": 1e-3}, (0.0, 1e-3)),  # hi raised
        ([2e-7, 3e-6], {"vmax": 1.0, "span": 2.0}, (-1.0, 1.0)),  # lo lowered
        ([1.0 - 1e-9, 1.0 + 1e-9], {"span": 1e-3}, (0.9995, 1.0005)),  # about the middle
        ([0.0, 5.0], {"span": 1e-3}, (0.0, 5.0)),  # wide enough: unchanged
        ([0.0, 5.0, 100.0], {"percentile": 50, "span": 1.0}, (0.0, 5.0)),
        ([3.0, 3.0], {}, (3.0, 3.0)),  # no span: as before
        ([], {"span": 0.5}, (0.0, 1.0)),  # no finite value
        ([1.0, 2.0], {"vmin": 1.0, "vmax": 1.25, "span": 1.0}, (1.0, 1.25)),  # both given
    ],
)
def test_the_least_span_moves_the_limits_the_values_set(values, options, expected):
    assert colormaps.color_limits(values, **options) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("span", "error"),
    [(-1.0, ValueError), (np.nan, ValueError), (np.inf, ValueError), (True, TypeError)],
)
def test_a_bad_span_is_named(span, error):
    with pytest.raises(error, match="span"):
        colormaps.color_limits([0.0, 1.0], span=span)


def test_picture_limits_by_quantity():
    tiny = [1e-9, 2e-9]
    close = pytest.approx
    assert colormaps.picture_limits("E_MLS", tiny) == close((1e-9, 1e-9 + 1e-6), abs=1e-18)
    assert colormaps.picture_limits("E_MLS", tiny, unit=0.5) == close((1e-9, 1e-9 + 0.25e-6))
    # the distance error is relative: its span does not follow the unit of length
    assert colormaps.picture_limits("distance", tiny, unit=0.5) == close((1e-9, 1e-9 + 1e-3))
    assert colormaps.picture_limits("angle", tiny) == close((1e-9, 1e-9 + 1e-3))
    # wide enough: the least error (white at the minimum, as the paper's figures) to the most
    assert colormaps.picture_limits("angle", [0.5, 2.0, 40.0]) == (0.5, 40.0)
    assert colormaps.picture_limits("construction", [0.2, 0.4]) == (0.0, 0.4)  # from 0
    assert colormaps.picture_limits("det_j", [0.5, 2.0]) == (0.5, 2.0)
    assert colormaps.picture_limits("det_j", [1.0, 1.0]) == close((0.9995, 1.0005))
    with pytest.raises(ValueError, match="quantity"):
        colormaps.picture_limits("E", tiny)
    with pytest.raises(ValueError, match="unit"):
        colormaps.picture_limits("E_MLS", tiny, unit=0.0)
    with pytest.raises(TypeError, match="unit"):
        colormaps.picture_limits("E_MLS", tiny, unit="1")


def test_a_large_error_field_equal_but_for_float32_takes_one_colour():
    """E_MLS of a global fit is the same everywhere, about 260 px², and the GPU's float32
    rounds it by about 1e-4 px² from pixel to pixel: the scale spans 1e-3 of it, so that
    the picture is one colour rather than that rounding stretched over the map."""
    rounding = 260.0 + np.array([-9e-5, 0.0, 3e-5])
    lo, hi = colormaps.picture_limits("E_MLS", rounding)
    assert lo == rounding.min() and hi == pytest.approx(lo + 260.00003e-3)
    colours = colormaps.apply_colormap(rounding, vmin=lo, vmax=hi)
    assert (colours == colours[0]).all()
    # a variation of 1e-4 of the field shows
    varied = colormaps.apply_colormap([260.0, 260.026], vmin=lo, vmax=hi)
    assert (varied[0] != varied[1]).any()
    # a field that does vary keeps its whole scale
    assert colormaps.picture_limits("E_MLS", [10.0, 260.0]) == (10.0, 260.0)


def test_a_rotation_reports_no_colour_for_its_rounding(gl, rng):
    """A rigid rotation keeps every angle: its reference triangles' angle errors are float32
    rounding (about 1e-6 degrees), and the report's scales reach the least spans above the
    least values, so every triangle takes the bottom colour, as does the error field."""
    shape = (64, 80)
    src = rng.uniform(8, 56, (8, 2)) * [1.2, 1.0]
    reference = rng.uniform(4, 60, (12, 2)) * [1.2, 1.0]
    dst = rotation(src, 0.3, (40.0, 32.0)) + [2.0, -1.5]
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    with glmls.MLS(src, dst, transform="rigid", ctx=gl) as m:
        found = glmls.analysis.report(image, m, reference, grid=2)
    angles = found.triangles.angle
    assert 0.0 < np.nanmax(angles) < 1e-3  # rounding, not exactly 0
    analysis = found.summary["analysis"]
    least = float(np.nanmin(angles))
    assert analysis["triangle_limits"] == pytest.approx([least, least + 1e-3])
    lo, hi = analysis["error_field_limits"]
    assert lo == found.summary["error_field"]["min"] and hi == pytest.approx(lo + 1e-6)
    assert found.summary["error_field"]["max"] < lo + 1e-6
    t_lo, t_hi = analysis["triangle_limits"]
    expected = colormaps.colorbar("viridis", t_lo, t_hi, length=64, label="angle error")
    assert_array_equal(found.images["triangle_angle_colorbar"], expected)


def test_a_rotated_volume_pictures_det_j_as_one(gl):
    """det J of a rotation is 1 but for float64 rounding: its picture's scale spans 1e-3
    about it instead of stretching the rounding over the whole map."""
    shape = (8, 9, 10)
    src = np.array([[1.0, 1, 1], [8, 1, 1], [1, 7, 1], [1, 1, 6], [8, 7, 6], [4, 3, 2]])
    m = ReferenceDeformation(src, rotation(src, 0.4, (4.5, 4.0)), transform="rigid", shape=shape)
    data = np.arange(np.prod(shape), dtype=np.float32).reshape(shape)
    found = volume_report(data, m, grid=2, warp=False)
    det = found.jacobians.det
    assert np.abs(det - 1.0).max() < 1e-9
    lo, hi = colormaps.picture_limits("det_j", det)
    assert hi - lo == pytest.approx(1e-3)
    expected = colormaps.colorbar("viridis", lo, hi, length=256, label="det J")
    assert_array_equal(found.images["jacobian_det_colorbar"], expected)
    lo, hi = found.summary["analysis"]["error_field_limits"]
    assert hi - lo == pytest.approx(1e-6)
