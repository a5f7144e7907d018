"""One rule for every real-valued option (``glmls.core.config.check_real``), 2D, 3D, batch,
augmentation and analyses alike: Python ints and floats, numpy integer and floating scalars
and 0-d arrays are taken and stored as floats; a bool, a string, None, a complex or an array
of another shape is a ``TypeError`` naming the option and the value's type; NaN, ±inf or a
value out of range a ``ValueError`` naming the option and the value."""

from __future__ import annotations

import math

import numpy as np
import pytest

import glmls
from glmls.analysis import color_limits, triangle_errors
from glmls.analysis.construction import construction_errors
from glmls.analysis.volume_pictures import render_volume_slices
from glmls.augment import (
    Augment,
    GridPreset,
    LandmarksPreset,
    TextDistortPreset,
    TextPerspectivePreset,
    TextStretchPreset,
)
from glmls.core.config import check_real
from glmls.files import NiftiHeader
from glmls.volume import VolumeOptions

WRONG_TYPES = [True, np.True_, "1", None, 1 + 0j, np.array([0.5]), np.array(True), [0.5]]
NOT_FINITE = [math.nan, math.inf, -math.inf, np.float32("nan"), np.array(np.inf)]
IMAGE = np.zeros((12, 14, 3), np.float64)
SQUARE = [[0.0, 0.0], [5.0, 0.0], [0.0, 5.0], [5.0, 5.0]]


def _snap(value):
    construction_errors(IMAGE, IMAGE, lambda p: np.asarray(p, np.float64), [[5.0, 6.0]], snap=value)
    return check_real("snap", value)


#: name: (what the messages call it, a call that takes the value and returns what it stored,
#: a value in range)
OPTIONS = {
    "MLSConfig.alpha": ("alpha", lambda v: glmls.MLSConfig(alpha=v).alpha, 0.5),
    "MLSConfig.s": ("s", lambda v: glmls.MLSConfig(s=v).s, 0.5),
    "MLSConfig.radius": ("radius", lambda v: glmls.MLSConfig(radius=v).radius, 0.5),
    "WarpOptions.tolerance": ("tolerance", lambda v: glmls.WarpOptions(tolerance=v).tolerance, 0.5),
    "WarpOptions.origin": ("origin", lambda v: glmls.WarpOptions(origin=(v, 0)).origin[0], 0.5),
    "VolumeOptions.origin": ("origin", lambda v: VolumeOptions(origin=(0, v, 0)).origin[1], 0.5),
    "VolumeOptions.spacing": (
        "spacing",
        lambda v: VolumeOptions(spacing=(1, 1, v)).spacing[2],
        0.5,
    ),
    "Bounds.x0": ("Bounds x0", lambda v: glmls.Bounds(v, 0, 1, 1).x0, 0.5),
    "GridPreset.displacement": (
        "displacement",
        lambda v: GridPreset(displacement=v).displacement,
        0.5,
    ),
    "LandmarksPreset.displacement": (
        "displacement",
        lambda v: LandmarksPreset(displacement=v).displacement,
        0.5,
    ),
    "TextDistortPreset.radius": ("radius", lambda v: TextDistortPreset(radius=v).radius, 0.5),
    "TextStretchPreset.radius": ("radius", lambda v: TextStretchPreset(radius=v).radius, 0.5),
    "TextPerspectivePreset.radius": (
        "radius",
        lambda v: TextPerspectivePreset(radius=v).radius,
        0.5,
    ),
    "Augment.box_step": ("box_step", lambda v: Augment("grid", box_step=v).box_step, 0.5),
    "Augment.densify": ("densify", lambda v: Augment("grid", densify=v).densify, 0.5),
    "color_limits.vmin": ("vmin", lambda v: color_limits([0.0, 1.0], vmin=v)[0], 0.5),
    "color_limits.vmax": ("vmax", lambda v: color_limits([0.0, 1.0], vmax=v)[1], 0.5),
    "color_limits.percentile": (
        "percentile",
        lambda v: color_limits([0.0, 100.0], percentile=v)[1],
        0.5,
    ),
    "triangle_errors.eps": ("eps", lambda v: triangle_errors(lambda p: p, SQUARE, eps=v).eps, 0.5),
    "construction_errors.snap": ("snap", _snap, 0.25),
    "NiftiHeader.time_step": ("time_step", lambda v: NiftiHeader(time_step=v).time_step, 0.5),
}


