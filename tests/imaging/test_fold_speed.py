"""Folds at full speed: the fused fast path of the quads (nearest, 8-bit) redraws with keys
only the cells near folded ones (warp/cells_hot.glsl), and its pictures are exactly those of
the keyed pass over every cell (the first cell in scan order shows; that pass is checked
against float64 containment in test_fold_rule.py): with few folds, many folds, a boundary that
fails the embedding test, meshes in bands, and border modes."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import coordinate_image, folded_case
from numpy.testing import assert_array_equal

import glmls
from glmls.core.mesh import MeshLattice
from glmls.gl import bindings


def random_folds(shape, seed, handles=24, move=0.12, pin_corners=True):
    """Handles spread over the image moved at random by up to ``move`` of its size (folds
    where neighbours cross), with the four corners held (a boundary that stays simple)."""
    height, width = shape
    rng = np.random.default_rng(seed)
    p = rng.uniform(0.1, 0.9, (handles, 2)) * [width, height]
    q = p + rng.uniform(-move, move, p.shape) * min(shape)
    if pin_corners:
        corners = np.array([[0, 0], [width - 1, 0], [0, height - 1], [width - 1, height - 1.0]])
        p, q = np.vstack([p, corners]), np.vstack([q, corners])
    return p, q


def coordinates_uint8(shape):
    """An RGB uint8 image whose pixels are told apart by their x, y (< 256 each)."""
    return coordinate_image(*shape).astype(np.uint8)


def fast_and_keyed(pipeline, m, img, **kwargs):
    """(fast path, keyed pass over every cell) pictures, and the fast pipeline's scan."""
    fast_pipe = pipeline()
    fast = fast_pipe.warp(m, img, **kwargs)
    assert fast_pipe.cells.last_path == "fused fast"
    keyed_pipe = pipeline(fast_embedded=False)
    keyed = keyed_pipe.warp(m, img, **kwargs)
    assert keyed_pipe.cells.last_path == "fused"
    return fast, keyed, fast_pipe.cells


def cells_of(shape, grid):
    columns, rows = MeshLattice.corners(shape, grid).cells
    return columns * rows


@pytest.mark.parametrize("grid", [1, 2, 4])
def test_few_folds_redraw_few_cells_and_give_the_keyed_picture(gl, pipeline, grid):
    shape, p, q = folded_case()
    img = coordinates_uint8(shape)
    with glmls.MLS(p, q, ctx=gl) as m:
        fast, keyed, scan = fast_and_keyed(pipeline, m, img, grid=grid, background=255)
    folded, crossings = scan.embedding_counts()
    assert folded > 0 and crossings == 1  # folds inside a simple boundary
    assert 0 < scan.redrawn_cells() < cells_of(shape, grid)
    assert_array_equal(fast, keyed)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("grid", [1, 3, 4])
def test_many_folds_give_the_keyed_picture(gl, pipeline, seed, grid):
    """Strong random moves: many folded and self-folded cells, folds meeting folds."""
    shape = (96, 128)
    p, q = random_folds(shape, seed, move=0.25)
    img = coordinates_uint8(shape)
    with glmls.MLS(p, q, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape, grid=grid).count > 0
        fast, keyed, scan = fast_and_keyed(pipeline, m, img, grid=grid, background=255)
    assert scan.embedding_counts()[0] > 0
    assert_array_equal(fast, keyed)


def test_more_folded_cells_than_listed_redraw_every_cell(gl, pipeline):
    shape = (96, 128)
    p, q = random_folds(shape, 4, move=0.25)
    img = coordinates_uint8(shape)
    short = pipeline()
    short.cells.folded_min = 16
    with glmls.MLS(p, q, ctx=gl) as m:
        fast, keyed, scan = fast_and_keyed(pipeline, m, img, grid=1, background=255)
        listed = scan.redrawn_cells()
        overflowing = short.warp(m, img, grid=1, background=255)
        assert short.cells.last_path == "fused fast"
        assert short.cells.embedding_counts()[0] > 16
        assert short.cells.redrawn_cells() == cells_of(shape, 1) > listed
    assert_array_equal(fast, keyed)
    assert_array_equal(overflowing, keyed)


def test_an_overflowing_fix_up_list_gives_the_keyed_picture(gl, pipeline):
    """More overlapping pixels than the fix-up list holds: every pixel with a key is fixed
    up, and only the redrawn cells left keys (the winner buffer was cleared)."""
    shape = (96, 128)
    p, q = random_folds(shape, 2, move=0.25)
    img = coordinates_uint8(shape)
    small = pipeline(fixup_min=8, fixup_fraction=10**9)
    with glmls.MLS(p, q, ctx=gl) as m:
        fast, keyed, _ = fast_and_keyed(pipeline, m, img, grid=1, background=255)
        overflowing = small.warp(m, img, grid=1, background=255)
        assert small.cells.last_path == "fused fast"
        assert 0 < small.cells.redrawn_cells() < cells_of(shape, 1)
    assert_array_equal(fast, keyed)
    assert_array_equal(overflowing, keyed)


