"""Reference tetrahedra (eq. 10 over six edges, the change of the 12 face angles), slivers left
out and counted, against hand-computed cases and the float64 reference."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.analysis import (
    SLIVER_QUALITY,
    ReferenceDeformation,
    delaunay3,
    tetrahedron_errors,
    tetrahedron_quality,
)

CORNER = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])  # the right-corner tetrahedron
CUBE = np.array([[x, y, z] for z in (0, 10) for y in (0, 10) for x in (0, 10)], dtype=float)


def rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_the_identity_has_no_error():
    points = np.random.default_rng(1).uniform(0, 50, (40, 3))
    found = tetrahedron_errors(lambda r: r.copy(), points)
    assert len(found.simplices) > 0
    assert not found.distance.any() and not found.angle.any() and not found.inverted.any()
    stats = found.stats()
    assert stats["tetrahedra"] + stats["slivers"] == len(delaunay3(points)[1])
    assert stats["angle"]["max"] == 0.0 and stats["inverted"] == 0


@pytest.mark.parametrize("scale", [0.5, 0.7, 2.0])
def test_a_similarity_changes_no_angle_and_every_distance_by_the_scale(scale):
    rng = np.random.default_rng(2)
    points = rng.uniform(0, 50, (40, 3))
    turn = rotation(rng)
    found = tetrahedron_errors(lambda r: scale * r @ turn + [3.0, -2.0, 7.0], points)
    assert found.angle.max() < 1e-9
    assert_allclose(found.distance, abs(scale - 1), rtol=0, atol=1e-12)
    assert not found.inverted.any()


def test_a_stretch_of_the_right_corner_by_hand():
    """z doubled: edges 0-3 (1 -> 2), 1-3 and 2-3 (sqrt 2 -> sqrt 5); faces 013 and 023 keep
    their right angle and turn 45 -> atan 2 (63.43) and 45 -> atan 1/2 (26.57); face 123
    goes from equilateral to the isosceles of apex acos 0.8 (36.87)."""
    found = tetrahedron_errors(
        lambda r: r * [1.0, 1.0, 2.0], CORNER, tetrahedra=[[0, 1, 2, 3]], min_quality=0
    )
    edges = (1.0 + 2 * (np.sqrt(5) - np.sqrt(2)) / np.sqrt(2)) / 6
    assert found.distance[0] == pytest.approx(edges, rel=1e-12)
    turn = np.degrees(np.arctan(2)) - 45
    apex = np.degrees(np.arccos(0.8))
    base = (180 - apex) / 2
    angles = (4 * turn + 2 * (base - 60) + (60 - apex)) / 12
    assert found.angle[0] == pytest.approx(angles, rel=1e-12)
    assert not found.inverted[0]


def test_the_paper_measure_is_eq_11_per_face_angle():
    eps = 1e-6
    found = tetrahedron_errors(
        lambda r: r * [1.0, 1.0, 2.0], CORNER, tetrahedra=[[0, 1, 2, 3]], angle="paper", eps=eps
    )
    before = np.radians([90, 45, 45] * 3 + [60, 60, 60])
    a = np.arctan(2)
    apex = np.arccos(0.8)
    after = np.array(
        [np.pi / 2, np.pi / 4, np.pi / 4, np.pi / 2, a, np.pi / 2 - a]
        + [np.pi / 2, a, np.pi / 2 - a, (np.pi - apex) / 2, (np.pi - apex) / 2, apex]
    )
    expected = np.mean(
        (np.abs(np.cos(before) - np.cos(after)) + eps) / (np.abs(np.cos(before)) + eps)
    )
    assert found.angle[0] == pytest.approx(expected, rel=1e-9)
    assert found.angle_measure == "paper" and found.stats()["angle_measure"] == "paper"


def test_a_mirror_inverts_every_tetrahedron_but_keeps_the_angles():
    found = tetrahedron_errors(lambda r: r * [-1.0, 1.0, 1.0], CUBE)
    assert found.inverted.all() and found.angle.max() < 1e-12
    assert found.stats()["inverted"] == len(found.simplices)


@pytest.mark.parametrize("offset", [0.0, 3000.0])
def test_a_flattening_that_rounds_off_zero_inverts_every_tetrahedron(offset):
    # onto the plane x + y + z = offset: every image has volume 0, but rounds to +-1e-13
    found = tetrahedron_errors(lambda r: r - (r.sum(1, keepdims=True) - offset) / 3, CUBE + 3)
    assert found.inverted.all() and found.stats()["inverted"] == len(found.simplices)


def test_a_thin_squeeze_inverts_nothing():
    found = tetrahedron_errors(lambda r: r * [1.0, 1.0, 1e-9] + 100.0, CUBE + 3)
    assert not found.inverted.any()


def test_the_mls_of_crossing_handles_inverts_the_tetrahedra_between_them():
    src = np.array([[10.0, 10, 10], [30, 10, 10], [20, 25, 10], [20, 15, 25], [20, 15, 0]])
    dst = src.copy()
    dst[0], dst[1] = src[1], src[0]  # the two handles swap places
    m = ReferenceDeformation(src, dst, transform="affine")
    found = tetrahedron_errors(m, src)
    f = m(src)
    volumes = lambda t: np.einsum(  # noqa: E731
        "ti,ti->t", t[:, 1] - t[:, 0], np.cross(t[:, 2] - t[:, 0], t[:, 3] - t[:, 0])
    )
    expected = np.sign(volumes(src[found.simplices])) != np.sign(volumes(f[found.simplices]))
    assert_array_equal(found.inverted, expected)
    assert found.inverted.any()
    assert_allclose(found.deformed_points, f)


@pytest.mark.parametrize("offset", [0.0, 1e5, 5e5, 9e5])
def test_far_from_the_origin_the_gpus_inversions_are_the_float64_ones(gl, offset):
    """Handles and points 5e5 voxels out: the GPU holds them about its frame's centre, so
    f(r)'s float32 rounding is that of a map at the origin; taken about the origin it made a
    flatness tolerance of ~1e3 voxel³ and flagged 126 of 139 healthy tetrahedra."""
    rng = np.random.default_rng(21)
    src = offset + rng.uniform(0, 40, (10, 3))
    dst = src + rng.normal(0, 2, src.shape)
    points = offset + rng.uniform(0, 40, (40, 3))
    with glmls.MLS(src, dst, transform="similarity", ctx=gl) as m:
        found = tetrahedron_errors(m, points)
    expected = tetrahedron_errors(ReferenceDeformation(src, dst, transform="similarity"), points)
    assert_array_equal(found.simplices, expected.simplices)
    assert_array_equal(found.inverted, expected.inverted)


def test_quality_is_the_radius_ratio():
    regular = np.array([[[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]])
    assert tetrahedron_quality(regular)[0] == pytest.approx(1.0, rel=1e-12)
    # one of the six tetrahedra of a unit cube: volume 1/6, faces 1/2, 1/2, sqrt(2)/2 twice,
    # so r = 3 V / area = 1 / (2 (1 + sqrt 2)); R = sqrt(3) / 2, the cube's
    kuhn = np.array([[[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 1]]])
    expected = 3 / (2 * (1 + np.sqrt(2))) / (np.sqrt(3) / 2)
    assert tetrahedron_quality(kuhn)[0] == pytest.approx(expected, rel=1e-12)
    assert tetrahedron_quality(7.0 * kuhn + 3)[0] == pytest.approx(expected, rel=1e-12)
    flat = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]])
    assert tetrahedron_quality(flat)[0] == 0.0
    with pytest.raises(ValueError, match=r"\(T, 4, 3\)"):
        tetrahedron_quality(np.zeros((2, 3, 3)))


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_quality_of_corners_that_are_not_finite_is_refused_not_0(value):
    """A NaN corner gave quality 0, as a flat tetrahedron's."""
    corners = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]] * 2)
    corners[1, 2, 0] = value
    with pytest.raises(ValueError, match=r"^corners must be finite; tetrahedron 1 is "):
        tetrahedron_quality(corners)