#: The options where None means "none given".
OPTIONAL = {
    "MLSConfig.radius",
    "WarpOptions.tolerance",
    "TextDistortPreset.radius",
    "TextStretchPreset.radius",
    "TextPerspectivePreset.radius",
    "Augment.densify",
    "color_limits.vmin",
    "color_limits.vmax",
    "color_limits.percentile",
    "NiftiHeader.time_step",
}


@pytest.mark.parametrize("value", WRONG_TYPES, ids=repr)
@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_a_value_of_another_type_is_a_type_error_naming_the_option(option, value):
    name, make, _ = OPTIONS[option]
    if value is None and option in OPTIONAL:
        make(None)  # the option's default: none given
        return
    with pytest.raises(TypeError, match=rf"^{name} must be .*{type(value).__name__}"):
        make(value)


@pytest.mark.parametrize("value", NOT_FINITE, ids=repr)
@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_a_value_that_is_not_finite_is_a_value_error_naming_the_option(option, value):
    name, make, _ = OPTIONS[option]
    with pytest.raises(ValueError, match=rf"^{name} must be .*finite"):
        make(value)


@pytest.mark.parametrize("kind", [float, np.float64, np.float32, np.array, np.float16])
@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_numpy_scalars_and_zero_dimensional_arrays_are_taken_as_floats(option, kind):
    _, make, good = OPTIONS[option]
    stored = make(kind(good))
    assert stored == good and type(stored) is float


def test_integers_are_reals_too():
    for value in (2, np.int64(2), np.uint8(2), np.array(2)):
        assert glmls.MLSConfig(alpha=value).alpha == 2.0
        assert type(GridPreset(displacement=value).displacement) is float


def test_a_huge_python_integer_is_a_value_error():
    with pytest.raises(ValueError, match=r"^alpha must be a finite number > 0, got 1000"):
        glmls.MLSConfig(alpha=10**400)
    with pytest.raises(ValueError, match=r"^radius must be a finite number > 0, got 1000"):
        glmls.MLSConfig(radius=10**400)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: glmls.MLSConfig(alpha=-0.0), "alpha must be a finite number > 0, got -0.0"),
        (lambda: glmls.MLSConfig(alpha=1e308), "alpha must be <= 10"),
        (lambda: glmls.MLSConfig(radius=-0.0), "radius must be a finite number > 0, got -0.0"),
        (lambda: glmls.MLSConfig(s=-1e-300), "s must be a finite number >= 0, got -1e-300"),
        (lambda: glmls.WarpOptions(tolerance=-0.0), "tolerance must be a number of pixels"),
        (lambda: glmls.WarpOptions(origin=(1e308, 0)), "origin must be finite and within"),
        (lambda: color_limits([0.0], percentile=1e308), r"percentile must be .* \(0, 100\]"),
        (lambda: color_limits([0.0], percentile=0), r"percentile must be .* \(0, 100\]"),
        (lambda: Augment("grid", box_step=-0.0), "box_step must be a finite number > 0"),
    ],
)
def test_out_of_range_is_a_value_error_naming_the_option(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_negative_zero_is_stored_as_zero():
    for stored in (
        glmls.MLSConfig(s=-0.0).s,
        GridPreset(displacement=-0.0).displacement,
        glmls.WarpOptions(origin=(-0.0, 0)).origin[0],
    ):
        assert stored == 0 and math.copysign(1.0, stored) == 1.0


def test_presets_of_zero_dimensional_options_stay_hashable():
    assert hash(GridPreset(displacement=np.array(0.05), rows=np.array(3))) == hash(
        GridPreset(displacement=0.05, rows=3)
    )


@pytest.mark.parametrize("value", [True, np.True_, "1", None, 1j, np.array(True), ["x"]], ids=repr)
def test_background_values_follow_the_rule(value):
    """(``np.array([0.5])`` and ``[0.5]`` are one value per channel, of a 1-channel image.)"""
    with pytest.raises(TypeError, match=r"^background values must be real numbers"):
        glmls.WarpOptions(background=value)


def test_background_takes_what_a_float_image_holds():
    assert math.isnan(glmls.WarpOptions(background=np.array(np.nan)).background)
    assert glmls.WarpOptions(background=np.float32(-np.inf)).background == -math.inf
    assert glmls.WarpOptions(background=(np.array(0.5), np.int64(2))).background == (0.5, 2.0)


@pytest.mark.parametrize("value", [True, "1", 1 + 0j, np.array([0.5])], ids=repr)
def test_the_analyses_refuse_wrong_types_before_any_work(value):
    volume = np.zeros((4, 5, 6), np.uint8)
    with pytest.raises(TypeError, match=r"^near must be a finite number >= 0 \(voxels\)"):
        render_volume_slices(volume, near=value)
    with pytest.raises(TypeError, match=r"^min_quality must be a finite number in \[0, 1\)"):
        glmls.analysis.tetrahedron_errors(lambda p: p, np.eye(4, 3), min_quality=value)


def test_albumentations_p_follows_the_rule():
    albumentations = pytest.importorskip("glmls.augment.albumentations")
    assert albumentations.MLSDeform(p=np.array(0.5)).p == 0.5
    for value in (True, "0.5", None, np.array([0.5])):
        with pytest.raises(TypeError, match=r"^p must be a probability from 0 to 1, got .*\("):
            albumentations.MLSDeform(p=value)


SRC2 = np.array([[1.0, 1], [6, 1], [1, 6], [6, 6]])
SRC3 = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])


