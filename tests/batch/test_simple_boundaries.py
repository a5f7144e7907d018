"""Meshes whose boundary is simple but not star-shaped about the centre vertex (a long strip
bent along its length, as text lines are): embeddings, shown so by a test of the boundary
edge against edge, on the host (:func:`glmls.batch.embedding.embedded`, for the keypoints' fold
test) and on the GPU (``batch/check.comp.glsl``, for the scan without keys), and a strip
wound more than once around (every triangle positive, the boundary crossing itself) is not.
Keypoints beyond the meshes move by f of all images at once."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.batch import chunks, embedding, labels
from glmls.batch.embedding import SIMPLE_EDGES, cross, embedded, simple_rings
from glmls.batch.gpu import BatchQuads
from glmls.core.mesh import MeshLattice

HEIGHT, WIDTH = 8, 240
_XS = np.linspace(0.0, WIDTH - 1.0, 41)
#: Handles along the strip's top and bottom rows.
SRC = np.r_[np.c_[_XS, np.zeros(41)], np.c_[_XS, np.full(41, HEIGHT - 1.0)]]


def bent(turns: float) -> np.ndarray:
    """The strip's handles on an annulus about (120, 120), its length ``turns`` times around
    (clockwise in x, y: the triangles keep their orientation)."""
    radius = WIDTH / (2 * np.pi * turns)
    theta = -SRC[:, 0] / radius
    r = radius + SRC[:, 1] - (HEIGHT - 1) / 2
    return np.c_[r * np.cos(theta), r * np.sin(theta)] + 120.0


CASES = {"straight": SRC, "arc": bent(300 / 360), "wound": bent(1.6)}


def _meshes() -> np.ndarray:
    lattice = MeshLattice.corners((HEIGHT, WIDTH), 4)
    points = lattice.points()
    out = []
    for dst in CASES.values():
        with glmls.MLS(SRC, dst, shape=(HEIGHT, WIDTH), transform="rigid") as m:
            out.append(m(points.reshape(-1, 2)).reshape(points.shape))
    return np.stack(out)


def _triangles_positive(vertices: np.ndarray) -> np.ndarray:
    a, b = vertices[:, :-1, :-1], vertices[:, :-1, 1:]
    c, d = vertices[:, 1:, 1:], vertices[:, 1:, :-1]
    return ((cross(b - a, c - a) > 0) & (cross(c - a, d - a) > 0)).all(axis=(1, 2))


def test_simple_rings_of_polygons():
    def rings(*polygons):
        return simple_rings(np.array(polygons, np.float64))

    square = [[0, 0], [1, 0], [2, 0], [2, 1], [2, 2], [1, 2], [0, 2], [0, 1]]  # collinear sides
    u_shape = [[0, 0], [6, 0], [6, 4], [5, 4], [5, 1], [1, 1], [1, 4], [0, 4]]  # not star
    crossed = [[0, 0], [2, 0], [2, 2], [1, 2], [1, -1], [3, -1], [3, 3], [0, 3]]
    back = [[0, 0], [4, 0], [2, 0], [2, 3], [1, 3], [0, 3], [0, 2], [0, 1]]  # turns back
    assert rings(square, u_shape, crossed, back).tolist() == [True, True, False, False]
    # a notch down to 5e-4 above the bottom edge is too close; to 1e-2, apart
    near = [[0, 0], [6, 0], [6, 4], [3, 5e-4], [0, 4]]
    apart = [[0, 0], [6, 0], [6, 4], [3, 1e-2], [0, 4]]
    assert rings(near, apart).tolist() == [False, True]
    nan = np.array(square, np.float64)
    nan[3] = np.nan
    assert rings(nan).tolist() == [False]
    angles = np.linspace(0, 2 * np.pi, SIMPLE_EDGES + 1, endpoint=False)
    circle = np.c_[np.cos(angles), np.sin(angles)] * 100
    assert rings(circle).tolist() == [False]  # too many edges to test: not shown
    assert rings(circle[:: (SIMPLE_EDGES + 1) // 64][:64]).tolist() == [True]


def test_a_bent_strip_is_an_embedding_and_a_wound_one_is_not(monkeypatch):
    meshes = _meshes()
    assert _triangles_positive(meshes).all()  # the wound strip folds by its boundary alone
    assert embedded(meshes).tolist() == [True, True, False]
    # the arc is shown by the edges' test: its boundary is not star-shaped about the centre
    monkeypatch.setattr(embedding, "simple_rings", lambda rings: np.zeros(len(rings), bool))
    assert embedded(meshes).tolist() == [True, False, False]


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_the_gpu_check_shows_the_bent_strip_and_the_pixels_are_the_single_warps(gl, interpolation):
    rng = np.random.default_rng(3)
    images = rng.integers(0, 255, (3, HEIGHT, WIDTH), dtype=np.uint8)
    dst = list(CASES.values())
    canvas = {"output_shape": (240, 240), "origin": (0.0, 0.0), "grid": 4}
    glmls.warp_batch(images, [SRC] * 3, dst, interpolation="linear", **canvas)
    assert BatchQuads.of(None).scan_folded().tolist() == [False, False, True]
    options = {"interpolation": interpolation, **canvas}
    out = glmls.warp_batch(images, [SRC] * 3, dst, **options)
    for image, target, warped in zip(images, dst, out, strict=True):
        np.testing.assert_array_equal(warped, glmls.warp(image, SRC, target, **options))
    assert out[1].any() and out[2].any()


def test_keypoints_on_a_bent_strip_are_valid_and_on_a_wound_one_some_are_hidden(gl):
    rng = np.random.default_rng(4)
    images = rng.integers(0, 255, (3, HEIGHT, WIDTH), dtype=np.uint8)
    points = np.c_[rng.uniform(0, WIDTH - 1, 400), rng.uniform(0, HEIGHT - 1, 400)]
    canvas = {"output_shape": (240, 240), "origin": (0.0, 0.0), "grid": 4}
    result = glmls.warp_batch(
        images, [SRC] * 3, list(CASES.values()), keypoints=[points] * 3, **canvas
    )
    straight, arc, wound = result.keypoints_valid
    on_canvas = labels.on_canvas(result.keypoints[1], (240, 240))
    assert on_canvas.all() and arc.all() and straight.all()  # an embedding hides none
    assert 0 < (~wound).sum() < len(points)  # the second turn covers part of the first


def test_keypoints_beyond_the_meshes_move_by_f_of_all_images_at_once(gl, monkeypatch):
    """Footprint points and keypoints outside the image (where no cell lies, the constant
    border) move by f bit for bit as each image's own MLS moves them, without one."""
    rng = np.random.default_rng(5)
    count = 6
    images = rng.integers(0, 255, (count, 20, 28), dtype=np.uint8)
    src = rng.uniform(2, 18, (count, 6, 2))
    dst = src + rng.normal(0, 2, src.shape)
    outside = rng.uniform(-6, 34, (count, 30, 2))
    made = []
    monkeypatch.setattr(chunks, "MLS", lambda *a, **k: made.append(a) or glmls.MLS(*a, **k))
    for interpolation in ("nearest", "linear"):
        result = glmls.warp_batch(
            images, src, dst, keypoints=outside, grid=4, interpolation=interpolation
        )
        assert made == []
        for k in range(count):
            far = ~np.all((outside[k] >= -0.5) & (outside[k] <= (27.5, 19.5)), axis=1)
            assert far.any()
            with glmls.MLS(src[k], dst[k], shape=(20, 28)) as f:
                np.testing.assert_array_equal(result.keypoints[k][far], f(outside[k][far]))
