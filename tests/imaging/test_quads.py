"""The quads' construction paths, each taken through explicit PipelineOptions: the compute
scan conversion (fused colours with fix-ups, the fast pass without keys, the resolve draws),
the GL rasterizer, meshes in bands, and their agreement."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SENTINEL, coordinate_image, folded_case, smooth_handles
from numpy.testing import assert_array_equal

import glmls
from glmls.core.mesh import MeshLattice
from glmls.gl import bindings
from glmls.imaging.quads import key_layout
from glmls.imaging.source import prepare_image


def test_meshes_drawn_in_bands_match_one_band(gl, rng, pipeline):
    """Meshes larger than a buffer band are evaluated and drawn band by band, without cracks."""
    img = rng.integers(0, 255, (60, 57), dtype=np.uint8)
    p = np.array([[5, 5], [50, 8], [20, 55.0]])
    q = p + np.array([[3, 2], [-2, 4], [1, -3]])
    banded = pipeline(band_bytes=2048)  # ~4 rows per band
    assert MeshLattice.corners((60, 57)).rows_per_band(2048) < 10
    with glmls.MLS(p, q, ctx=gl) as m:
        for method in glmls.METHODS:
            whole = m.warp(img, method=method, background=1)
            assert_array_equal(banded.warp(m, img, method=method, background=1), whole)
    with glmls.MLS(p, p, ctx=gl) as m:
        assert_array_equal(banded.warp(m, img), img)


@pytest.mark.parametrize("grid", [1, 3, 4])
def test_fused_quads_match_the_resolve_draw_on_folds(gl, grid):
    """uint8 RGBA images take the fused path (colours written by the scan conversion, folds
    fixed up after); uint16 ones the resolve draw. Both show the same source pixels."""
    shape, p, q = folded_case()
    coords16 = coordinate_image(*shape)
    coords8 = coords16.astype(np.uint8)  # x, y < 256
    pipe = glmls.gl.WarpPipeline.of(gl)
    with glmls.MLS(p, q, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape, grid=grid).count > 0
        fused = m.warp(coords8, grid=grid, background=255)
        assert pipe.cells.last_path in ("fused", "fused fast")
        drawn = m.warp(coords16, grid=grid, background=SENTINEL)
        assert pipe.cells.last_path == "nearest"
    covered = drawn[..., 0] != SENTINEL
    assert_array_equal(fused[..., :2][covered], drawn[..., :2][covered])
    assert (fused[~covered] == 255).all()


@pytest.mark.parametrize("capacity", [1, 3])
def test_fused_quads_survive_an_overflowing_fixup_list(gl, pipeline, capacity):
    """More overlapping pixels than the fix-up list holds: every pixel is redone."""
    shape, p, q = folded_case()
    img = coordinate_image(*shape).astype(np.uint8)
    small = pipeline(fixup_min=capacity, fixup_fraction=10**9)
    with glmls.MLS(p, q, ctx=gl) as m:
        expected = m.warp(img, background=255)
        assert_array_equal(small.warp(m, img, background=255), expected)
        assert small.cells.last_path.startswith("fused")


def render_into_texture(gl, pipe, m, img, *, clear=(0, 0, 0, 0), **options):
    """``pipe.render`` of ``img`` into an RGBA8 framebuffer of its size, read back."""
    with gl:  # raw moderngl calls around the pipeline's
        return _render_into_texture(gl, pipe, m, img, clear, options)


def _render_into_texture(gl, pipe, m, img, clear, options):
    shape = img.shape[:2]
    source = pipe.upload(prepare_image(img, pipe.max_image_size, normalized=True), "test")
    target = gl.mgl.texture((shape[1], shape[0]), 4, dtype="f1")
    bound = gl.mgl.fbo or gl.mgl.detect_framebuffer(0)
    framebuffer = gl.mgl.framebuffer(color_attachments=[target])
    try:
        framebuffer.use()
        framebuffer.clear(*clear)
        pipe.render(m, source, framebuffer, **options)
        return np.frombuffer(target.read(), np.uint8).reshape(*shape, 4)
    finally:
        bound.use()  # never leave a released framebuffer bound
        framebuffer.release()
        target.release()


def test_fused_quads_keep_the_callers_background(gl, rng):
    """render() fills only covered pixels of an RGBA8 target: what was there stays."""
    shape, p, q = folded_case()
    img = rng.integers(0, 255, (*shape, 4), dtype=np.uint8)
    pipe = glmls.gl.WarpPipeline.of(gl)
    with glmls.MLS(p, q, ctx=gl) as m:
        expected = m.warp(img, background=(1, 2, 3, 4))
        out = render_into_texture(gl, pipe, m, img, clear=(1 / 255, 2 / 255, 3 / 255, 4 / 255))
    assert_array_equal(out, expected)


def test_rasterizer_quads_agree_with_the_compute_scan_conversion(gl, rng, pipeline):
    """The GL rasterizer path (other viewports, keys too long) covers the same pixels with
    the same source pixels, but for pixel centres within rounding of an edge."""
    shape = (64, 80)
    p, q = smooth_handles(shape, rng)
    img = coordinate_image(*shape)
    raster = pipeline(compute_quads=False)
    with glmls.MLS(p, q, ctx=gl) as m:
        scan = m.warp(img, grid=4, background=SENTINEL)
        drawn = raster.warp(m, img, grid=4, background=SENTINEL)
    assert raster.cells.last_path is None  # never scan-converted
    same = (scan == drawn).all(axis=-1)
    assert same.mean() > 0.99


def test_cell_keys_fit_in_31_bits_or_are_refused():
    def layout(shape, grid, source_pixel):
        return key_layout(MeshLattice.corners(shape, grid), source_pixel=source_pixel)

    assert layout((1024, 1024), 4, True) == (2, 5, 13)
    assert layout((1024, 1024), 1, True) == (0, 1, 11)
    assert layout((1024, 1024), 4, False) == (0, 1, 9)
    assert layout((16384, 16384), 1, True) == (0, 1, 15)  # 29 bits
    assert layout((32768, 32768), 1, True) == (0, 1, 16)  # 31 bits
    assert layout((40000, 40000), 1, True) is None
    assert layout((30000, 30000), 3, True) is None  # 14 + 14 + 1 + 4 bits
    assert layout((30000, 30000), 3, False) is not None


# -- the fast pass of the fused quads (no keys where the mesh is an embedding) ---------------


def warp_both_ways(gl, pipeline, m, img, **kwargs):
    """(fast path, keyed pass only) pictures of ``img``, and the fast scan's counts."""
    fast_pipe = pipeline()
    fast = fast_pipe.warp(m, img, **kwargs)
    assert fast_pipe.cells.last_path == "fused fast"
    counts = fast_pipe.cells.embedding_counts()
    keyed_pipe = pipeline(fast_embedded=False)
    keyed = keyed_pipe.warp(m, img, **kwargs)
    assert keyed_pipe.cells.last_path == "fused"
    return fast, keyed, counts


