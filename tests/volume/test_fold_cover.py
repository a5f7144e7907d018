"""The backward method next to folds (glmls.volume.folds): an output voxel whose preimage
lies inside the volume is found where Newton from the cells' guess and from the voxel itself
both end on another sheet of f (or at a preimage outside the volume), from the points found
for its neighbours; the check is an independent float64 search for preimages; slabs and
boxes of columns and rows still change no voxel."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.core.config import MLSConfig
from glmls.volume import SlabOptions, volume_coordinate_map
from glmls.volume.construction import VolumeWarper
from glmls.volume.fields import NEWTON_ACCEPT, ReferenceField, fold_neighbours, newton_inverse
from glmls.volume.kernel_field import KernelField
from glmls.volume.options import VolumeOptions

SHAPE = (16, 18, 20)  # D, H, W
#: A preimage counts where it lies this far inside the volume's box at least (a preimage on
#: a face is in or out by float32's rounding), ...
INSIDE = 0.01
#: ... with a float64 residual below this (voxels).
EXACT = 1e-7


def _folding_handles():
    """Handles that fold the volume over itself (pulled several voxels each way): without
    the fold pass, two voxels of this map with a preimage inside the volume (det J > 0.3
    there) are left to the background."""
    rng = np.random.default_rng(1008)
    count = int(rng.integers(6, 12))
    src = rng.uniform(0, 1, (count, 3)) * (np.array(SHAPE[::-1]) - 1)
    dst = src + rng.normal(0, 4.0 / np.sqrt(3), src.shape) * rng.uniform(0.8, 1.6)
    return src, dst


def _preimages(field, targets):
    """(found, s): for each of ``targets`` (K, 3) voxel centres, a float64 preimage inside
    the volume's box by INSIDE at least, where one exists. The candidates are the cubes of
    the lattice of voxel corners and centres (step 1/2) whose corners' images' box, grown
    by a voxel, holds the target: float64 Newton from each such cube's centre, one start
    per source voxel."""
    step = 0.5
    axes = [np.arange(-0.5, n - 0.5 + 1e-9, step) for n in SHAPE[::-1]]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    nx, ny, nz, _ = grid.shape
    images = field.evaluate(grid.reshape(-1, 3)).reshape(grid.shape)
    corners = [
        images[i : nx - 1 + i, j : ny - 1 + j, k : nz - 1 + k]
        for i in (0, 1)
        for j in (0, 1)
        for k in (0, 1)
    ]
    low = np.min(corners, axis=0).reshape(-1, 3) - 1.0
    high = np.max(corners, axis=0).reshape(-1, 3) + 1.0
    centres = (0.5 * (grid[:-1, :-1, :-1] + grid[1:, 1:, 1:])).reshape(-1, 3)
    owners, starts = [], []
    for k, u in enumerate(targets):
        hit = np.flatnonzero(np.all((low <= u) & (u <= high), axis=1))
        _, first = np.unique(np.floor(centres[hit]), axis=0, return_index=True)
        owners.append(np.full(len(first), k))
        starts.append(centres[hit[first]])
    found = np.zeros(len(targets), bool)
    points = np.zeros((len(targets), 3))
    if not owners:
        return found, points
    owner = np.concatenate(owners)
    s, residual = newton_inverse(
        field, targets[owner], np.concatenate(starts), tolerance=1e-10, steps=40, max_step=1.0
    )
    top = np.array(SHAPE[::-1], np.float64) - 0.5
    good = (residual < EXACT) & np.all((s >= -0.5 + INSIDE) & (s <= top - INSIDE), axis=1)
    found[owner[good]] = True
    points[owner[good]] = s[good]
    return found, points


def test_preimages_next_to_a_fold_are_found(gl):
    """Every voxel left to the background has no preimage inside the volume (the float64
    search finds none), and every voxel found maps to itself within 0.05 voxel (float64 f
    at the GPU's point)."""
    src, dst = _folding_handles()
    field = ReferenceField(src, dst, MLSConfig(transform="rigid"), shape=SHAPE)
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        points, _, covered = volume_coordinate_map(m, SHAPE)
        volume = np.ones(SHAPE, np.uint8)
        shown = m.warp(volume, method="backward", background=0)
    np.testing.assert_array_equal(shown == 1, covered)
    u = np.indices(SHAPE)[::-1].reshape(3, -1).T.astype(np.float64)
    covered = covered.reshape(-1)
    left = np.flatnonzero(~covered)
    found, _ = _preimages(field, u[left])
    assert not found.any(), f"voxels with a preimage left uncovered: {u[left[found]].tolist()}"
    at = points.reshape(-1, 3)[covered].astype(np.float64)
    assert np.linalg.norm(field.evaluate(at) - u[covered], axis=1).max() < 0.05 + 1e-3


def test_the_fold_pass_takes_these_voxels(gl, monkeypatch):
    """The voxels the fold pass found: some (the map folds), only where Newton's passes left
    none, each from a neighbour's point; without the pass they keep the background."""
    src, dst = _folding_handles()
    rescued = []
    original = KernelField.rescue

    def counted(self, neighbours, coords, listed, **keywords):
        original(self, neighbours, coords, listed, **keywords)
        rescued.append(int(np.frombuffer(listed.read(size=16), np.uint32)[3]))

    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        _, _, covered = volume_coordinate_map(m, SHAPE)
        monkeypatch.setattr(KernelField, "rescue", counted)
        volume_coordinate_map(m, SHAPE)
        monkeypatch.setattr(KernelField, "rescue", lambda *args, **keywords: None)
        _, _, without = volume_coordinate_map(m, SHAPE)
    assert sum(rescued) > 0
    assert np.all(covered >= without)
    assert np.count_nonzero(covered & ~without) >= 2


def _smooth_handles():
    """A smooth map that moves the volume's faces in and out by about a voxel."""
    rng = np.random.default_rng(3)
    src = rng.uniform(0, 1, (10, 3)) * (np.array(SHAPE[::-1]) - 1)
    return src, src + rng.normal(0, 0.6, src.shape)


def _shrinking_handles():
    """A similarity that shrinks the volume eightfold about its centre: f's inverse spreads
    neighbouring voxels' points 8 voxels apart everywhere."""
    src = np.random.default_rng(4).uniform(0, 1, (10, 3)) * (np.array(SHAPE[::-1]) - 1)
    centre = (np.array(SHAPE[::-1]) - 1) / 2
    return src, centre + (src - centre) / 8


def _listed_converged(listed, neighbours, *, size, first, window):
    """How many of the voxels that the fold pass's first stage listed have a point that
    their own Newton converged to (a preimage outside the volume)."""
    count = int(np.frombuffer(listed.read(size=16), np.uint32)[3])
    if count == 0:
        return 0
    items = np.frombuffer(listed.read(size=4 * count, offset=16), np.uint32).astype(np.int64)
    width, height, _ = size
    v = np.stack([items % width, items // width % height, items // (width * height)], 1)
    (corner, (ww, wh, wd)) = window
    w = v + np.asarray(first) - np.asarray(corner)
    points = np.frombuffer(neighbours.read(size=ww * wh * wd * 16), np.float32).reshape(-1, 4)
    own = points[(w[:, 2] * wh + w[:, 1]) * ww + w[:, 0], 3]
    return int(np.count_nonzero(-1.0 - own <= NEWTON_ACCEPT))


@pytest.mark.parametrize("handles", [_smooth_handles, _shrinking_handles])
def test_without_a_fold_the_pass_lists_no_converged_voxel(gl, monkeypatch, handles):
    """Where f does not fold, the fold pass's first stage lists no voxel whose own Newton
    converged: on a canvas past every side, the background voxels about the volume's image
    converged to points outside it, each on the line of its neighbours' points, however far
    apart f's inverse puts them (eightfold). The voxels whose Newton did not converge (past
    its reach, with the constant border) are listed; with the edge border none is left."""
    src, dst = handles()
    listed = {"constant": [], "edge": []}
    original = KernelField.rescue
    border = None

    def counted(self, neighbours, coords, items, **keywords):
        cut = {name: keywords[name] for name in ("size", "first", "window")}
        total = int(np.frombuffer(items.read(size=16), np.uint32)[3])
        listed[border].append((total, _listed_converged(items, neighbours, **cut)))
        original(self, neighbours, coords, items, **keywords)

    monkeypatch.setattr(KernelField, "rescue", counted)
    canvas = {"output_shape": (20, 22, 24), "origin": (-2.0, -2.0, -2.0)}
    with glmls.MLS(src, dst, transform="similarity", shape=SHAPE) as m:
        for border in ("constant", "edge"):
            _, _, covered = volume_coordinate_map(m, SHAPE, border=border, **canvas)
            assert covered.any()
    assert [converged for _, converged in listed["constant"]] == [0]
    assert listed["edge"] == [(0, 0)]


@pytest.mark.parametrize("border", ["constant", "edge"])
def test_slabbed_fold_passes_equal_the_whole(gl, border):
    """Slabs of one slice (each voxel's neighbours across a slab's side are the next slab's
    or the last one's) and boxes of 7 columns and rows give the one-piece points exactly."""
    src, dst = _folding_handles()
    cuts = (
        SlabOptions(slab_bytes=3000, band_bytes=40000),
        SlabOptions(texture_side=7),
        SlabOptions(texture_side=9, slab_bytes=4096),
    )
    volume = np.random.default_rng(0).normal(0, 1, SHAPE).astype(np.float32)
    options = {"method": "backward", "interpolation": "linear", "border": border}
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        whole = volume_coordinate_map(m, SHAPE, border=border)
        warped = m.warp(volume, **options)
        for cut in cuts:
            points = VolumeWarper.of(gl).coordinate_map(
                KernelField(m.kernel, shape=SHAPE),
                SHAPE,
                VolumeOptions(method="backward", border=border),
                cut,
            )
            for a, b in zip(points, whole, strict=True):
                np.testing.assert_array_equal(a, b, err_msg=str(cut))
            np.testing.assert_array_equal(m.warp(volume, **options, slabs=cut), warped)


def test_the_float64_field_finds_them_too(gl):
    """The construction with the float64 field (its Newton and fold pass on the CPU) covers
    the voxels that the GPU's fold pass found."""
    src, dst = _folding_handles()
    field = ReferenceField(src, dst, MLSConfig(transform="rigid"), shape=SHAPE)
    volume = np.ones(SHAPE, np.uint8)
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        _, _, covered = volume_coordinate_map(m, SHAPE)
    out = VolumeWarper.of(gl).warp(field, volume, VolumeOptions(method="backward"))
    u = np.indices(SHAPE)[::-1].reshape(3, -1).T.astype(np.float64)
    cpu = (out == 1).reshape(-1)
    differ = np.flatnonzero(cpu != covered.reshape(-1))
    found, _ = _preimages(field, u[differ])
    assert np.all(cpu[differ] == found)  # where they differ, the float64 search decides


def test_neighbours_in_the_shaders_order(gl):
    """The float64 field's fold pass takes the neighbours in the GPU's order."""
    from importlib import resources

    source = resources.files("glmls").joinpath("shaders/volume/neighbours.glsl").read_text()
    table = source[source.index("ivec3[](") : source.index(");", source.index("ivec3[]("))]
    numbers = [
        int(n)
        for n in table.replace("ivec3[](", "")
        .replace("ivec3(", " ")
        .replace(")", " ")
        .replace(",", " ")
        .split()
    ]
    np.testing.assert_array_equal(np.reshape(numbers, (-1, 3)), fold_neighbours())


def test_a_converged_voxel_takes_a_near_neighbours_point(gl):
    """A voxel next to a fold whose own Newton converged to a preimage outside the volume
    (affine, 18 handles pulled by about 5 voxels on a 20 x 30 x 28 volume): the point of a
    neighbour less than 5 voxels from its own leads to its preimage inside, and the fold
    pass takes it from there (it keeps the background where only points farther away are
    tried)."""
    rng = np.random.default_rng(5)
    shape = tuple(int(n) for n in rng.integers(20, 33, 3))
    count = int(rng.integers(8, 21))
    src = rng.uniform(0, 1, (count, 3)) * (np.array(shape[::-1]) - 1)
    dst = src + rng.normal(0, rng.uniform(2, 6), src.shape)
    field = ReferenceField(src, dst, MLSConfig(transform="affine"), shape=shape)
    with glmls.MLS(src, dst, transform="affine", shape=shape) as m:
        points, _, covered = volume_coordinate_map(m, shape)
    x, y, z = 13, 17, 2
    assert covered[z, y, x]
    s = points[z, y, x].astype(np.float64)
    assert np.linalg.norm(field.evaluate(s)[0] - (x, y, z)) < 0.05
    assert np.all(s >= -0.5) and np.all(s <= np.array(shape[::-1]) - 0.5)
