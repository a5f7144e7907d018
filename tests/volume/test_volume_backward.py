"""The backward method on volumes, border modes, and the inverse it solves."""

from __future__ import annotations

import numpy as np
import pytest
from volume_reference import box_handles, inverse, sample

import glmls
from glmls import BORDERS
from glmls.core.config import MLSConfig
from glmls.volume import (
    VolumeOptions,
    kernel_field,
    volume_bounds,
    volume_coordinate_map,
    warp_volume,
)
from glmls.volume.construction import VolumeWarper
from glmls.volume.fields import NEWTON_TOLERANCE, ReferenceField

SHAPE = (9, 10, 12)


@pytest.fixture
def volume(rng):
    return rng.integers(0, 256, SHAPE, dtype=np.uint8)


@pytest.mark.parametrize("border", BORDERS)
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_every_border_mode_is_numpy_pad(kernel3, rng, volume, border, method):
    """A translation by whole voxels shows numpy.pad's extension of the volume."""
    src, _ = box_handles(SHAPE, rng)
    shift = np.array([4, -3, 2])  # x, y, z
    m = kernel3(src, src + shift, SHAPE, transform="rigid")
    out = warp_volume(m, volume, method=method, border=border, background=9)
    pad = 6
    if border == "constant":
        padded = np.pad(volume, pad, mode="constant", constant_values=9)
    else:
        padded = np.pad(volume, pad, mode=border)
    d, h, w = SHAPE
    z0, y0, x0 = pad - shift[2], pad - shift[1], pad - shift[0]
    np.testing.assert_array_equal(out, padded[z0 : z0 + d, y0 : y0 + h, x0 : x0 + w])


@pytest.mark.parametrize("border", ["constant", "reflect"])
def test_backward_matches_newton_in_float64(kernel3, gl, rng, volume, border):
    """The GPU's source points within 0.01 voxel of float64 Newton's where both converge
    and f is far from singular; the volumes then agree but for voxels on rounding edges."""
    src, dst = box_handles(SHAPE, rng, count=12, spread=2.0)
    config = {"transform": "rigid", "weight": "idw"}
    m = kernel3(src, dst, SHAPE, **config)
    points, residual, covered = volume_coordinate_map(m, SHAPE, border=border)
    field = ReferenceField(src, dst, MLSConfig(**config), shape=SHAPE)
    expected, expected_residual = inverse(field, SHAPE, guess=points.astype(np.float64))
    good = covered & (expected_residual < 1e-6)
    assert good.mean() > 0.5
    assert np.abs(points - expected)[good].max() < 0.01
    assert residual[covered].max() <= 0.05
    # f(f^-1(u)) = u within 0.01 voxel
    d, h, w = SHAPE
    k, j, i = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    u = np.stack([i, j, k], axis=-1)[covered]
    assert np.abs(field.evaluate(points[covered].astype(np.float64)) - u).max() < 0.01
    out = warp_volume(m, volume, method="backward", border=border, interpolation="linear")
    values = sample(volume[..., None], expected[good], border, True)[:, 0]
    assert np.mean(np.abs(out[good] - np.rint(values)) > 1) < 0.01


def test_inverse_of_forward_points(kernel3, rng):
    """f^-1(f(x)) = x within 0.01 voxel at voxel centres x moved by f: with an output origin
    at f(x) - round(f(x)) the output voxel nearest f(x) shows f(x) itself."""
    src, dst = box_handles(SHAPE, rng, count=10, spread=1.5)
    m = kernel3(src, dst, SHAPE, transform="similarity")
    field = ReferenceField(src, dst, MLSConfig(transform="similarity"), shape=SHAPE)
    x = np.array([[5.0, 4.0, 3.0], [2.0, 7.0, 6.0], [9.0, 2.0, 1.0]])
    for point in x:
        fx = field.evaluate(point[None])[0]
        origin = fx - np.round(fx)
        points, _, covered = volume_coordinate_map(m, SHAPE, origin=tuple(origin))
        i, j, k = np.round(fx).astype(int)
        assert covered[k, j, i]
        np.testing.assert_allclose(points[k, j, i], point, atol=0.01)


def test_reference_field_and_cpu_newton(gl, rng, volume):
    """The construction run with the float64 field (its Newton's method on the CPU) agrees
    with the GPU kernel's."""
    src, dst = box_handles(SHAPE, rng, count=8, spread=1.0)
    field = ReferenceField(src, dst, MLSConfig(), shape=SHAPE)
    out = VolumeWarper.of(gl).warp(field, volume, VolumeOptions(method="backward"))
    assert out.shape == SHAPE and np.mean(out == 0) < 0.5


def test_bounds(kernel3, rng, volume):
    src, _ = box_handles(SHAPE, rng)
    m = kernel3(src, src + [2.0, -1.0, 0.5], SHAPE, transform="rigid")
    b = volume_bounds(m, SHAPE)
    np.testing.assert_allclose([b.x0, b.y0, b.z0], [1.5, -1.5, 0.0], atol=1e-4)
    np.testing.assert_allclose([b.x1, b.y1, b.z1], [13.5, 8.5, 9.0], atol=1e-4)
    assert b.output_shape == (10, 10, 12) and b.origin == (2.0, -1.0, 0.0)  # z: half voxels
    out = warp_volume(m, volume, output_shape=b.output_shape, origin=b.origin)
    assert out.shape == (10, 10, 12)