def test_slivers_are_left_out_and_counted():
    # a fine tetrahedron, a flat one (zero volume), and a sliver (4 points of a square, one
    # lifted by 0.01: every face fine, the volume almost nothing)
    points = np.array(
        [[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10], [10, 10, 0], [10, 10, 0.01]]
    )
    tetrahedra = np.array([[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]])
    quality = tetrahedron_quality(points[tetrahedra])
    assert quality[0] > 0.5 and quality[1] == 0 and 0 < quality[2] < SLIVER_QUALITY
    found = tetrahedron_errors(lambda r: r + 1.0, points, tetrahedra=tetrahedra)
    assert_array_equal(found.simplices, tetrahedra[:1])
    assert_array_equal(found.slivers, tetrahedra[1:])
    assert found.stats()["slivers"] == 2 and found.stats()["tetrahedra"] == 1
    assert found.min_quality == SLIVER_QUALITY
    # min_quality 0 keeps the sliver, never the flat one
    kept = tetrahedron_errors(lambda r: r + 1.0, points, tetrahedra=tetrahedra, min_quality=0)
    assert_array_equal(kept.simplices, tetrahedra[[0, 2]])
    assert_array_equal(kept.slivers, tetrahedra[[1]])
    with pytest.raises(ValueError, match="every one of the 2 tetrahedra is a sliver"):
        tetrahedron_errors(lambda r: r, points, tetrahedra=tetrahedra[1:])