@pytest.mark.parametrize("grid", [1, 3, 4])
def test_fast_quads_equal_the_keyed_pass_where_the_mesh_embeds(gl, rng, pipeline, grid):
    """Fold-free deformations are recognised as embeddings and drawn without keys; every
    pixel shows the same source pixel as with the keyed pass."""
    shape = (72, 96)
    img = coordinate_image(*shape).astype(np.uint8)
    for transform in ("affine", "similarity", "rigid"):
        p, q = smooth_handles(shape, rng)
        with glmls.MLS(p, q, transform=transform, ctx=gl) as m:
            assert glmls.analysis.foldovers(m, shape, grid=grid).count == 0
            fast, keyed, counts = warp_both_ways(gl, pipeline, m, img, grid=grid, background=255)
        assert counts == (0, 1), "the mesh was not recognised as an embedding"
        assert_array_equal(fast, keyed)


@pytest.mark.parametrize("grid", [1, 4])
def test_fast_quads_fall_back_to_the_keyed_pass_on_folds(gl, pipeline, grid):
    shape, p, q = folded_case()
    img = coordinate_image(*shape).astype(np.uint8)
    with glmls.MLS(p, q, ctx=gl) as m:
        fast, keyed, counts = warp_both_ways(gl, pipeline, m, img, grid=grid, background=255)
    assert counts[0] > 0, "folded cells were not counted"
    assert_array_equal(fast, keyed)