def test_a_large_image_with_random_handles_redraws_a_small_part(gl, pipeline):
    """The benchmark's folding case at 256²: a few hundred folded cells, and the keyed pass
    redraws a small fraction of the mesh."""
    size = 256
    rng = np.random.default_rng(4)
    p = rng.uniform(0.05 * size, 0.95 * size, (64, 2))
    q = p + rng.uniform(-9, 9, (64, 2))
    img = rng.integers(0, 256, (size, size, 3), dtype=np.uint8)
    for grid in (1, 4):
        with glmls.MLS(p, q, transform="rigid", ctx=gl) as m:
            assert glmls.analysis.foldovers(m, (size, size), grid=grid).count > 0
            fast, keyed, scan = fast_and_keyed(pipeline, m, img, grid=grid)
        assert scan.embedding_counts()[1] == 1
        assert 0 < scan.redrawn_cells() < 0.2 * cells_of((size, size), grid)
        assert_array_equal(fast, keyed)


def test_a_mirrored_map_redraws_every_cell(gl, pipeline):
    """Every cell negative and the boundary going the wrong way round: the keyed pass over
    every cell, as before."""
    shape = (48, 64)
    p = np.array([[8, 8], [56, 8], [8, 40], [56, 40], [30, 22.0]])
    q = p * [-1, 1] + [63, 0]  # mirrored left to right
    img = coordinates_uint8(shape)
    with glmls.MLS(p, q, transform="affine", ctx=gl) as m:
        fast, keyed, scan = fast_and_keyed(pipeline, m, img, grid=2, background=255)
    assert scan.embedding_counts()[0] > 0
    assert scan.redrawn_cells() == cells_of(shape, 2)
    assert_array_equal(fast, keyed)


def test_fold_free_maps_redraw_nothing(gl, pipeline):
    shape = (64, 80)
    p, q = random_folds(shape, 0, move=0.01)
    img = coordinates_uint8(shape)
    with glmls.MLS(p, q, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape, grid=2).count == 0
        fast, keyed, scan = fast_and_keyed(pipeline, m, img, grid=2, background=255)
    assert scan.embedding_counts() == (0, 1)
    assert scan.redrawn_cells() == 0
    assert_array_equal(fast, keyed)


@pytest.mark.parametrize("grid", [1, 3])
def test_folds_across_bands_give_the_one_band_picture(gl, pipeline, grid):
    """A mesh in bands takes the keyed pass band by band (the fast path needs the whole mesh
    at once): the same picture as the fast path's in one band, folds crossing bands."""
    shape = (96, 128)
    p, q = random_folds(shape, 3, move=0.25)
    img = coordinates_uint8(shape)
    banded = pipeline(band_bytes=2048)  # a few rows per band
    with glmls.MLS(p, q, ctx=gl) as m:
        fast, keyed, _ = fast_and_keyed(pipeline, m, img, grid=grid, background=255)
        in_bands = banded.warp(m, img, grid=grid, background=255)
    assert banded.cells.last_path == "fused"
    assert_array_equal(fast, keyed)
    assert_array_equal(in_bands, fast)


@pytest.mark.parametrize("border", ["edge", "reflect"])
def test_folds_with_a_border_mode_give_the_keyed_picture(gl, pipeline, border):
    """The lattice then reaches past the image: its blocks and tiles too."""
    shape = (72, 96)
    p, q = random_folds(shape, 5, move=0.2, pin_corners=False)
    img = coordinates_uint8(shape)
    with glmls.MLS(p, q, ctx=gl) as m:
        fast, keyed, _ = fast_and_keyed(pipeline, m, img, grid=2, border=border)
    assert_array_equal(fast, keyed)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_every_path_agrees_on_a_folded_map(gl, pipeline, interpolation):
    """Whatever path a dtype takes (fused fast for uint8 nearest; the nearest or
    interpolated fill otherwise), the fast path's picture is the keyed pass's: uint8 and
    float32 images of the same coordinates show the same pixels."""
    shape = (80, 96)
    p, q = random_folds(shape, 1, move=0.25)
    img = coordinates_uint8(shape)
    pipe = pipeline()
    keyed = pipeline(fast_embedded=False)
    with glmls.MLS(p, q, ctx=gl) as m:
        as_uint8 = pipe.warp(m, img, grid=2, interpolation=interpolation, background=255)
        as_float = pipe.warp(
            m, img.astype(np.float32), grid=2, interpolation=interpolation, background=255
        )
        as_keyed = keyed.warp(m, img, grid=2, interpolation=interpolation, background=255)
    assert_array_equal(as_uint8, as_keyed)
    if interpolation == "nearest":
        assert_array_equal(as_uint8.astype(np.float32), as_float)


