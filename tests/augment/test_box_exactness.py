"""Boxes hold their warped objects: with ``quads`` the moved outline holds every point where
a side crosses a cell's or a triangle's edge of the mesh, whose map is linear between them,
so the box is the warped outline's extent, exactly (a float64 reference of the mesh's map
on an outline sampled every 0.005 px says so); with the mesh's vertices inside the box it is
the whole warped box's extent where the map folds too, and every output pixel that shows
the object lies in it."""

from __future__ import annotations

import numpy as np
import pytest

from glmls import reference
from glmls.augment import Augment, box_outlines
from glmls.core.mesh import MeshLattice


def objects(rng, count, shape):
    """Per image one rectangle of pixels off the image's edge (where the edge border would
    repeat it), as a mask, and its box around the pixels' squares."""
    height, width = shape
    masks = np.zeros((count, height, width), np.uint8)
    boxes = np.zeros((count, 1, 4))
    for i in range(count):
        x0, y0 = rng.integers(1, width - 12), rng.integers(1, height - 12)
        x1 = min(x0 + int(rng.integers(3, 20)), width - 2)
        y1 = min(y0 + int(rng.integers(3, 20)), height - 2)
        masks[i, y0 : y1 + 1, x0 : x1 + 1] = 1
        boxes[i, 0] = [x0 - 0.5, y0 - 0.5, x1 + 0.5, y1 + 0.5]
    return masks, boxes


@pytest.mark.parametrize("grid", [1, 4, 7])
def test_a_box_holds_its_warped_object(gl, grid):
    rng = np.random.default_rng(3)
    masks, boxes = objects(rng, 60, (48, 64))
    aug = Augment("grid", seed=5, displacement=0.08, warp_options={"grid": grid})
    out = aug(masks * 255, masks=masks, boxes=boxes)
    for i in range(len(masks)):
        rows, columns = np.nonzero(out.masks[i])
        x_min, y_min, x_max, y_max = out.boxes[i][0]
        assert out.boxes_valid[i][0]
        assert x_min <= columns.min() and columns.max() <= x_max, (i, out.boxes[i])
        assert y_min <= rows.min() and rows.max() <= y_max, (i, out.boxes[i])


def mesh_map(f, lattice: MeshLattice, points: np.ndarray) -> np.ndarray:
    """The mesh's piecewise linear map at ``points`` in the lattice, in float64: the cell
    holding each, its triangle (00, 10, 11) where u >= v, else (00, 11, 01)."""
    origin, last = np.asarray(lattice.origin), np.asarray(lattice.last)
    index = np.clip(np.floor((points - origin) / lattice.grid), 0, np.asarray(lattice.cells) - 1)
    low = np.minimum(origin + index * lattice.grid, last)
    high = np.minimum(origin + (index + 1) * lattice.grid, last)
    u, v = ((points - low) / (high - low)).T
    corners = [low, np.c_[high[:, 0], low[:, 1]], np.c_[low[:, 0], high[:, 1]], high]
    d00, d10, d01, d11 = (f(c) for c in corners)
    lower = (u >= v)[:, None]
    ex = np.where(lower, d10 - d00, d11 - d01)
    ey = np.where(lower, d11 - d10, d01 - d00)
    return d00 + u[:, None] * ex + v[:, None] * ey


@pytest.mark.parametrize(("grid", "shape"), [(1, (30, 41)), (4, (30, 41)), (6, (33, 50))])
def test_quads_boxes_are_the_warped_outlines_extent(gl, grid, shape):
    rng = np.random.default_rng(4)
    _, boxes = objects(rng, 12, shape)
    options = {"grid": grid, "border": "constant"}  # the mesh of the image alone
    aug = Augment("grid", seed=2, displacement=0.1, warp_options=options)
    out = aug(np.zeros((len(boxes), *shape), np.uint8), boxes=boxes)
    lattice = MeshLattice.corners(shape, grid)
    for i, draw in enumerate(out.params):
        src, dst = np.array(draw["src"]), np.array(draw["dst"])

        def f(points, src=src, dst=dst):
            return reference.mls(src, dst, points, shape=shape, transform="similarity")[0]

        outline, _ = box_outlines(boxes[i], 0.005)
        moved = mesh_map(f, lattice, outline)
        high = (shape[1] - 0.5, shape[0] - 0.5)  # clipped to the canvas
        extent = np.clip([*moved.min(axis=0), *moved.max(axis=0)], -0.5, [*high, *high])
        np.testing.assert_allclose(out.boxes[i][0], extent, rtol=0, atol=2e-3)


