"""The fold test of a chunk's ``quads`` keypoints with keypoint counts that differ widely
between images: each image's flags are those of its mesh tested alone, in blocks of any
size, and one image's many keypoints make no work or memory for the other meshes."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import glmls
import glmls.batch.covering
import glmls.batch.labels
from glmls.batch.embedding import fold_candidates
from glmls.batch.labels import mesh_keypoints
from glmls.core.mesh import MeshLattice

SHAPE = (28, 36)


def folded_meshes(count: int, grid: int = 1) -> tuple[MeshLattice, np.ndarray]:
    """The lattice and ``count`` deformed meshes (count, rows, columns, 2), each folding
    by its own amount: two handles pass each other."""
    height, width = SHAPE
    lattice = MeshLattice.corners(SHAPE, grid)
    points = lattice.points()
    src = np.array([[4.0, 4.0], [width - 5, 4], [4, height - 5], [width - 5, height - 5]])
    src = np.r_[src, [[width / 2 - 4, height / 2]], [[width / 2 + 4, height / 2]]]
    meshes = []
    for k in range(count):
        dst = src.copy()
        dst[4, 0], dst[5, 0] = width / 2 + 3 + k % 7, width / 2 - 3 - k % 5
        with glmls.MLS(src, dst, shape=SHAPE) as m:
            meshes.append(m(points.reshape(-1, 2)).reshape(points.shape))
    return lattice, np.stack(meshes)


@pytest.mark.parametrize("block", [None, 1, 50])
def test_each_image_keeps_the_flags_of_its_mesh_alone(gl, rng, monkeypatch, block):
    lattice, meshes = folded_meshes(6, grid=2)
    sizes = [0, 500, 3, 1, 0, 40]
    points = [rng.uniform(-1, 36, (k, 2)) for k in sizes]
    alone = [mesh_keypoints(lattice, mesh, p, None) for mesh, p in zip(meshes, points, strict=True)]
    if block is not None:
        monkeypatch.setattr(glmls.batch.covering, "_NEAR_BLOCK", block)
    images = np.repeat(np.arange(len(sizes)), sizes)
    moved, valid = mesh_keypoints(lattice, meshes, np.concatenate(points), None, images)
    ends = np.cumsum(sizes)
    for (want_moved, want_valid), end, size in zip(alone, ends, sizes, strict=True):
        np.testing.assert_array_equal(moved[end - size : end], want_moved)
        np.testing.assert_array_equal(valid[end - size : end], want_valid)
    assert not valid.all()  # the folds hide some


def _peak(function) -> int:
    tracemalloc.start()
    try:
        function()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_many_keypoints_on_one_image_cost_the_others_nothing(gl, rng):
    """64 folded meshes, one with 20,000 keypoints and the others with one: the test takes
    about the memory of that mesh's alone, not 64 meshes' worth of its points."""
    lattice, meshes = folded_meshes(64)
    many = rng.uniform(0, 35, (20_000, 2))
    few = rng.uniform(0, 27, (63, 2))
    points = np.concatenate([many, few])
    images = np.r_[np.zeros(len(many), np.int64), np.arange(1, 64)]
    alone = _peak(lambda: mesh_keypoints(lattice, meshes[:1], many, None))
    together = _peak(lambda: mesh_keypoints(lattice, meshes, points, None, images))
    assert together < 1.25 * alone, (together, alone)


@pytest.mark.parametrize("grid", [1, 2, 4])
def test_points_far_from_a_fold_are_not_tested_and_keep_their_flags(gl, monkeypatch, grid):
    """Only points in the box of a triangle that is not positive are tested for a triangle
    before theirs (the others cannot lie in two: the triangles holding a point sum, with
    their orientations' signs, to the boundary's winding number); a boundary wound twice
    has every point tested. The flags equal those of testing every point, with many of
    them hidden, and most points of a folded mesh are spared the test."""
    rng = np.random.default_rng(grid)
    lattice, meshes = folded_meshes(8, grid=grid)
    centre = meshes[7].reshape(-1, 2).mean(axis=0)
    rel = meshes[7] - centre  # mesh 7 spun twice around its centre: its boundary too
    angle, radius = 2 * np.arctan2(rel[..., 1], rel[..., 0]), np.hypot(rel[..., 0], rel[..., 1])
    meshes[7] = centre + np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=-1)
    points = rng.uniform(-1, 36, (4000, 2))
    images = rng.integers(0, len(meshes), len(points))
    moved, valid = mesh_keypoints(lattice, meshes, points, None, images)
    candidates = fold_candidates(meshes, images, moved)
    assert candidates[images == 7].all()
    assert candidates.mean() < 0.5
    monkeypatch.setattr(
        glmls.batch.labels, "fold_candidates", lambda v, i, p: np.ones(len(p), bool)
    )
    every, flags = mesh_keypoints(lattice, meshes, points, None, images)
    np.testing.assert_array_equal(moved, every)
    np.testing.assert_array_equal(valid, flags)
    inside = glmls.batch.labels.in_lattice(lattice, points)
    assert (inside & ~valid).sum() > 50


def _candidates_one_by_one(meshes: np.ndarray, images: np.ndarray, points: np.ndarray):
    """fold_candidates's rule, point by point: every point of a mesh not shown star-shaped;
    else those within the box (widened by 1e-6 px) of one of its mesh's triangles whose
    doubled area is at most EMBED_MARGIN. Also each mesh's count of such boxes."""
    from glmls.batch import embedding

    keep = np.ones(len(points), bool)
    counts = np.zeros(len(meshes), int)
    for k, mesh in enumerate(meshes.astype(np.float64)):
        if not embedding.star_shaped(mesh[None], embedding.boundary(mesh[None]))[0]:
            continue
        lower, upper = (a[0] for a in embedding.triangle_areas(mesh[None]))
        boxes = []
        triangles = ((lower, ((0, 0), (0, 1), (1, 1))), (upper, ((0, 0), (1, 1), (1, 0))))
        for area, corners in triangles:
            for r, c in zip(*np.nonzero(area <= embedding.EMBED_MARGIN), strict=True):
                tri = np.array([mesh[r + dr, c + dc] for dr, dc in corners])
                boxes.append((tri.min(axis=0) - 1e-6, tri.max(axis=0) + 1e-6))
        counts[k] = len(boxes)
        for i in np.flatnonzero(images == k):
            keep[i] = any(((lo <= points[i]) & (points[i] <= hi)).all() for lo, hi in boxes)
    return keep, counts


