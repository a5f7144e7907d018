"""The fused quads of a batch's chunk on the caller's bytes: 8-bit images in, 8-bit images out,
nothing converted or copied per image on the host.

For nearest ``quads`` of uint8 images (:func:`takes`), a chunk is

1. one upload of the chunk's (N, H, W, C) bytes as they are (a slice of the caller's array,
   no RGBA made on the host) and, where a label rides along, its (N, H, W) labels, into
   uint32 tables (:mod:`glmls.gl.tables`) that ``batch/bytes.glsl`` reads as the single
   warp's RGBA8 texels;
2. f at every image's mesh vertices (:meth:`BatchLattices.evaluate`), then
   ``batch/check.comp.glsl``: which meshes are embeddings, on the GPU, each image listed for
   one of the two scans (``batch/lists.glsl``, indirect dispatches sized there);
3. the fused scans ``batch/cells.comp.glsl``, writing the texels into an atlas (an RGBA8
   texture filled with the background): the embeddings without keys, both triangles of
   every cell known positive (the single warp's fast pass), the others with keys, then
   ``batch/fixup.comp.glsl`` where two triangles reached a pixel;
4. ``batch/pack.comp.glsl``: the atlas packed into the caller's layout (C bytes a pixel, the
   labels apart), and one read-back straight into the caller's output arrays.

Each image equals its :func:`glmls.warp`, bit for bit (the texels, keys and sampling are the
single warp's)."""

from __future__ import annotations

import numpy as np

from ..core.mesh import MeshLattice
from ..gl import bindings
from ..gl.dispatch import ScanPieces, fill_buffer, run_1d, set_uniforms
from ..gl.tables import TABLE_WIDTH, table_rows
from ..imaging.frame import Frame
from ..imaging.options import PipelineOptions, WarpOptions
from ..imaging.quads import key_layout
from .drawer import mesh_stride
from .fill import check_embeddings
from .gpu import BatchQuads, mesh_capacity

__all__ = ["FAST_PASS", "chunk_size", "takes", "warp_texels"]

#: The fix-up list's header before a scan: no pixel listed, an indirect dispatch of none.
_NO_FIXUPS = np.array([0, 0, 0, 1], np.uint32).tobytes()
#: Scan the images whose mesh is an embedding by a program of their own (both triangles of
#: every cell positive, no keys: the single warp's fast pass), the others by the keyed one;
#: else one program takes every image, keys or not decided per image. Tests take both ways.
FAST_PASS = True


def takes(options: WarpOptions, dtype: np.dtype, fused: bool) -> bool:
    """Does a chunk of images of ``dtype`` take this path (nearest ``quads`` of uint8 images
    with the ``constant`` border, ``fused`` scans)?"""
    return (
        fused
        and options.method == "quads"
        and options.border == "constant"
        and options.interpolation == "nearest"
        and (np.dtype(dtype) == np.uint8)
    )