def test_delaunay_slivers_of_random_points_are_below_the_threshold():
    points = np.random.default_rng(4).uniform(0, 1, (80, 3))
    _, simplices = delaunay3(points)
    found = tetrahedron_errors(lambda r: r * 2, points)
    quality = tetrahedron_quality(points[simplices])
    assert len(found.slivers) == int((quality < SLIVER_QUALITY).sum()) > 0
    assert found.quality.min() >= SLIVER_QUALITY
    assert len(found.simplices) + len(found.slivers) == len(simplices)


@pytest.mark.parametrize(
    ("points", "options", "message"),
    [
        (CORNER[:3], {}, "at least 4"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], {}, "one plane"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1e300, 0, 0]], {}, r"within 1e-10 .*, 0\."),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]], {}, r"\[4\] repeats"),
        ([[0, 0], [1, 0], [0, 1], [1, 1]], {}, r"\(N, 3\)"),
        (CORNER, {"tetrahedra": [[0, 1, 2, 3], [0, 1, 2, 4]]}, r"\[1\] is \[0, 1, 2, 4\].* 4 "),
        (CORNER, {"tetrahedra": [[0, 1, 2, 3], [-1, 1, 2, 3]]}, r"\[1\] is \[-1, 1, 2, 3\]"),
        (CORNER, {"tetrahedra": [[0, 1, 2, 3], [0, 1, 2, 2]]}, r"\[1\] .*repeats a vertex"),
        (CORNER, {"tetrahedra": np.array([[0, 1, 2, 2**63]], np.uint64)}, r"\[0\] is"),
        (CORNER, {"tetrahedra": [[0, 1, 2]]}, r"\(T, 4\)"),
        (CORNER, {"angle": "radians"}, "unknown angle 'radians'"),
        (CORNER, {"eps": 0}, "eps"),
        (CORNER, {"min_quality": 1.0}, "min_quality"),
    ],
)
def test_bad_arguments_raise(points, options, message):
    with pytest.raises(ValueError, match=message):
        tetrahedron_errors(lambda r: r, points, **options)


def test_an_angle_measure_of_another_type_is_a_type_error():
    for angle in (None, 1):
        with pytest.raises(TypeError, match=f"angle must be a string, .*; got {angle}"):
            tetrahedron_errors(lambda r: r, CORNER, angle=angle)