@pytest.mark.parametrize("seed", range(4))
def test_fold_candidates_test_each_point_against_its_own_meshs_boxes(seed):
    # meshes that fold by their own amounts, one of them reversed (not star-shaped),
    # points on and around them: the candidates equal the rule applied point by point, in
    # blocks of a few meshes and pieces of a few hundred point-box pairs too, where a mesh
    # of more pairs than a piece keeps every point
    rng = np.random.default_rng(seed)
    _, meshes = folded_meshes(7)
    meshes = np.concatenate([meshes, meshes[:1, ::-1]])
    meshes = (meshes + rng.normal(0, 0.03 * seed, meshes.shape)).astype(np.float32)
    points = rng.uniform(-2, 38, (600, 2))
    images = rng.integers(0, len(meshes), len(points))
    expected, boxes = _candidates_one_by_one(meshes, images, points)
    assert expected.any() and not expected.all()
    np.testing.assert_array_equal(fold_candidates(meshes, images, points), expected)
    pairs = np.bincount(images, minlength=len(meshes)) * boxes
    piece = int(np.median(pairs[pairs > 0]))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(glmls.batch.embedding, "_FOLD_BLOCK", 3 * meshes[0].size // 2)
        patch.setattr(glmls.batch.embedding, "_FOLD_PAIRS", piece)
        found = fold_candidates(meshes, images, points)
    whole = pairs[images] > piece
    assert whole.any() and (~whole & (pairs[images] > 0)).any()
    np.testing.assert_array_equal(found, expected | whole)


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def _hidden_by_any_triangle(mesh, points, moved):
    """The float64 rule of mesh_keypoints, triangle by triangle (grid 1): a point is hidden
    where a triangle before its own (cell row, column, then (00, 10, 11) before (00, 11,
    01), its own the one its source point lies in) holds its moved point strictly inside,
    in either orientation."""
    rows, columns = mesh.shape[0] - 1, mesh.shape[1] - 1
    cell = np.clip(np.floor(points + 0.5).astype(np.int64), 0, [columns - 1, rows - 1])
    local = points + 0.5 - cell
    hidden = np.zeros(len(points), bool)
    for k, q in enumerate(moved):
        col, row = cell[k]
        own = (row * columns + col) * 2 + int(local[k, 1] > local[k, 0])
        for key in range(own):
            r, c = divmod(key // 2, columns)
            p00, p10, p11, p01 = mesh[r, c], mesh[r, c + 1], mesh[r + 1, c + 1], mesh[r + 1, c]
            x0, x1, x2 = (p00, p10, p11) if key % 2 == 0 else (p00, p11, p01)
            area = _cross(x1 - x0, x2 - x0)
            if area == 0:
                continue
            edges = ((x0, x1), (x1, x2), (x2, x0))
            if all(_cross(v - u, q - u) * np.sign(area) > 1e-9 * abs(area) for u, v in edges):
                hidden[k] = True
                break
    return hidden


@pytest.mark.parametrize("shape", [(28, 36), (41, 19)])
@pytest.mark.parametrize("fold", ["handles pass", "spun twice"])
def test_the_tiles_find_every_triangle_that_hides_a_point(gl, rng, shape, fold):
    """Tiles of 16 x 16 cells (fewer at the last row and column), then their rows' pieces,
    then the cells: the points hidden are those a search of every earlier triangle finds,
    on meshes that fold (in the middle; everywhere, spun twice about the centre) and whose
    sides are no multiple of the tile."""
    lattice = MeshLattice.corners(shape, 1)
    grid = lattice.points()
    height, width = shape
    if fold == "spun twice":
        rel = grid - [(width - 1) / 2, (height - 1) / 2]
        angle, radius = 2 * np.arctan2(rel[..., 1], rel[..., 0]), np.hypot(*np.moveaxis(rel, -1, 0))
        mesh = [(width - 1) / 2, (height - 1) / 2] + np.stack(
            [radius * np.cos(angle), radius * np.sin(angle)], axis=-1
        )
    else:  # two handles pass each other
        src = np.array([[4.0, 4], [width - 5, 4], [4, height - 5], [width - 5, height - 5],
                        [width / 2 - 4, height / 2], [width / 2 + 4, height / 2]])  # fmt: skip
        dst = src.copy()
        dst[4, 0], dst[5, 0] = width / 2 + 5, width / 2 - 5
        with glmls.MLS(src, dst, shape=shape) as m:
            mesh = m(grid.reshape(-1, 2)).reshape(grid.shape)
    points = rng.uniform(-0.4, [width - 0.6, height - 0.6], (300, 2))
    moved, valid = mesh_keypoints(lattice, mesh, points, None)
    hidden = _hidden_by_any_triangle(mesh, points, moved)
    assert hidden.any() and not hidden.all()
    np.testing.assert_array_equal(valid, ~hidden)