def test_bad_inputs_are_named(kernel3, gl, rng, volume):
    src, _ = box_handles(SHAPE, rng)
    m = kernel3(src, src, SHAPE)
    with pytest.raises(ValueError, match="2D image"):
        warp_volume(m, np.zeros((8, 9), np.uint8))
    with pytest.raises(TypeError, match="got object"):  # no MLS at all
        warp_volume(object(), volume)
    import glmls

    with glmls.MLS([[0, 0], [5, 3]], [[1, 0], [6, 3]]) as m2:
        with pytest.raises(ValueError, match="2D handles"):
            warp_volume(m2, volume)
    with pytest.raises(TypeError, match="dtype"):
        warp_volume(m, volume.astype(np.int32))
    with pytest.raises(ValueError, match=r"C in 1\.\.4"):
        warp_volume(m, np.zeros((4, 5, 6, 5), np.uint8))
    with pytest.raises(ValueError, match="unknown method 'splat' for a volume"):
        warp_volume(m, volume, method="splat")
    with pytest.raises(ValueError, match="output_shape"):
        warp_volume(m, volume, output_shape=(4, 5))
    with pytest.raises(ValueError, match="spacing"):
        warp_volume(m, volume, spacing=(1, 0, 1))
    with pytest.raises(ValueError, match="origin"):
        warp_volume(m, volume, origin=(1, 2))
    with pytest.raises(TypeError, match="unknown volume warp option"):
        warp_volume(m, volume, tolerance=0.1)
    with pytest.raises(ValueError, match="background"):
        warp_volume(m, volume, background=300)


def test_the_facade_warps_volumes(gl, rng, volume):
    """glmls.MLS of (N, 3) handles warps volumes through warp_volume; a 2D MLS says that a
    volume needs a 3D one."""
    import glmls

    src, _ = box_handles(SHAPE, rng)
    with glmls.MLS(src, src + [2, 0, 0], transform="rigid", ctx=gl) as m:
        out = m.warp(volume, method="backward", spacing=(1, 1, 1), background=5)
        np.testing.assert_array_equal(out[:, :, 2:], volume[:, :, :-2])
        assert (out[:, :, :2] == 5).all()
        np.testing.assert_array_equal(warp_volume(m, volume), m.warp(volume))
    with glmls.MLS([[0, 0], [5, 3]], [[1, 0], [6, 3]], ctx=gl) as m2:
        with pytest.raises(ValueError, match="3D MLS"):
            m2.warp(volume)


@pytest.mark.parametrize("grid, ratio", [(2, 8), (4, 3)])
def test_the_first_guess_is_second_order(kernel3, monkeypatch, grid, ratio):
    """At grid >= 2 Newton starts from the cells' piecewise linear inverse corrected by f's
    inverse Jacobians at the tetrahedron's corners (docs/mathematics.md): with no Newton
    step allowed, the guess's residual |f(s) - u| is a fraction of the linear guess's (the
    more so the finer the lattice: third order against second), and at grid 2 within
    Newton's tolerance at most voxels."""
    shape = (32, 32, 32)
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 31, (8, 3))
    dst = src + rng.normal(0, 1.0, src.shape)
    m = kernel3(src, dst, shape, transform="rigid")
    monkeypatch.setattr(kernel_field, "NEWTON_STEPS", 0)  # f at the guess, no step
    inner = (slice(4, -4),) * 3  # voxels that cells cover
    _, second, _ = volume_coordinate_map(m, shape, grid=grid)
    monkeypatch.setattr(VolumeWarper, "_jacobians", lambda *args: None)
    _, linear, _ = volume_coordinate_map(m, shape, grid=grid)
    second, linear = second[inner], linear[inner]
    assert np.all(np.isfinite(second))
    assert np.median(second) < np.median(linear) / ratio
    assert np.percentile(second, 90) < np.percentile(linear, 90) / (ratio / 2)
    if grid == 2:
        assert np.mean(second <= NEWTON_TOLERANCE) > 0.5


def test_the_backward_method_takes_grid_2_unless_told(gl, rng):
    """A backward warp given no grid takes the first guess's lattice of step 2 (a third of
    grid 1's time on a CPU renderer, the same result within Newton's tolerance); quads keep
    step 1, and a grid given wins."""
    from glmls.volume import VolumeOptions

    shape = (9, 11, 13)
    src = rng.uniform(0, 10, (8, 3))
    dst = src + rng.normal(0, 1.0, src.shape)
    with glmls.MLS(src, dst, transform="rigid", shape=shape, ctx=gl) as m:
        default = volume_coordinate_map(m, shape)
        two = volume_coordinate_map(m, shape, grid=2)
        one = volume_coordinate_map(m, shape, grid=1)
        volume = rng.uniform(0, 1, shape).astype(np.float32)
        np.testing.assert_array_equal(
            m.warp(volume, method="backward", interpolation="linear"),
            m.warp(volume, method="backward", interpolation="linear", grid=2),
        )
        np.testing.assert_array_equal(m.warp(volume), m.warp(volume, grid=1))
    for a, b in zip(default, two, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(default[0], one[0])  # Newton started elsewhere
    covered = default[2] & one[2]
    assert np.abs(default[0][covered] - one[0][covered]).max() < 0.01
    assert VolumeOptions().lattice_step == 1
    assert VolumeOptions(method="backward").lattice_step == 2
    assert VolumeOptions(method="backward", grid=3).lattice_step == 3
    assert VolumeOptions.of(VolumeOptions(), method="backward").lattice_step == 2
