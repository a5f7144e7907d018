"""The flat rule of the meshes' folds (glmls.core.mesh3.flat_to_zero): det J is 0 where it
is within FLAT_ROUNDINGS roundings of J's entries times |cof J|, bit for bit the plain test
of every vertex (the rule takes |cof J| only where a cheaper bound leaves the answer open),
and the float64 reference deform_mesh folds a map that flattens space everywhere, whatever
float64's rounding leaves of det J's sign, while a thin map well above that rounding keeps
its det J and does not fold. The exact rule: targets coplanar to float64's rounding
(mesh3.coplanar, at every scale; not one off the plane by 1e-9 of their spread) and the
affine solve the plain A^-1 B at each of J's probes (glmls.reference.plain_affine: not for
similarity or rigid, a ridge, or the identity out of a compact weight's reach) give det J =
0 (deform_mesh's ``flat``)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import probes_plain_affine, tilted_plane

from glmls import reference
from glmls.core import mesh3

EPS64 = np.finfo(np.float64).eps


def _plain(det, jacobian, rounding):
    """The rule at every vertex, as written: |cof J| everywhere, one comparison."""
    size = np.linalg.norm(mesh3.cofactor(jacobian).reshape(len(det), 9), axis=1)
    return np.where(np.abs(det) <= mesh3.FLAT_ROUNDINGS * rounding * size, 0.0, det)


def _rotation(rng, count):
    q, r = np.linalg.qr(rng.normal(size=(count, 3, 3)))
    return q * np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("share", [0.1, 0.8])
def test_the_rule_equals_the_plain_test_bit_for_bit(rng, dtype, share):
    """Random J, ``share`` of them of rank 2 to float32's rounding (the rule takes |cof J|
    at the few vertices its bound leaves open, or at every vertex where they are most), and
    det J set at the rule's threshold and one rounding either side of it; -0.0, NaN and
    infinities too. The roundings are float32 per vertex (the GPU's), or float64 ones."""
    count = 20000
    j = rng.normal(size=(count, 3, 3)) * np.exp(rng.uniform(-5, 5, (count, 1, 1)))
    flat = rng.random(count) < share
    mix = rng.normal(size=(flat.sum(), 2, 1))
    j[flat, 2] = mix[:, 0] * j[flat, 0] + mix[:, 1] * j[flat, 1]
    j = j.astype(np.float32).astype(np.float64)
    j[5, 0, 0], j[6, 1, 1] = np.nan, np.inf
    rounding = np.exp(rng.uniform(-20, -5, count)).astype(dtype)
    with np.errstate(invalid="ignore", over="ignore"):  # the NaN and infinite J
        det = mesh3.determinant(j, mesh3.cofactor(j)).astype(np.float32).astype(np.float64)
        # a third of them at the threshold, or one rounding below or above it
        size = np.linalg.norm(mesh3.cofactor(j).reshape(count, 9), axis=1)
        edge = rng.random(count) < 0.3
        at = mesh3.FLAT_ROUNDINGS * rounding * size * rng.choice([-1.0, 1.0], count)
        away = rng.choice([0.0, 2.0], count) ** rng.integers(0, 2, count)  # 1, 0 or 2
        det[edge] = np.nextafter(at, at * away)[edge]
        det[:5] = [-0.0, np.nan, np.inf, -np.inf, 0.0]
        expected = _plain(det.copy(), j, rounding)
        got = mesh3.flat_to_zero(det.copy(), j, rounding)
        scalar = mesh3.flat_to_zero(det.copy(), j, 1e-9)
        scalar_expected = _plain(det.copy(), j, 1e-9)
    assert got.tobytes() == expected.tobytes()
    assert 0.1 * count < (got == 0).sum() < 0.95 * count  # both sides of the rule are met
    assert scalar.tobytes() == scalar_expected.tobytes()


def test_a_map_that_flattens_space_folds_everywhere_in_the_reference(rng):
    """f(v) = v M with M of rank 2 (turned off the axes), J = M rounded to float64: det J is
    float64's rounding of either sign, and the reference folds every vertex and face; a
    thin map (one singular value 1e-9) keeps det J = 1e-9 and folds none."""
    count = 400
    vertices = rng.uniform(-50, 50, (count, 3))
    faces = rng.integers(0, count, (800, 3))
    u, w = _rotation(rng, 2)
    for share, folds in ((0.0, True), (1e-9, False)):
        m = u @ np.diag([2.0, 0.5, share]) @ w
        jacobian = np.repeat(m[None], count, axis=0)
        jacobian += rng.normal(0, 2 * EPS64, jacobian.shape) * np.abs(m)  # float64 noise
        cof = mesh3.cofactor(jacobian)
        raw = mesh3.determinant(jacobian, cof)
        out = mesh3.deform_mesh(vertices, faces, None, vertices @ m, jacobian)
        if folds:
            assert (raw > 0).any() and (raw < 0).any()  # the sign alone would fold half
            assert (out.det_j == 0).all() and out.vertex_folds.all() and out.face_folds.all()
            assert (out.normals == 0).all()  # no normal where J is singular
        else:
            np.testing.assert_allclose(out.det_j, 1e-9, rtol=1e-6)
            assert not out.vertex_folds.any()


def test_central_differences_take_the_rounding_of_their_step(rng):
    """J by central differences of a float64 f over h carries eps64 |f| / h of rounding:
    given ``step``, the reference counts a flattening map's J as singular; J's own entries'
    rounding (no ``step``) is far below what the differences leave."""
    count, h = 300, 1e-3
    vertices = rng.uniform(0, 100, (count, 3))
    u, w = _rotation(rng, 2)
    m = u @ np.diag([1.0, 0.7, 0.0]) @ w

    def f(v):
        return v @ m + 30.0

    jacobian = np.stack(
        [(f(vertices + h * e) - f(vertices - h * e)) / (2 * h) for e in np.eye(3)], 1
    )
    raw = mesh3.determinant(jacobian, mesh3.cofactor(jacobian))
    assert np.abs(raw).max() > 0
    given = mesh3.deform_mesh(
        vertices, np.zeros((0, 3), np.int64), None, f(vertices), jacobian, step=h
    )
    assert (given.det_j == 0).all() and given.vertex_folds.all()
    exact = mesh3.deform_mesh(vertices, np.zeros((0, 3), np.int64), None, f(vertices), jacobian)
    assert (exact.det_j != 0).any()
    rounding = mesh3.difference_rounding(vertices, f(vertices), h)
    reach = np.maximum(np.abs(vertices).max(axis=1), np.abs(f(vertices)).max(axis=1))
    assert np.array_equal(rounding, EPS64 * reach / h)


@pytest.mark.parametrize("size", [1.0, 100.0, 1e4])
def test_coplanar_targets_to_float64s_rounding(rng, size):
    """Targets projected onto a random plane, or a plane's points turned and moved far off
    the origin, are coplanar, at every scale; one of them off the plane by 1e-3 or 1e-9 of
    their spread is not; three targets always are."""
    for _ in range(200):
        count = int(rng.integers(4, 200))
        src, dst, _ = tilted_plane(rng, size, count)
        turn, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        plane = np.c_[rng.uniform(0, 64, (count, 2)) * size, np.zeros(count)]
        moved = plane @ turn + rng.normal(0, 1e3 * size, 3)
        assert mesh3.coplanar(dst) and mesh3.coplanar(moved)
        for share in (1e-3, 1e-9):
            off = moved.copy()
            spread = np.linalg.norm(moved - moved.mean(axis=0), axis=1).max()
            off[rng.integers(count)] += share * spread * turn[2]
            assert not mesh3.coplanar(off)
        assert mesh3.coplanar(src[:3])


def _differences(src, dst, vertices, h, **options):
    """f and J by float64 central differences of glmls.reference.mls over h."""
    f = reference.mls(src, dst, vertices, **options)[0]
    columns = [
        reference.mls(src, dst, vertices + h * e, **options)[0]
        - reference.mls(src, dst, vertices - h * e, **options)[0]
        for e in np.eye(3)
    ]
    return f, np.stack(columns, axis=1) / (2 * h)


@pytest.mark.parametrize("size", [1.0, 100.0, 1e4])
def test_the_reference_folds_an_affine_map_onto_a_tilted_plane_everywhere(rng, size):
    """Random planes turned off the axes: the affine solve is the plain A^-1 B at every probe
    of every vertex (points in a box half as large again as the handles'), so ``flat``
    zeroes det J everywhere and every vertex and face folds, where float64's J, taken as
    good to its own entries' rounding, leaves det J of either sign at some."""
    vertices = rng.uniform(-16, 80, (300, 3)) * size
    faces = rng.integers(0, len(vertices), (600, 3))
    h = 1e-3 * size
    missed = 0
    for _ in range(4):
        src, dst, _ = tilted_plane(rng, size)
        f, jacobian = _differences(src, dst, vertices, h, transform="affine")
        flat = probes_plain_affine(src, dst, vertices, h, transform="affine")
        assert mesh3.coplanar(dst) and flat.all()
        out = mesh3.deform_mesh(vertices, faces, None, f, jacobian, flat=flat)
        assert (out.det_j == 0).all() and out.vertex_folds.all() and out.face_folds.all()
        assert (out.normals == 0).all()
        missed += (mesh3.deform_mesh(vertices, faces, None, f, jacobian).det_j != 0).sum()
    assert missed > 0  # the rounding rule alone would keep det J at some vertices


@pytest.mark.parametrize("size", [1.0, 100.0, 1e4])
def test_the_plain_affine_solve_alone_is_flat(rng, size):
    """Similarity and rigid never take it; three handles take a ridge; a compact weight
    (cressman) leaves the identity out of every handle's reach (J = I, det J = 1); targets
    off the plane by 1e-3 of their spread are not coplanar, and their map keeps det J
    clear of 0 at most vertices."""
    src, dst, normal = tilted_plane(rng, size)
    vertices = rng.uniform(-40, 96, (400, 3)) * size
    for transform in ("similarity", "rigid"):
        assert not reference.plain_affine(src, dst, vertices, transform=transform).any()
    assert not reference.plain_affine(src[:3], dst[:3], vertices, transform="affine").any()
    reach = {"transform": "affine", "weight": "cressman", "radius": 20.0 * size}
    plain = reference.plain_affine(src, dst, vertices, **reach)
    f, big_m, _ = reference.mls(src, dst, vertices, **reach)
    alone = (np.linalg.norm(vertices[:, None] - src[None], axis=2) > 20.0 * size).all(axis=1)
    assert alone.mean() > 0.3 and not plain[alone].any()
    assert (f[alone] == vertices[alone]).all() and (big_m[alone] == np.eye(3)).all()
    off = dst.copy()
    off[3] += 1e-3 * np.linalg.norm(dst - dst.mean(axis=0), axis=1).max() * normal
    assert not mesh3.coplanar(off)
    h = 1e-3 * size
    f, jacobian = _differences(src, off, vertices, h, transform="affine")
    flat = mesh3.coplanar(off) & probes_plain_affine(src, off, vertices, h, transform="affine")
    out = mesh3.deform_mesh(
        vertices, np.zeros((0, 3), np.int64), None, f, jacobian, step=h, flat=flat
    )
    assert (out.det_j != 0).mean() > 0.9 and not out.vertex_folds.all()