def test_the_keyed_redraw_compiles_for_every_border(gl):
    """The programs of the fold path (the keyed redraw of listed blocks, every stage of the
    test) with every border rule: each define given, as NVIDIA requires."""
    with gl:
        for border in range(5):  # glmls.imaging.source.BORDERS
            cells = {"WARP_CELLS_SOURCE": 1, "WARP_CELLS_FUSED": 1, "WARP_BORDER": border}
            gl.compute("warp/cells.comp.glsl", cells | {"WARP_CELLS_FAST": 0, "WARP_CELLS_HOT": 1})
        for stage in (0, 1, 2, 3, 6):
            gl.compute("warp/cells_check.comp.glsl", {"WARP_CHECK_STAGE": stage})


def list_blocks(gl, mesh, hot_tiles, folded_blocks, target=(64, 64), shift=2):
    """Run the block list of warp/cells_check.comp.glsl (stage 3) on ``mesh`` (rows, cols, 2)
    pixel coordinates, the tiles ``hot_tiles`` ((x, y) in tiles of 2^shift px) marked hot and
    the blocks ``folded_blocks`` marked as holding a folded cell: the listed blocks."""
    rows, cols = mesh.shape[:2]
    blocks_x, blocks_y = -(-(cols - 1) // 8), -(-(rows - 1) // 8)
    words = ((target[0] - 1 >> shift) + 32) // 32
    hot = 12
    folded = hot + words * ((target[1] - 1 >> shift) + 1)
    listed = folded + (blocks_x * blocks_y + 31) // 32
    data = np.zeros(listed + blocks_x * blocks_y, np.uint32)
    for x, y in hot_tiles:
        data[hot + y * words + x // 32] |= np.uint32(1 << (x % 32))
    for b in folded_blocks:
        data[folded + b // 32] |= np.uint32(1 << (b % 32))
    head = np.array([0, 1, len(folded_blocks) or 1, 0] + [0] * 8, np.uint32)  # a simple boundary
    with gl:
        program = gl.compute("warp/cells_check.comp.glsl", {"WARP_CHECK_STAGE": 3})
        vertices = gl.mgl.texture(
            (cols, rows), 2, np.ascontiguousarray(mesh, np.float32), dtype="f4"
        )
        check = gl.mgl.buffer(np.concatenate([head, data]).tobytes())
        try:
            vertices.use(bindings.MESH.index)
            check.bind_to_storage_buffer(bindings.CHECK.index)
            uniforms = {
                "u_center": (0.0, 0.0),
                "u_scale": 1.0,
                "u_origin": (0.0, 0.0),
                "u_mesh_dims": (cols, rows),
                "u_target_size": target,
                "u_offset": 0,
                "u_hot_shift": shift,
                "u_hot_words": words,
                "u_folded_blocks": folded,
                "u_folded_capacity": 1 << 20,
                "u_block_list": listed,
            }
            for name, value in uniforms.items():
                if name in program:
                    program[name].value = value
            program.run(group_x=1)
            gl.mgl.memory_barrier()
            out = np.frombuffer(check.read(), np.uint32)[12:]
        finally:
            vertices.release()
            check.release()
    return sorted(out[listed : listed + out[4]].tolist())


def test_a_block_with_a_folded_cell_is_boxed_by_all_its_vertices(gl):
    """A block of cells with a folded one may reach past its boundary's image (a vertex
    dragged out across its neighbours): all its vertices bound it. A block of positive cells
    lies inside its boundary's image, whose vertices bound it."""
    yy, xx = np.mgrid[0:17, 0:17]
    mesh = np.stack([10.0 + 2 * xx, 10.0 + 2 * yy], -1)  # 2 x 2 blocks of 8 x 8 cells
    mesh[4, 4] = (52.5, 52.5)  # an inner vertex of block 0 far out: its cells fold
    hot = [(13, 13)]  # the tile of pixels 52..55
    assert list_blocks(gl, mesh, hot, folded_blocks=[0]) == [0]
    assert list_blocks(gl, mesh, hot, folded_blocks=[]) == []  # the boundary's box only
    assert list_blocks(gl, mesh, [(3, 3)], folded_blocks=[]) == [0]  # pixels 12..15
    assert list_blocks(gl, mesh, [(6, 6)], folded_blocks=[]) == [0, 1, 2, 3]  # 24..27
