"""MLS in 3D on the GPU against the float64 reference: every transform and weight on 256^3
coordinates, the degenerate handle sets, the identity, continuity, the 2D reduction, the
lattice pass, the inverse and the Jacobian."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import degenerate_sets3, random_rotation

import glmls
from glmls import reference
from glmls.core.config import MLSConfig
from glmls.core.handles3 import fit_scaling3
from glmls.core.weights import REGISTRY
from glmls.engine.kernel3 import MLSKernel3
from glmls.engine.passes3 import evaluate_lattice3, evaluate_points3

SHAPE = (256, 256, 256)
#: Where fewer than 4 handles in general position are in reach (two, three, collinear), a
#: ridge of 1e-3 of the moments fixes what they leave free and divides their rounding by
#: 1e-3: those points sum their moments and solve in float64 (docs/mathematics.md, "The 3D
#: solve on the GPU"), as close to the reference as the others.
RIDGE_TOLERANCE = 1e-3
#: Points with few handles in reach: affine solves them in float32 only where every
#: eigenvalue of A is above 1e-2 of its trace (A's condition up to 100 magnifying the
#: moments' rounding).
NEAR_RIDGE_TOLERANCE = 2e-3
#: Points with a handle within EDGE_BAND voxel of a radius weight's R, where f is steep: up to
#: 0.024 voxel from the reference over 52 random sets of 64 handles and 2000 points (R = 60),
#: with room, all of it the float32 rounding of the inputs, which f's steepness magnifies (the
#: reference at the inputs as the GPU holds them: 1.9e-4); nearer R, more (docs/mathematics.md).
EDGE_BAND = 0.1
EDGE_TOLERANCE = 0.04
#: Handles near a radius weight's R (d^2 within 5e-3 R^2 of R^2) take their distance and
#: weight in float64 (mls/weighting.glsl, mls_at_edge): against the reference at the inputs as
#: float32 holds them, f is within this 1e-3 to 0.1 voxel from R (measured: 4.4e-4 affine,
#: whose float32 solve takes A's condition up to 100, 7.7e-5 the rotations; float32 distances
#: and weights left 0.12 voxel 1e-3 from R, 5e-3 1e-2 from R, 1.2e-3 0.1 from R).
HELD_EDGE_TOLERANCE = {"affine": 1e-3, "similarity": 3e-4, "rigid": 3e-4}
#: The weights that are 0 from d = R on.
COMPACT_WEIGHTS = [name for name, entry in REGISTRY.items() if entry.support == "radius"]


@pytest.fixture(scope="module")
def handles():
    rng = np.random.default_rng(7)
    src = rng.uniform(0, 256, (64, 3))
    return src, src + rng.normal(0, 8, (64, 3)), rng.uniform(0, 256, (2000, 3))


def _compare(src, dst, points, config, storage="auto"):
    """max |f - f_ref| (voxels) and max |M - M_ref| of the GPU against the reference."""
    with glmls.MLS.from_config(src, dst, config, shape=SHAPE, storage=storage) as m:
        big_m, t = m.matrices(points)
    f = np.einsum("ki,kij->kj", points, big_m) + t
    f_ref, m_ref, _ = reference.mls(src, dst, points, config, shape=SHAPE)
    assert np.isfinite(f).all() and np.isfinite(big_m).all()
    return np.abs(f - f_ref).max(), np.abs(big_m - m_ref).max()


@pytest.mark.parametrize("weight", glmls.WEIGHTS)
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_every_transform_and_weight_within_1e3_voxel(gl, handles, transform, weight):
    src, dst, points = handles
    f_err, m_err = _compare(src, dst, points, MLSConfig(transform=transform, weight=weight))
    assert f_err < 1e-3
    assert m_err < 1e-5


@pytest.mark.parametrize(
    "options",
    [
        {"alpha": 1.5},
        {"s": 100.0},
        {"weight": "cressman", "radius": 60.0, "interpolating": True},
        {"weight": "gaussian", "radius": 40.0},
    ],
)
def test_parameters(gl, handles, options):
    src, dst, points = handles
    if options.get("weight") == "cressman":
        # where a handle enters the reach f is steep (docs/mathematics.md, "The edge of a
        # compact weight's reach"): float32's rounding of the point and of the handles
        # moves it there, by up to 0.024 voxel within 0.1 voxel of R over 52 random sets
        distance = np.linalg.norm(points[:, None] - src[None], axis=-1)
        edge = np.abs(distance - options["radius"]).min(axis=1) <= EDGE_BAND
        assert edge.any()
        points = points[~edge]
    for transform in ("affine", "rigid"):
        f_err, _ = _compare(src, dst, points, MLSConfig(transform=transform, **options))
        # within a small radius some points see only 2 to 4 handles
        assert f_err < (NEAR_RIDGE_TOLERANCE if "radius" in options else 1e-3), transform


@pytest.mark.parametrize("seed", [7, 19, 47, 48])
@pytest.mark.parametrize("transform", ["affine", "rigid"])
def test_random_points_near_the_edge_of_the_reach(gl, seed, transform):
    """Points with a handle within EDGE_BAND of R: f there changes fast as the handle's
    weight tends to 0, and float32's rounding of the point and of the handles moves it by
    more than elsewhere (seeds of the largest errors of 52 random sets: 0.024 voxel)."""
    rng = np.random.default_rng(seed)
    src = rng.uniform(0, 256, (64, 3))
    dst = src + rng.normal(0, 8, (64, 3))
    points = rng.uniform(0, 256, (2000, 3))
    config = MLSConfig(transform=transform, weight="cressman", radius=60.0, interpolating=True)
    f_err, _ = _compare(src, dst, points, config)
    assert f_err < EDGE_TOLERANCE


def _held(m, src, dst, points, radius):
    """``src``, ``dst``, ``points`` and ``radius`` as the GPU holds them (float32, in the
    kernel's scaled units), in float64: the reference there leaves out the inputs' rounding,
    which f's steepness near R magnifies (docs/mathematics.md)."""
    center, scale = np.asarray(m.kernel.scaling.center), m.kernel.scaling.scale
    offset = m.kernel.offset

    def held(x):
        return ((x - center) / scale).astype(np.float32).astype(np.float64) * scale + center

    moves = (((dst - offset) - src) / scale).astype(np.float32).astype(np.float64)
    src_held = held(src)
    radius_held = float(np.float32(radius / scale)) * scale
    return src_held, src_held + moves * scale + offset, held(points), radius_held


@pytest.mark.parametrize("distance", [1e-3, 1e-2, 1e-1])
@pytest.mark.parametrize("weight", COMPACT_WEIGHTS)
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_a_handle_at_the_edge_of_the_reach(gl, transform, weight, distance):
    """Points ``distance`` voxel inside or outside R of a handle: that handle's weight is
    nearly 0 and f steep in it, so float32's rounding of its d^2 (~1e-7 R^2) and of 1 - d^2 /
    R^2 moved f by up to 0.12 voxel; in float64, f is as close to the reference at the
    GPU-held inputs as elsewhere."""
    radius = 60.0
    rng = np.random.default_rng(7)
    src = rng.uniform(0, 256, (64, 3))
    dst = src + rng.normal(0, 8, (64, 3))
    toward = rng.normal(size=(2000, 3))
    toward /= np.linalg.norm(toward, axis=1, keepdims=True)
    reach = radius + distance * rng.choice([-1.0, 1.0], len(toward))
    points = src[rng.integers(len(src), size=len(toward))] + reach[:, None] * toward
    points = points[((points >= 0) & (points <= 255)).all(axis=1)][:500]
    config = MLSConfig(
        transform=transform, weight=weight, radius=radius, interpolating=weight == "cressman"
    )
    with glmls.MLS.from_config(src, dst, config, shape=SHAPE) as m:
        big_m, t = m.matrices(points)
        src_held, dst_held, points_held, radius_held = _held(m, src, dst, points, radius)
    f = np.einsum("ki,kij->kj", points, big_m) + t
    config_held = MLSConfig(
        transform=transform, weight=weight, radius=radius_held, interpolating=config.interpolating
    )
    f_ref, _, _ = reference.mls(src_held, dst_held, points_held, config_held, shape=SHAPE)
    assert len(points) == 500
    assert np.abs(f - f_ref).max() < HELD_EDGE_TOLERANCE[transform]


def test_many_handles_storages(gl):
    """Past the unrolled slots (a loop), in every storage."""
    rng = np.random.default_rng(3)
    src = rng.uniform(0, 256, (100, 3))
    dst = src + rng.normal(0, 5, src.shape)
    points = rng.uniform(0, 256, (300, 3))
    for storage in ("ssbo", "ubo", "texture"):
        f_err, _ = _compare(src, dst, points, MLSConfig(transform="similarity"), storage)
        assert f_err < 1e-3, storage


def test_idw_with_a_large_s_on_handles(gl, handles):
    """idw with s far above d^(2 alpha) next to a handle weighs the nearby handles alike (the
    shader's capped s / m^alpha made them fall off: 10 voxels off on the handles)."""
    src, dst, _ = handles
    points = np.concatenate([src[:10], src[10:20] + 2e-3])
    for transform in glmls.TRANSFORMS:
        config = MLSConfig(transform=transform, s=1e12, alpha=3.7)
        f_err, _ = _compare(src, dst, points, config)
        assert f_err < 1e-3, transform


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("name", ["two", "three", "coplanar", "collinear", "one", "coincident"])
def test_degenerate_sets(gl, transform, name):
    rng = np.random.default_rng(11)
    src = degenerate_sets3(rng)[name]
    dst = src @ random_rotation(rng).T * 1.1 + 5.0
    if name != "coincident":
        dst += rng.normal(0, 3, src.shape)
    points = rng.uniform(0, 256, (500, 3))
    f_err, _ = _compare(src, dst, points, MLSConfig(transform=transform))
    ridge = name in ("two", "three", "collinear") or (name, transform) == ("coplanar", "affine")
    assert f_err < (RIDGE_TOLERANCE if ridge else 1e-3)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("axis", [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [3.0, 4, 0], [1.0, 1, 1]])
def test_two_handles_swapped_turn_as_the_reference(gl, transform, axis):
    """Two handles that trade places: the rotation about their axis is free, and the least
    rotation is a half turn about a perpendicular that the rule of glmls.reference picks (the
    one choice that cannot be continuous in the handles). Along a coordinate axis or a
    diagonal, where the rule's candidates tie, float32's rounding of the principal axis must
    not pick another perpendicular than the reference: that turns points 2 |v - axis| away."""
    rng = np.random.default_rng(3)
    src = 128.0 + np.array([[0.0, 0, 0], axis]) * 40.0 / np.linalg.norm(axis)
    points = rng.uniform(0, 256, (2000, 3))
    f_err, _ = _compare(src, src[::-1].copy(), points, MLSConfig(transform=transform))
    assert f_err < RIDGE_TOLERANCE


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_identity_is_exact(gl, handles, transform):
    src, _, points = handles
    with glmls.MLS(src, src, transform=transform) as m:
        big_m, t = m.matrices(points)
        assert (m(points) == points).all()
        assert (big_m == np.eye(3)).all() and (t == 0).all()
    with glmls.MLS(src[:2], src[:2] + [1.0, 2.0, 3.0], transform=transform) as m:
        assert (m(points[:10]) - points[:10] == [1.0, 2.0, 3.0]).all()  # a translation


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("name", ["two", "collinear", "three", "coplanar"])
def test_continuous_between_neighbouring_points(gl, transform, name):
    rng = np.random.default_rng(5)
    src = degenerate_sets3(rng)[name]
    dst = src + rng.normal(0, 10, src.shape)
    # a segment through the handles' box, 0.05 voxel steps
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    points = np.array([10.0, 30.0, 250.0]) * (1 - t) + np.array([240.0, 200.0, 5.0]) * t
    with glmls.MLS(src, dst, transform=transform) as m:
        f = m(points)
    jumps = np.linalg.norm(np.diff(f, axis=0), axis=1)
    step = np.linalg.norm(points[1] - points[0])
    assert jumps.max() < 10 * step


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("count", [3, 10])
def test_collinear_targets_as_the_reference(gl, transform, count):
    """Targets on one line from spread sources (B of rank 1): the rotation about that line is
    free, and the GPU fixes it by the reference's rule, continuously along a line of points."""
    rng = np.random.default_rng(21)
    src = rng.uniform(0, 100, (count, 3))
    centre = src.mean(0)
    dst = centre + np.outer((src - centre) @ [1 / 3, 2 / 3, 2 / 3], [0.6, 0.8, 0.0])
    t = np.linspace(-0.5, 1.5, 2001)[:, None]
    points = src[0] * (1 - t) + src[-1] * t + [0.0, 0.0, 3.0]
    with glmls.MLS(src, dst, transform=transform) as m:
        f = m(points)
    f_ref, _, _ = reference.mls(src, dst, points, transform=transform)
    assert np.abs(f - f_ref).max() < RIDGE_TOLERANCE
    jumps = np.linalg.norm(np.diff(f, axis=0), axis=1)
    assert jumps.max() < 10 * np.linalg.norm(points[1] - points[0])


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_plane_z0_equals_2d(gl, transform):
    rng = np.random.default_rng(9)
    src = rng.uniform(0, 200, (10, 2))
    dst = src + rng.normal(0, 4, src.shape)
    points = rng.uniform(0, 200, (300, 2))

    def lift(a):
        return np.concatenate([a, np.zeros((len(a), 1))], axis=1)

    with (
        glmls.MLS(src, dst, transform=transform) as m2,
        glmls.MLS(lift(src), lift(dst), transform=transform) as m3,
    ):
        f2, f3 = m2(points), m3(lift(points))
    assert np.abs(f3[:, 2]).max() < 1e-6
    assert np.abs(f3[:, :2] - f2).max() < 1e-3


@pytest.mark.parametrize("options", [{"s": 0.0}, {"weight": "shepard", "radius": 100.0}])
def test_handles_map_to_targets(gl, handles, options):
    src, dst, _ = handles
    with glmls.MLS(src, dst, **options) as m:
        assert np.abs(m(src) - dst).max() < 1e-3


def test_lattice_pass_matches_points(gl):
    rng = np.random.default_rng(2)
    src = rng.uniform(0, 32, (10, 3))
    dst = src + rng.normal(0, 2, src.shape)
    kernel = MLSKernel3(gl, MLSConfig(), shape=(8, 9, 10))
    kernel.upload(src, dst, fit_scaling3(src, dst, (8, 9, 10)))
    try:
        with gl:
            buffer = gl.mgl.buffer(reserve=630 * 12)
        written = evaluate_lattice3(
            kernel, buffer, origin=(0.5, 0, 1), step=(1, 2, 0.5), size=(10, 9, 8), first=90
        )
        with gl:
            out = np.frombuffer(buffer.read(size=written * 12), np.float32).reshape(-1, 3)
            buffer.release()
        z, y, x = np.mgrid[0:8, 0:9, 0:10]
        points = np.stack([0.5 + x, 2.0 * y, 1 + 0.5 * z], -1).reshape(-1, 3)[90:]
        f, _ = evaluate_points3(kernel, points)
        assert written == 630
        assert np.abs(out - f).max() < 1e-4
    finally:
        kernel.release()


def test_jacobian_against_the_reference(gl, handles):
    src, dst, points = handles
    points = points[:60]
    for transform in glmls.TRANSFORMS:
        with glmls.MLS(src, dst, transform=transform) as m:
            _, jacobian = m.jacobian(points)
        h = 1e-3
        rows = [
            reference.mls(src, dst, points + h * e, transform=transform)[0]
            - reference.mls(src, dst, points - h * e, transform=transform)[0]
            for e in np.eye(3)
        ]
        expected = np.stack(rows, axis=1) / (2 * h)
        assert np.abs(jacobian - expected).max() < 1e-3, transform


def test_inverse(gl, handles):
    src, dst, points = handles
    with glmls.MLS(src, dst) as m:
        u = m(points)
        s, valid = m.inverse(u, return_valid=True)
        assert isinstance(m.inverse, glmls.InverseMLS)
        assert valid.all()
        assert np.abs(m(s) - u).max() < 1e-3
    # where f nearly folds, J's least singular value magnifies the residual
    assert np.median(np.abs(s - points)) < 1e-4
    assert np.abs(s - points).max() < 1e-2
    # within 20 voxels of (40, 30, 30) the space moves 10 voxels along -x; past it f is the
    # identity: (55, 30, 30) has no preimage
    with glmls.MLS([[40, 30, 30]], [[30, 30, 30]], weight="cressman", radius=20) as m:
        s, valid = m.inverse([[20, 30, 30], [55, 30, 30], [70, 30, 30]], return_valid=True)
        assert np.isnan(s[1]).all() and valid.tolist() == [True, False, True]
        assert np.abs(s[[0, 2]] - [[30, 30, 30], [70, 30, 30]]).max() < 1e-3
        assert np.abs(m.inverse.residuals([[20, 30, 30]], [[30, 30, 30]])).max() < 1e-3


def test_residuals_and_shapes(gl, handles):
    src, dst, _ = handles
    with glmls.MLS(src, dst, s=0.0) as m:
        assert m.residuals(src, dst).max() < 1e-3
        assert m(np.zeros((0, 3))).shape == (0, 3)
        assert m.src.shape == (64, 3) and not m.src.flags.writeable
        assert "64 3D handles" in repr(m)


def test_errors(gl, handles):
    src, dst, _ = handles
    with pytest.raises(ValueError, match="2D only"):
        glmls.MLS(src, dst, src_segments=[[[0, 0], [1, 1]]], dst_segments=[[[0, 0], [1, 1]]])
    with pytest.raises(ValueError, match="2D only"):
        glmls.MLS(src, dst, bins=True)
    with glmls.MLS(src, dst, weight="cressman") as m:  # as 2D: the warps take each volume's
        with pytest.raises(ValueError, match="volume diagonal"):
            m(src)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        glmls.MLS(src, dst[:, :2])
    with pytest.raises(ValueError, match="same point"):
        glmls.MLS(src[[0, 0]], dst[:2])
    with pytest.raises(ValueError, match=r"\(D, H, W\)"):
        glmls.MLS(src, dst, shape=(4, 4))
    with glmls.MLS(src, dst) as m:
        with pytest.raises(ValueError, match="shape"):
            m([[1.0, 2.0]])
        for call in (lambda: m.error_field((4, 4)), lambda: m.mesh((4, 4))):
            with pytest.raises(ValueError, match="2D only"):
                call()
    with glmls.MLS(src[:, :2], dst[:, :2]) as m2, pytest.raises(ValueError, match="3D"):
        m2.deform(np.zeros((3, 3)))


@pytest.mark.parametrize("transform", ["similarity", "rigid"])
def test_the_inverse_finds_a_preimage_of_every_image(gl, transform):
    """y = f(x) has a preimage, x; Newton without a damped step lost a few (u in a region where
    f curves within a step, the preimage 2-3.5 voxels from u, det J 0.5-0.6 there)."""
    rng = np.random.default_rng(42)
    src = rng.uniform(0, 39, (64, 3))
    dst = src + rng.normal(0, 3 / np.sqrt(3), src.shape)
    points = np.random.default_rng(5).uniform(0, 39, (5000, 3))
    options = {"weight": "gaussian", "radius": 12.0, "interpolating": True, "shape": (40,) * 3}
    with glmls.MLS(src, dst, transform=transform, **options) as m:
        y = m(points)
        s, valid = m.inverse(y, return_valid=True)
        assert valid.all(), np.flatnonzero(~valid)
        assert np.abs(m(s) - y).max() < 0.05  # the acceptance; most within 1e-4


def test_the_inverse_starts_from_a_lattice_where_both_starts_miss(gl):
    """Next to a fold, the swapped MLS and u itself may both lie in the basin of no preimage:
    for these two points Newton from either ended 1-4 voxels from u (NaN rows); the starts
    from the lattice whose images lie nearest u find x itself."""
    rng = np.random.default_rng(10)
    shape = (16, 20, 24)
    for amp in (1.0, 3.0):  # the draws of the second, folding, set
        src = rng.uniform(0, 1, (12, 3)) * [23, 19, 15]
        dst = src + rng.normal(0, amp, src.shape)
        rng.uniform(size=(3000, 3))  # (the points this set was first tried at)
    x = np.array([[10.508, 16.436, 5.717], [13.021, 15.541, 4.983]])
    y = reference.mls(src, dst, x, shape=shape)[0]  # f(x) in float64
    with glmls.MLS(src, dst, shape=shape) as m:
        s, valid = m.inverse(y, return_valid=True)
        assert valid.all()
        assert np.abs(m(s) - y).max() < 0.05
        assert np.abs(s - x).max() < 0.01  # the preimage found is x's


def test_a_points_inverse_does_not_depend_on_the_other_points_of_the_call(gl, monkeypatch):
    """The lattice restart of a point that both starts miss is built from that point and f
    alone: the folding set's two hard points come back bit for bit whether they are inverted
    alone or among other points that need the lattice too (a lattice spanning all the missed
    points of a call gave them other starts, and ends some float32 steps apart)."""
    rng = np.random.default_rng(10)
    shape = (16, 20, 24)
    for amp in (1.0, 3.0):  # the draws of the folding set, as in the test above
        src = rng.uniform(0, 1, (12, 3)) * [23, 19, 15]
        dst = src + rng.normal(0, amp, src.shape)
        rng.uniform(size=(3000, 3))
    x = np.array([[10.508, 16.436, 5.717], [13.021, 15.541, 4.983]])
    y = reference.mls(src, dst, x, shape=shape)[0]
    # points of these 20,000 whose starts both miss, or nearly
    others = np.random.default_rng(3).uniform(-10, 35, (20000, 3))
    others = others[[455, 1855, 5325, 6771, 7179, 8459, 9123]]
    restarted = []
    restart = glmls.mls3.InverseMLS3._from_lattice

    def spy(self, u, s):
        restarted.append(len(u))
        return restart(self, u, s)

    monkeypatch.setattr(glmls.mls3.InverseMLS3, "_from_lattice", spy)
    with glmls.MLS(src, dst, shape=shape) as m:
        alone, valid = m.inverse(y, return_valid=True)
        assert valid.all()
        mixed, mixed_valid = m.inverse(np.concatenate([others, y]), return_valid=True)
        assert restarted[0] == 2 and restarted[1] > 2 and mixed_valid.all()
        np.testing.assert_array_equal(mixed[len(others) :], alone)
        np.testing.assert_array_equal(m.inverse(y[::-1]), alone[::-1])


@pytest.mark.parametrize("size", [1e-3, 1e-6])
def test_handles_a_few_thousandths_apart_with_s_0(gl, size):
    """Handles in a box of ``size`` units (a mesh in metres, s=0): a point near a handle
    snaps to it only where the other handles' share of the weights is below float32's
    rounding, so f, J and the deformed mesh follow the float64 f, as for handles in voxels."""
    rng = np.random.default_rng(12)
    src = rng.uniform(0, size, (10, 3))
    dst = src + rng.normal(0, 0.05 * size, src.shape)
    points = rng.uniform(0, size, (300, 3))
    expected = reference.mls(src, dst, points, s=0)[0]
    with glmls.MLS(src, dst, s=0) as m:
        f = m(points)
        out = m.deform((points, rng.integers(0, len(points), (200, 3))))
    assert np.abs(f - expected).max() < 1e-6 * size
    assert np.abs(out.vertices - expected).max() < 1e-6 * size
