"""A radius weight given neither ``radius`` nor ``shape`` makes a 3D MLS, as it makes a 2D
one: each volume warp (and ``bounds``, ``coordinate_map``, the analyses of a volume) takes
that volume's diagonal in the handles' units, exactly what an MLS made with the volume's
``shape`` does; the methods of points, which have no volume, raise ValueError asking for a
radius or a shape, as in 2D."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.analysis import volume_report
from glmls.core.handles3 import volume_diagonal

SPACING = (2.0, 1.0, 0.5)  # dz, dy, dx
ASKS = "needs an influence radius"


def _problem(seed: int = 9) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    src = rng.uniform(2, 14, (7, 3))
    return src, src + rng.normal(0, 1.5, src.shape)


def _volume(shape: tuple[int, int, int]) -> np.ndarray:
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in shape), indexing="ij")
    return (np.sin(x / 2) + np.cos(y / 3) + z / 4).astype(np.float32)


#: An MLS made with ``shape`` scales its coordinates to the box of the handles and the
#: volume, one without to the handles' alone: the same f, rounded apart in float32.
ROUNDING = 1e-5


@pytest.mark.parametrize("weight", glmls.RADIUS_WEIGHTS)
def test_each_warp_takes_its_volume_s_diagonal(gl, weight):
    src, dst = _problem()
    options = {"weight": weight, "transform": "similarity", "ctx": gl}
    linear = {"interpolation": "linear"}
    with glmls.MLS(src, dst, **options) as m:
        assert m.config.radius is None and m.shape is None
        for shape in ((9, 12, 16), (14, 10, 11)):  # two diagonals, one MLS
            volume = _volume(shape)
            found = m.warp(volume, **linear)
            backward = m.warp(volume, method="backward", **linear)
            with glmls.MLS(src, dst, radius=volume_diagonal(shape), **options) as given:
                assert_array_equal(found, given.warp(volume, **linear))
                assert_array_equal(backward, given.warp(volume, method="backward", **linear))
            with glmls.MLS(src, dst, shape=shape, **options) as sized:
                assert_allclose(found, sized.warp(volume, **linear), rtol=0, atol=ROUNDING)
    with glmls.MLS(src, dst, radius=3.0, **options) as narrow:
        assert np.abs(narrow.warp(volume, **linear) - found).max() > 1e-3  # R matters here


def test_bounds_maps_analyses_and_spacing_take_the_volume_s_too(gl):
    src, dst = _problem(4)
    shape = (8, 12, 20)  # with SPACING: 16 x 12 x 10 units
    volume = _volume(shape)
    diagonal = volume_diagonal(shape, SPACING)
    options = {"weight": "gaussian", "transform": "affine", "spacing": SPACING, "ctx": gl}
    with (
        glmls.MLS(src, dst, **options) as m,
        glmls.MLS(src, dst, radius=diagonal, **options) as given,
    ):
        assert_array_equal(m.warp(volume), given.warp(volume))
        assert m.bounds(shape) == given.bounds(shape)
        for got, expected in zip(m.coordinate_map(shape), given.coordinate_map(shape), strict=True):
            assert_array_equal(got, expected)
        report = volume_report(volume, m, warp=False)
    assert report.summary["configuration"]["radius_used"] == pytest.approx(diagonal)


def test_points_without_a_volume_are_refused_as_in_2d(gl):
    src, dst = _problem()
    points = src[:3] + 0.5
    with glmls.MLS(src[:, :2], dst[:, :2], weight="gaussian", ctx=gl) as planar:
        for call in (planar, planar.matrices, planar.inverse):
            with pytest.raises(ValueError, match=ASKS):
                call(points[:, :2])
    with glmls.MLS(src, dst, weight="gaussian", ctx=gl) as m:
        calls = {
            "m(points)": lambda: m(points),
            "matrices": lambda: m.matrices(points),
            "jacobian": lambda: m.jacobian(points),
            "deform": lambda: m.deform(points),
            "inverse": lambda: m.inverse(points),
            "residuals": lambda: m.residuals(points, points),
            "inverse.residuals": lambda: m.inverse.residuals(points, points),
            "uniforms": lambda: m.uniforms(),
        }
        for name, call in calls.items():
            with pytest.raises(ValueError, match=ASKS):
                call()
                pytest.fail(name)
        assert m.uniforms((4, 5, 6))  # a volume's: its diagonal
        m.set_handles(src, dst + 1.0)  # the MLS stays usable
        assert m.warp(_volume((4, 5, 6))).shape == (4, 5, 6)