def chunk_size(
    gl, shape: tuple[int, ...], frame: Frame, lattice: MeshLattice, labelled: bool, max_bytes: int
) -> int:
    """Images per chunk of this path for images of ``shape`` ((H, W) or (H, W, C)): every
    buffer within the GL storage block size, the tables of bytes and the atlas within a
    texture, and the chunk's GPU memory (bytes, atlas, winners, packed output, meshes)
    within ``max_bytes``."""
    height, width = shape[:2]
    channels = (shape[2] if len(shape) == 3 else 1) + labelled
    per_image = height * width * channels + frame.pixels * (8 + channels)
    per_image += mesh_stride(lattice) + 32
    block = int(gl.mgl.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
    largest = max(4 * frame.pixels, height * width * channels, mesh_stride(lattice)) + 64
    # a table's words (the bytes), or the atlas's texels, in one texture (a row to spare)
    texels = TABLE_WIDTH * (gl.limits["max_texture_size"] - 1)
    most = max(frame.pixels, -(-height * width * channels // 4)) + 1
    capacity = mesh_capacity(gl, lattice)
    return max(1, min(block // largest, max_bytes // per_image, texels // most, capacity))


def _words(data: np.ndarray) -> np.ndarray:
    """The bytes of the C-contiguous array ``data`` as (n, 1) little-endian uint32 words (a
    view; a copy padded with zeros where the bytes are not whole words)."""
    flat = data.reshape(-1).view(np.uint8)
    if flat.size % 4:
        flat = np.concatenate([flat, np.zeros(4 - flat.size % 4, np.uint8)])
    return flat.view("<u4").reshape(-1, 1)


def warp_texels(
    quads: BatchQuads,
    lattices,
    images: np.ndarray,
    labels: np.ndarray | None,
    grid: float,
    frame: Frame,
    background: tuple[float, float, float, float],
    out: np.ndarray,
    out_labels: np.ndarray | None,
) -> bool:
    """Warp the chunk ``images`` ((N, H, W) or (N, H, W, C) uint8, C-contiguous) into ``out``
    ((N, H', W'[, C]) uint8, C-contiguous, the frame's canvas), with ``labels`` ((N, H, W)
    uint8 or None) riding as one more channel into ``out_labels``; ``background``: the clear
    colour of the texels (labels 0). False where the keys of this mesh do not fit in 31 bits
    (nothing written; the single path's rasterizer then draws it)."""
    count, height, width = images.shape[:3]
    channels = images.shape[3] if images.ndim == 4 else 1
    lattice = MeshLattice.corners((height, width), grid)
    layout = key_layout(lattice, source_pixel=True)
    if layout is None:
        return False
    sub_bits, col_shift, row_shift = layout
    gl, resources = quads.ctx, quads.resources
    mgl = gl.mgl
    stride = mesh_stride(lattice)
    quads.meshes(lattices, lattice)  # 1. every image's f
    labelled = labels is not None
    defines = {"BATCH_CHANNELS": channels, "BATCH_LABELS": labelled}
    tables = resources.tables
    tables.write("batch source", _words(images), None)
    tables.bind_image("batch source", bindings.BATCH_SOURCE.index)
    if labelled:
        tables.write("batch labels", _words(labels), None)
        tables.bind_image("batch labels", bindings.BATCH_LABEL_IMAGE.index)
    out_w, out_h = frame.size
    pixels = out_w * out_h * count
    values = {
        **lattice.pixel_uniforms(),
        "u_target_size": frame.size,
        "u_origin": frame.origin,
        "u_source_size": (width, height),
        "u_mesh_dims": lattice.dims,
        "u_mesh_stride": stride // 8,
        "u_images": count,
        "u_sub_bits": sub_bits,
        "u_col_shift": col_shift,
        "u_row_shift": row_shift,
    }
    max_groups = gl.limits["max_work_groups_x"]
    lists = check_embeddings(gl, resources, values, lattice, count)  # 2.
    winner = resources.buffer("winner", 4 * pixels)
    fill_buffer(gl, winner, 4 * pixels)
    atlas = _atlas(resources, pixels, background, gl.limits["max_texture_size"])
    values["u_atlas_width"] = out_w
    values["u_fixup_capacity"] = PipelineOptions().fixup_capacity(pixels)
    fixups = resources.buffer("fixups", 16 + 4 * values["u_fixup_capacity"])
    fixups.write(_NO_FIXUPS)
    winner.bind_to_storage_buffer(bindings.WINNER.index)
    fixups.bind_to_storage_buffer(bindings.FIXUPS.index)
    bindings.bind_texels(atlas, bindings.TEXEL_TARGET, write=True)
    columns, rows = lattice.dims
    cells = (columns - 1) * (rows - 1)
    mgl.memory_barrier()
    pieces = ScanPieces(gl)  # large cells on llvmpipe (common/pieces.glsl)
    for part in (1, 2) if FAST_PASS else (0,):  # 3. the embeddings, then the others
        fused = {"WARP_CELLS_SOURCE": True, "WARP_CELLS_FUSED": True, "BATCH_CELLS_PASS": part}
        scan = gl.compute("batch/cells.comp.glsl", fused | {"WARP_SOURCE_BYTES": True} | defines)
        set_uniforms(scan, values)
        if part:  # the images listed for it, sized on the GPU
            pieces.start(scan)
            scan.run_indirect(lists, offset=16 * (part - 1))
            pieces.finish(scan)
        else:
            pieces.run_1d(scan, cells * count, max_groups=max_groups)
    mgl.memory_barrier()
    fixup = gl.compute("batch/fixup.comp.glsl", {"WARP_SOURCE_BYTES": True} | defines)
    set_uniforms(fixup, values)
    fixup.run_indirect(fixups, offset=4)
    mgl.memory_barrier()
    _pack(quads, atlas, pixels, channels, out, out_labels)  # 4.
    return True


def _atlas(resources, pixels: int, background, limit: int):
    """The RGBA8 texture of a chunk's ``pixels`` output texels (a table's layout: texel i
    at (i % TABLE_WIDTH, i // TABLE_WIDTH)), its first rows (those the pixels and the pack's
    last group of four reach) filled with the ``background`` colour. Its rows are a power of
    two (``limit`` at most), so that chunks of a little fewer pixels keep the texture."""
    rows = table_rows(pixels)
    texture = resources.texture(
        "batch atlas", (TABLE_WIDTH, min(limit, 1 << (rows - 1).bit_length())), 4, "f1"
    )
    resources.fill(texture, background, rows=rows)
    return texture


def _pack(quads, atlas, pixels: int, channels: int, out, out_labels):
    """The atlas packed by ``batch/pack.comp.glsl`` and read back into ``out`` (and the
    labels into ``out_labels``)."""
    gl, resources = quads.ctx, quads.resources
    labelled = out_labels is not None
    quads_of_four = -(-pixels // 4)  # an invocation packs four pixels into C words (and one)
    colour_bytes = 4 * channels * quads_of_four
    label_bytes = 4 * quads_of_four if labelled else 0
    packed = resources.buffer("packed", colour_bytes + label_bytes)
    program = gl.compute(
        "batch/pack.comp.glsl", {"BATCH_CHANNELS": channels, "BATCH_LABELS": labelled}
    )
    set_uniforms(program, {"u_quads": quads_of_four, "u_labels_at": colour_bytes // 4})
    bindings.bind_texels(atlas, bindings.TEXEL_SOURCE, write=False)
    packed.bind_to_storage_buffer(bindings.BATCH_OUTPUT.index)
    run_1d(program, quads_of_four, max_groups=gl.limits["max_work_groups_x"])
    gl.mgl.memory_barrier()
    packed.read_into(out, size=pixels * channels)
    if labelled:
        packed.read_into(out_labels, size=pixels, offset=colour_bytes)