@pytest.mark.parametrize(
    ("preset", "options", "grid", "shape"),
    [
        ("grid", {"displacement": 0.3}, 4, (48, 64)),
        ("grid", {"displacement": 0.3}, 1, (48, 64)),
        ("text-perspective", {"radius": 40.0}, 2, (32, 128)),
    ],
)
def test_a_box_holds_its_object_where_the_map_folds(gl, preset, options, grid, shape):
    """Where the map folds, the inside of a box can land past its moved outline (a fold
    turns it back over the outline): the box holds the mesh's vertices inside it too, and
    with them every output pixel that shows the object."""
    rng = np.random.default_rng(1)
    masks, boxes = objects(rng, 120, shape)
    aug = Augment(preset, seed=5, warp_options={"grid": grid, "border": "constant"}, **options)
    out = aug(masks * 255, masks=masks, boxes=boxes)
    outside = []
    for i in range(len(masks)):
        rows, columns = np.nonzero(out.masks[i])
        if not len(rows):
            continue
        x_min, y_min, x_max, y_max = out.boxes[i][0]
        reach = max(x_min - columns.min(), columns.max() - x_max)
        reach = max(reach, y_min - rows.min(), rows.max() - y_max)
        if reach > 0:
            outside.append((i, float(reach)))
    assert not outside, outside


def _mesh_vertices_inside(box, grid, shape):
    """The mesh's vertices strictly inside ``box``, row by row, by brute force."""
    height, width = shape
    xs = np.unique(np.append(np.arange(-0.5, width, grid), width - 0.5))
    ys = np.unique(np.append(np.arange(-0.5, height, grid), height - 0.5))
    xs = xs[(xs > box[0]) & (xs < box[2])]
    ys = ys[(ys > box[1]) & (ys < box[3])]
    return np.array([[x, y] for y in ys for x in xs]).reshape(-1, 2)


@pytest.mark.parametrize("grid", [1, 3, 4])
def test_many_boxes_at_once_equal_each_box_alone(grid):
    """box_outlines of many boxes (lines, points, boxes past the image and on its mesh lines
    among them) gives each box the points it gets alone, its mesh vertices last, those
    inside it and no other; outline_sets splits a batch's boxes back per image and names the
    image of a box it refuses."""
    from glmls.augment.labels import outline_sets

    rng = np.random.default_rng(grid)
    shape = (23, 30)
    low = np.round(rng.uniform(-6, 34, (80, 2)) * 2) / 2
    boxes = np.concatenate([low, low + rng.uniform(0, 14, (80, 2))], axis=1)
    boxes[::9, 2] = boxes[::9, 0]  # lines
    boxes[::13, 2:] = boxes[::13, :2]  # points
    points, counts = box_outlines(boxes, 1.5, mesh=(grid, shape))
    pieces = np.split(points, np.cumsum(counts)[:-1])
    for box, piece in zip(boxes, pieces, strict=True):
        alone, _ = box_outlines(box, 1.5, mesh=(grid, shape))
        np.testing.assert_array_equal(piece, alone)
        inner = _mesh_vertices_inside(box, grid, shape)
        np.testing.assert_array_equal(piece[len(piece) - len(inner) :], inner)
    sets = [boxes[:5], boxes[5:5], boxes[5:40], boxes[40:]]
    meshes = [(grid, shape), (grid, shape), None, (grid, shape)]
    for given, mesh, (outline, part) in zip(
        sets, meshes, outline_sets(sets, [1.5] * 4, meshes), strict=True
    ):
        want, want_counts = box_outlines(given, 1.5, mesh=mesh) if len(given) else (None, None)
        if want is None:
            assert outline.shape == (0, 2) and part.shape == (0,)
        else:
            np.testing.assert_array_equal(outline, want)
            np.testing.assert_array_equal(part, want_counts)
    huge = [boxes[:2], np.array([[0.0, 0.0, 1e7, 1.0]])]
    with pytest.raises(ValueError, match=r"boxes\[1\] with box_step=1: step 1 px puts"):
        outline_sets(huge, [1.0, 1.0], [None, None])