def test_ragged_rows_are_a_value_error_naming_the_argument():
    with pytest.raises(ValueError, match=r"tetrahedra must be \(T, 4\).*rows of different"):
        tetrahedron_errors(lambda r: r, CORNER, tetrahedra=[[0, 1, 2, 3], [0, 1]])
    ragged = [[0, 0, 0], [1, 0, 0], [0, 1], [0, 0, 1]]
    with pytest.raises(ValueError, match=r"reference_points must .*rows of different"):
        tetrahedron_errors(lambda r: r, ragged)
    with pytest.raises(ValueError, match=r"src must .*rows of different"):
        ReferenceDeformation(ragged, CORNER)


def test_tetrahedra_of_zero_volume_are_named_where_every_one_is_a_sliver():
    points = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [10, 10, 0], [10, 10, 0.01]])
    flat = r"zero volume, which no min_quality keeps .*tetrahedra\[1\] = \[0, 1, 2, 3\]"
    with pytest.raises(ValueError, match=flat):
        tetrahedron_errors(lambda r: r, points, tetrahedra=[[0, 1, 2, 4], [0, 1, 2, 3]])
    with pytest.raises(ValueError, match=r"lower min_quality$"):  # a sliver, none flat
        tetrahedron_errors(lambda r: r, points, tetrahedra=[[0, 1, 2, 4]])


def test_tetrahedra_that_are_not_integers_are_a_type_error():
    for tetrahedra in ([[0.0, 1, 2, 3]], [[True, False, True, False]], [["0", "1", "2", "3"]]):
        with pytest.raises(TypeError, match="tetrahedra must be integer indices, got dtype"):
            tetrahedron_errors(lambda r: r, CORNER, tetrahedra=tetrahedra)


def test_a_bad_map_raises():
    with pytest.raises(ValueError, match="returned shape"):
        tetrahedron_errors(lambda r: r[:, :2], CUBE)
    with pytest.raises(ValueError, match="NaN"):
        tetrahedron_errors(lambda r: r * np.nan, CUBE)


def test_the_arrays_are_read_only():
    found = tetrahedron_errors(lambda r: r, CUBE)
    for array in (found.points, found.simplices, found.angle, found.inverted, found.slivers):
        assert not array.flags.writeable


def test_points_beyond_the_coordinate_range_are_refused_before_qhull():
    """Qhull crashes the interpreter on some such points: a child process shows it."""
    script = (
        "import numpy as np, glmls\n"
        "r = np.random.default_rng(0).random((8, 3)) * 100\n"
        "for points, options in ((r * 1e150, {}), (r * 1e150, {'tetrahedra': [[0, 1, 2, 3]]}),\n"
        "                        (np.vstack([r[:7], [[np.inf, 0, 0]]]), {})):\n"
        "    try:\n"
        "        glmls.analysis.tetrahedron_errors(lambda p: p * 2, points, **options)\n"
        "    except ValueError as error:\n"
        "        print(str(error).split(';')[0])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        "reference_points must lie within ±1e+06 voxels of the origin (float32 on the GPU "
        "keeps ~1e-7 of the coordinates' extent)",
    ] * 2 + ["reference_points must be finite"]


@pytest.mark.parametrize("scale", [1e-150, 1e-300])
def test_tiny_points_are_measured_as_their_copy_at_unit_scale(scale):
    """Their volumes underflow float64: a shape 1e-150 across is not on one plane."""
    points = np.random.default_rng(0).random((8, 3)) * 100
    unit = tetrahedron_errors(lambda r: r * 2.0, points)
    tiny = tetrahedron_errors(lambda r: r * 2.0, points * scale)
    assert_array_equal(tiny.simplices, unit.simplices)
    assert_allclose(tiny.quality, unit.quality, rtol=1e-12)
    assert_allclose(tiny.distance, 1.0, rtol=1e-12)
    assert not tiny.angle.any() and not tiny.inverted.any()
    corners = points[unit.simplices]
    assert_allclose(tetrahedron_quality(corners * scale), tetrahedron_quality(corners), 1e-12)
