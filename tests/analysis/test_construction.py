"""The construction error (paper section 6's missing metric): exact zeros for copies of the input,
a float64 loop written from the definition, the orderings it is meant to show (splat's holes,
nearest against linear), the canvas origin, the picture, the report and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import smooth_handles
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.analysis.colormaps import NAN_COLOR, apply_colormap
from glmls.analysis.construction import ConstructionErrors, construction_errors
from glmls.analysis.pictures import render_construction_errors

SHAPE = (96, 128)


def smooth_image(shape=SHAPE):
    """Sinusoids a few pixels long in three channels: smooth, but not linear over a window."""
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    channels = [np.sin(xx / 7 + yy / 11), np.cos(yy / 5), np.sin((xx + yy) / 9)]
    return np.round(127.5 + 120 * np.stack(channels, -1)).astype(np.uint8)


def interior_points(rng, n=30, shape=SHAPE, margin=16):
    return rng.uniform(margin, [shape[1] - margin, shape[0] - margin], (n, 2))


def loop_errors(image, output, f, jacobian, points, radius, scale):
    """The definition point by point with plain float64 arithmetic and a hand-written bilinear
    sample (edges clamped); no snapping (the maps used here put no sample within 1e-3 px of a
    pixel centre). NaN where the window leaves either image."""
    height, width = image.shape[:2]
    out = []
    for r in points:
        fr, inverse = f(r[None])[0], np.linalg.inv(jacobian(r))
        cx, cy = int(np.rint(fr[0])), int(np.rint(fr[1]))
        total, count, defined = 0.0, 0, True
        for oy in range(-radius, radius + 1):
            for ox in range(-radius, radius + 1):
                u = np.array([cx + ox, cy + oy], dtype=np.float64)
                s = r + (u - fr) @ inverse
                if not (0 <= u[0] < output.shape[1] and 0 <= u[1] < output.shape[0]):
                    defined = False
                if not (-0.5 <= s[0] <= width - 0.5 and -0.5 <= s[1] <= height - 0.5):
                    defined = False
                x0, y0 = int(np.floor(s[0])), int(np.floor(s[1]))
                tx, ty = s[0] - x0, s[1] - y0
                for c in range(image.shape[2]):

                    def at(x, y, c=c):
                        return float(
                            image[min(max(y, 0), height - 1), min(max(x, 0), width - 1), c]
                        )

                    ideal = (1 - ty) * ((1 - tx) * at(x0, y0) + tx * at(x0 + 1, y0)) + ty * (
                        (1 - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1)
                    )
                    if defined:
                        got = float(output[int(u[1]), int(u[0]), c])
                        total += (got - ideal) ** 2
                        count += 1
        out.append(np.sqrt(total / count) / scale if defined else np.nan)
    return np.array(out)


# -- exact zeros ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("method", "interpolation"),
    [("quads", "nearest"), ("quads", "linear"), ("backward", "linear"), ("splat", "nearest")],
)
def test_identity_gives_exactly_zero(gl, rng, method, interpolation):
    image = rng.integers(0, 256, (*SHAPE, 3), dtype=np.uint8)  # noise: any offset would show
    src = smooth_handles(SHAPE, rng)[0]
    points = interior_points(rng)
    with glmls.MLS(src, src.copy(), shape=SHAPE, ctx=gl) as m:
        output = m.warp(image, method=method, interpolation=interpolation)
        errors = construction_errors(image, output, m, points)
    assert errors.values.shape == (len(points),)
    assert (errors.values == 0).all(), errors.values
    assert errors.stats()["mean"] == 0 and errors.stats()["nan_count"] == 0


@pytest.mark.parametrize(
    ("method", "interpolation"),
    [("quads", "nearest"), ("quads", "linear"), ("splat", "nearest"), ("backward", "linear")],
)
def test_an_integer_translation_gives_zero(gl, rng, method, interpolation):
    image = rng.integers(0, 65536, (*SHAPE, 3), dtype=np.uint16)
    shift = np.array([5.0, -3.0])
    points = np.concatenate([interior_points(rng), [[0.5, 50.0]]])  # the last sees past x = 0
    with glmls.MLS([[60.0, 40.0]], [[65.0, 37.0]], shape=SHAPE, ctx=gl) as m:
        output = m.warp(image, method=method, interpolation=interpolation)
        errors = construction_errors(image, output, m, points)
        edged = m.warp(image, method=method, interpolation=interpolation, border="edge")
        edge = construction_errors(image, edged, m, points, border="edge")
    assert_allclose(errors.deformed_points, points + shift, rtol=0, atol=1e-12)
    assert (errors.values[:-1] == 0).all(), errors.values
    # constant border: the window's preimage leaves the image, so the point is undefined
    assert np.isnan(errors.values[-1])
    # any other border defines the input beyond its edge, in the warp as in the metric
    if method != "splat":  # splat moves pixels only; nothing of the border reaches x < 5
        assert (edge.values == 0).all(), edge.values


# -- the definition, in float64 -------------------------------------------------------------


def quadratic_map(v):
    """A map with curvature whose central differences are exact (third derivatives are 0)."""
    x, y = v[:, 0], v[:, 1]
    return np.stack(
        [3.0 + 1.1 * x - 0.2 * y + 0.002 * x * y, -2.0 + 0.15 * x + 0.9 * y + 0.003 * x * x], 1
    )


def quadratic_jacobian(r):
    x, y = r
    return np.array([[1.1 + 0.002 * y, 0.15 + 0.006 * x], [-0.2 + 0.002 * x, 0.9]])


@pytest.mark.parametrize("dtype", [np.float64, np.uint8, np.uint16])
def test_matches_a_loop_written_from_the_definition(rng, dtype):
    """Independent of the GPU: any output array against any map, every sample by hand."""
    shape = (60, 72)
    top = 1.0 if dtype == np.float64 else np.iinfo(dtype).max
    image = (rng.uniform(0, 1, (*shape, 3)) * top).astype(dtype)
    output = (rng.uniform(0, 1, (*shape, 3)) * top).astype(dtype)
    points = np.concatenate([rng.uniform(8, 50, (12, 2)), [[1.0, 30.0], [66.0, 58.0]]])
    errors = construction_errors(image, output, quadratic_map, points, radius=2, snap=0.0)
    expected = loop_errors(
        image, output, quadratic_map, quadratic_jacobian, points, 2, 255.0 if top == 255 else top
    )
    # float64 throughout: only the order of the sums differs (and the Jacobian's difference
    # quotient, exact for a quadratic up to rounding)
    assert_allclose(errors.values, expected, rtol=1e-10, atol=1e-12, equal_nan=True)
    assert np.isnan(errors.values[-2:]).all()  # near the edges: windows leave the images
    assert_allclose(errors.matrices, [quadratic_jacobian(r) for r in points], atol=1e-12)
    assert errors.scale == top


def test_the_gpu_map_matches_the_float64_reference(gl, rng):
    image = smooth_image()
    src, dst = smooth_handles(SHAPE, rng)
    points = interior_points(rng, 20)

    def f(v):
        return reference.mls(src, dst, v, transform="rigid", shape=SHAPE)[0]

    def jacobian(r):
        h = 0.5
        dx = (f(r[None] + [h, 0]) - f(r[None] - [h, 0]))[0] / (2 * h)
        dy = (f(r[None] + [0, h]) - f(r[None] - [0, h]))[0] / (2 * h)
        return np.stack([dx, dy])

    with glmls.MLS(src, dst, shape=SHAPE, ctx=gl) as m:
        output = m.warp(image, method="quads", interpolation="linear")
        errors = construction_errors(image, output, m, points)
    expected = loop_errors(image, output, f, jacobian, points, 2, 255.0)
    # f on the GPU is float32: ~1e-5 px, which moves a sample's colour by far less than 1e-4
    assert_allclose(errors.values, expected, rtol=0, atol=1e-4, equal_nan=True)
    assert_allclose(errors.deformed_points, f(points), atol=1e-3)


# -- what it is for -------------------------------------------------------------------------


def scale_by_two(gl):
    centre = np.array([SHAPE[1] - 1, SHAPE[0] - 1]) / 2
    src = centre + np.array([[-30.0, -30.0], [30.0, -30.0], [30.0, 30.0], [-30.0, 30.0]])
    return glmls.MLS(src, centre + 2 * (src - centre), transform="similarity", ctx=gl)


def test_splat_scores_far_worse_than_quads_under_magnification(gl, rng):
    image = smooth_image()
    centre = np.array([SHAPE[1] - 1, SHAPE[0] - 1]) / 2
    points = centre + rng.uniform(-18, 18, (30, 2))  # f(r) stays inside the frame
    means = {}
    with scale_by_two(gl) as m:
        for method in ("quads", "splat"):
            output = m.warp(image, method=method)
            errors = construction_errors(image, output, m, points)
            assert not np.isnan(errors.values).any()
            means[method] = errors.stats()["mean"]
    # splat writes one output pixel in four: holes of background in every window
    assert means["splat"] > 10 * means["quads"], means
    assert means["splat"] > 0.2 and means["quads"] < 0.03, means


def test_linear_beats_nearest_on_smooth_images(gl, rng):
    image = smooth_image()
    src, dst = smooth_handles(SHAPE, rng)
    points = interior_points(rng, 40)
    means = {}
    with glmls.MLS(src, dst, shape=SHAPE, ctx=gl) as m:
        for method in ("quads", "backward"):
            for interpolation in ("nearest", "linear"):
                output = m.warp(image, method=method, interpolation=interpolation)
                errors = construction_errors(image, output, m, points)
                means[method, interpolation] = errors.stats()["mean"]
        matrix = construction_errors(image, output, m, points, alignment="matrix")
        big_m, _ = m.matrices(points)
    assert means["quads", "linear"] < 0.3 * means["quads", "nearest"], means
    assert means["backward", "linear"] < 0.3 * means["backward", "nearest"], means
    # both linear constructions are near the ideal: 8-bit rounding and f's curvature
    assert means["quads", "linear"] < 0.005 and means["backward", "linear"] < 0.005, means
    # aligned by the MLS's M(r) instead of Df(r), the deformation leaks into the error
    assert_allclose(matrix.matrices, big_m, rtol=0, atol=0)
    assert matrix.stats()["mean"] > 2 * means["backward", "linear"]


def test_another_canvas_with_its_origin(gl, rng):
    image = smooth_image()
    src, dst = smooth_handles(SHAPE, rng)
    dst = dst + rng.uniform(-12, 12, dst.shape)
    points = interior_points(rng, 30)
    with glmls.MLS(src, dst, shape=SHAPE, ctx=gl) as m:
        plain = construction_errors(image, m.warp(image), m, points)
        b = m.bounds(SHAPE)
        whole = m.warp(image, output_shape=b.output_shape, origin=b.origin)
        fitted = construction_errors(image, whole, m, points, origin=b.origin)
        with pytest.raises(ValueError, match="origin"):
            construction_errors(image, whole, m, points)
    assert fitted.origin == tuple(b.origin)
    both = ~np.isnan(plain.values)
    assert both.sum() >= 20
    assert_allclose(fitted.values[both], plain.values[both], rtol=0, atol=1e-12)
    assert_allclose(fitted.centres - plain.centres, [np.rint(np.negative(b.origin))] * 30)


# -- undefined points and bad input ---------------------------------------------------------


def test_singular_maps_and_no_points(rng):
    image = rng.integers(0, 256, (40, 40), dtype=np.uint8)

    def collapse(v):
        return np.stack([np.full(len(v), 20.0), v[:, 1]], 1)  # every x to 20

    errors = construction_errors(image, image, collapse, [[20.0, 20.0], [15.0, 10.0]])
    assert np.isnan(errors.values).all()
    assert errors.stats()["nan_count"] == 2 and errors.stats()["mean"] is None
    empty = construction_errors(image, image, collapse, np.zeros((0, 2)))
    assert empty.values.shape == (0,) and empty.matrices.shape == (0, 2, 2)


def test_result_is_frozen_and_json_ready(rng):
    image = rng.uniform(0, 1, (30, 30)).astype(np.float32)
    errors = construction_errors(image, image, lambda v: v + 0.0, [[10.0, 12.0], [20.0, 9.5]])
    assert isinstance(errors, ConstructionErrors) and errors.scale == 1.0
    assert (errors.values == 0).all()
    with pytest.raises(ValueError):
        errors.values[0] = 1.0
    json.dumps({"stats": errors.stats(), "settings": errors.settings()})
    assert errors.settings()["window"] == 5


def bad_cases(image):
    ok = [[10.0, 10.0]]
    ident = lambda v: v  # noqa: E731

    def wrong_shape(v):
        return v[:, :1]

    return [
        ((image.astype(bool), image, ident, ok), {}, TypeError, "image dtype"),
        ((image.astype(np.int64), image, ident, ok), {}, TypeError, "image dtype"),
        ((image, image.astype(np.uint16), ident, ok), {}, TypeError, "output dtype"),
        ((image, image[..., :2], ident, ok), {}, ValueError, "channels"),
        ((image, image[..., 0], ident, ok), {}, ValueError, "channels"),
        ((image, image[:10], ident, ok), {}, ValueError, "origin"),
        ((image[:0], image[:0], ident, ok), {}, ValueError, "empty"),
        ((image, image, ident, [[np.nan, 1.0]]), {}, ValueError, "points must be finite"),
        ((image, image, ident, [[1.0, 2.0, 3.0]]), {}, ValueError, "points must have shape"),
        ((image, image, ident, [["a", "b"]]), {}, TypeError, "points must be real"),
        ((image, image, "f", ok), {}, TypeError, "m must be"),
        ((image, image, wrong_shape, ok), {}, ValueError, "returned shape"),
        ((image, image, lambda v: v + 0j, ok), {}, TypeError, "complex128 values"),
        ((image, image, lambda v: v > 0, ok), {}, TypeError, "bool values"),
        ((image, image, ident, ok), {"radius": -1}, ValueError, "radius"),
        ((image, image, ident, ok), {"radius": 1.5}, TypeError, "radius"),
        ((image, image, ident, ok), {"radius": True}, TypeError, "radius"),
        ((image, image, ident, ok), {"alignment": "mls"}, ValueError, "alignment"),
        ((image, image, ident, ok), {"alignment": "matrix"}, TypeError, "matrices"),
        ((image, image, ident, ok), {"border": "mirror"}, ValueError, "border"),
        ((image, image, ident, ok), {"snap": 0.5}, ValueError, "snap"),
        ((image, image, ident, ok), {"origin": (0.0, np.inf)}, ValueError, "origin"),
        ((image, image, ident, ok), {"origin": "xy"}, ValueError, "origin"),
    ]


def test_bad_input_is_named(rng):
    image = rng.integers(0, 256, (24, 24, 3), dtype=np.uint8)
    for args, options, error, message in bad_cases(image):
        with pytest.raises(error, match=message):
            construction_errors(*args, **options)
    floats = rng.uniform(0, 1, (24, 24)).astype(np.float64)
    spoiled = floats.copy()
    spoiled[3, 4] = np.nan
    with pytest.raises(ValueError, match="output holds NaN"):
        construction_errors(floats, spoiled, lambda v: v, [[10.0, 10.0]])
    # float widths may differ (the warp computes floats as float32)
    construction_errors(floats, floats.astype(np.float32), lambda v: v, [[10.0, 10.0]])


# -- picture and report ---------------------------------------------------------------------


def test_picture_colours_a_disk_at_each_deformed_point(gl, rng):
    image = np.full((64, 80, 3), 255, np.uint8)
    output = rng.integers(0, 256, (64, 80, 3), dtype=np.uint8)
    points = np.array([[20.0, 20.0], [60.0, 40.0], [1.0, 1.0]])  # the last is undefined

    def shift(v):
        return v + [3.0, 2.0]

    errors = construction_errors(image, output, shift, points)
    assert np.isnan(errors.values[2]) and not np.isnan(errors.values[:2]).any()
    picture = render_construction_errors(image, errors, vmin=0.0, ctx=gl)
    colors = apply_colormap(errors.values, vmin=0.0)
    for (x, y), color in zip(errors.deformed_points, colors, strict=True):
        assert_allclose(picture[round(y), round(x)], color, atol=2)
    assert_allclose(picture[3, 4], NAN_COLOR, atol=2)
    at_r = render_construction_errors(image, errors, deformed=False, vmin=0.0, ctx=gl)
    assert_allclose(at_r[20, 20], colors[0], atol=2)
    moved = render_construction_errors(image, errors, vmin=0.0, origin=(3.0, 2.0), ctx=gl)
    assert_allclose(moved[20, 20], colors[0], atol=2)
    with pytest.raises(TypeError, match="ConstructionErrors"):
        render_construction_errors(image, errors.values, ctx=gl)


def test_report_adds_the_construction_metric(gl, rng, tmp_path):
    image = smooth_image((64, 80))
    src, dst = smooth_handles((64, 80), rng)
    reference_points = interior_points(rng, 12, (64, 80), 10)
    with glmls.MLS(src, dst, shape=(64, 80), ctx=gl) as m:
        plain = glmls.analysis.report(image, m, reference_points, construction=False)
        result = glmls.analysis.report(
            image, m, reference_points, method="backward", out_dir=tmp_path
        )
        expected = construction_errors(
            image, m.warp(image, method="backward"), m, result.triangles.points
        )
        with pytest.raises(ValueError, match="radius"):
            glmls.analysis.report(
                image, m, reference_points, construction=True, construction_radius=-2
            )
    assert "construction" not in plain.summary and plain.construction is None
    assert "construction_errors" not in plain.images  # on by default, off when asked
    assert result.summary["construction"] == expected.stats()
    settings = result.summary["analysis"]["construction"]
    assert settings["radius"] == 2 and settings["alignment"] == "jacobian"
    assert settings["limits"][0] == 0.0
    assert_allclose(result.construction.values, expected.values, equal_nan=True)
    assert "construction_errors" in result.summary["timings_s"]
    assert result.images["construction_errors"].shape == (64, 80, 3)
    assert result.images["construction_errors_colorbar"].dtype == np.uint8
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["construction"] == expected.stats()
    assert (tmp_path / "construction_errors.png").is_file()