def test_the_warps_take_and_refuse_alike(gl):
    """2D, 3D and batches: a 0-d alpha, radius and tolerance are taken; the wrong types are
    refused by the same words."""
    image = np.zeros((8, 8), np.uint8)
    image[2:6, 2:6] = 200
    volume = np.zeros((6, 6, 6), np.uint8)
    with glmls.MLS(SRC2, SRC2 + 0.5, alpha=np.array(2.0), ctx=gl) as m2:
        expected = m2.warp(image, tolerance=0.5)
        np.testing.assert_array_equal(m2.warp(image, tolerance=np.array(0.5)), expected)
        with pytest.raises(TypeError, match=r"^tolerance must be .*\(bool\)"):
            m2.warp(image, tolerance=True)
    batch = glmls.warp_batch([image], [SRC2], [SRC2 + 0.5], alpha=np.float32(2), tolerance=0.5)
    np.testing.assert_array_equal(batch[0], expected)
    with glmls.MLS(SRC3, SRC3 + [2, 0, 0], weight="gaussian", radius=np.array(9.0)) as m3:
        assert m3.config.radius == 9.0
        assert m3.warp(volume, background=np.array(7)).max() == 7
    for make in (
        lambda v: glmls.MLS(SRC2, SRC2, alpha=v, ctx=gl),
        lambda v: glmls.MLS(SRC3, SRC3, alpha=v, ctx=gl),
        lambda v: glmls.warp_batch([image], [SRC2], [SRC2], alpha=v),
    ):
        for value in ("1", None, 1j, np.array([0.5])):
            with pytest.raises(TypeError, match=r"^alpha must be a finite number > 0, got .*\("):
                make(value)
        with pytest.raises(ValueError, match=r"^alpha must be a finite number > 0, got nan"):
            make(np.nan)


def test_drawn_sizes_follow_the_rule(gl):
    image = np.zeros((16, 16), np.uint8)
    picture = glmls.analysis.render_handles(image, [[4, 4]], [[9, 8]], width=np.float32(2))
    assert picture.shape == (16, 16, 3)
    for value, error in (
        (True, TypeError),
        ("2", TypeError),
        (np.inf, ValueError),
        (0, ValueError),
    ):
        with pytest.raises(error, match=r"^width must be a finite number of pixels > 0"):
            glmls.analysis.render_handles(image, [[4, 4]], [[9, 8]], width=value, ctx=gl)