def boundary_check(gl, mesh):
    """Run the boundary stages of warp/cells_check.comp.glsl on ``mesh`` (rows, cols, 2),
    pixel coordinates: (bad, crossings, clear groups, scan groups)."""
    with gl:
        return _boundary_check(gl, mesh)


def _boundary_check(gl, mesh):
    rows, cols = mesh.shape[:2]
    entry = "warp/cells_check.comp.glsl"
    stages = [gl.compute(entry, {"WARP_CHECK_STAGE": s}) for s in (0, 1)]
    vertices = gl.mgl.texture((cols, rows), 2, np.ascontiguousarray(mesh, np.float32), dtype="f4")
    check = gl.mgl.buffer(reserve=48)
    try:
        check.clear()
        vertices.use(bindings.MESH.index)
        check.bind_to_storage_buffer(bindings.CHECK.index)
        for program in stages:
            for name, value in (
                ("u_center", (0.0, 0.0)),
                ("u_scale", 1.0),
                ("u_mesh_dims", (cols, rows)),
                ("u_target_size", (64, 64)),
            ):
                if name in program:
                    program[name].value = value
        edges = 2 * (rows - 1) + 2 * (cols - 1)
        stages[0].run(group_x=(edges + 63) // 64)
        gl.mgl.memory_barrier()
        stages[1].run(group_x=1)
        gl.mgl.memory_barrier()
        out = np.frombuffer(check.read(), np.uint32)
    finally:
        vertices.release()
        check.release()
    return int(out[0]), int(out[1]), tuple(out[4:7]), tuple(out[8:11])


def ring_mesh(turns, rows=9, cols=9, radius=20.0, centre=(32.0, 32.0)):
    """A mesh whose boundary vertices go ``turns`` times around a circle, counter-clockwise
    in the triangles' sense (from +x towards +y, y down), with its centre vertex at the centre."""
    mesh = np.zeros((rows, cols, 2))
    ij = [(i, 0) for i in range(cols - 1)] + [(cols - 1, j) for j in range(rows - 1)]
    ij += [(i, rows - 1) for i in range(cols - 1, 0, -1)] + [(0, j) for j in range(rows - 1, 0, -1)]
    for t, (i, j) in enumerate(ij):
        angle = 2 * np.pi * turns * t / len(ij)
        mesh[j, i] = centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle)
    mesh[rows // 2, cols // 2] = centre
    return mesh


def test_embedding_check_counts_how_often_the_boundary_goes_around(gl):
    """Star-shaped from the centre vertex and once around: an embedding (nothing to redo);
    twice around (each edge still turning the right way) or the wrong way round: not."""
    cells = 8 * 8
    assert boundary_check(gl, ring_mesh(1)) == (0, 1, (0, 1, 1), (0, 1, 1))
    bad, crossings, clear, scan = boundary_check(gl, ring_mesh(2))
    assert (bad, crossings) == (0, 2)
    assert clear == ((64 * 64 // 4 + 63) // 64, 1, 1) and scan == ((cells + 63) // 64, 1, 1)
    bad, crossings, _, scan = boundary_check(gl, ring_mesh(-1))
    assert bad == 32 and scan[0] > 0


@pytest.mark.parametrize(
    "method, interpolation",
    [("quads", "nearest"), ("quads", "linear"), ("backward", "nearest")],
)
def test_render_flip_y_draws_rows_bottom_up(gl, rng, method, interpolation):
    """flip_y (a window's framebuffer, row 0 at the bottom) gives the same picture upside
    down, for each full-viewport fill (warp/target.glsl)."""
    shape = (40, 56)
    p, q = smooth_handles(shape, rng)
    img = rng.integers(0, 255, (*shape, 4), dtype=np.uint8)
    pipe = glmls.gl.WarpPipeline.of(gl)
    with glmls.MLS(p, q, ctx=gl) as m:
        pictures = [
            render_into_texture(
                gl, pipe, m, img, method=method, interpolation=interpolation, grid=2, flip_y=flip
            )
            for flip in (False, True)
        ]
    assert pictures[0].any()
    assert_array_equal(pictures[1], pictures[0][::-1])
