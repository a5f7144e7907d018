"""The one table of GL binding points: every buffer, uniform block, texture unit and image unit
a glmls shader uses, each with an index of its own.

The shader loader (:mod:`glmls.gl.shaders`) defines each entry's :attr:`Binding.define` in every
program, so GLSL writes ``layout(std430, binding = BIND_DEFORMED)`` and Python
``buffer.bind_to_storage_buffer(DEFORMED.index)``: no binding number is written anywhere else.
Indices are distinct within each kind (GL keeps one namespace per kind), so a buffer bound for
one pass can never be read by another through a shared number.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl

__all__ = [
    "ALL",
    "KINDS",
    "Binding",
    "bind_texels",
    "defines",
    "holds_texels",
    "needed",
    "shortfall",
]

#: Binding namespaces, with the GL limit that bounds each one's indices.
KINDS = {
    "storage": "GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS",
    "uniform": "GL_MAX_UNIFORM_BUFFER_BINDINGS",
    "texture": "GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS",
    "image": "GL_MAX_IMAGE_UNITS",
}


@dataclass(frozen=True)
class Binding:
    """One binding point: ``name`` (the GLSL define is ``BIND_<name>``), its ``kind`` (a key
    of :data:`KINDS`) and ``index``."""

    name: str
    kind: str
    index: int
    what: str

    @property
    def define(self) -> str:
        return f"BIND_{self.name}"


# -- storage buffers ---------------------------------------------------------------------------
HANDLES = Binding("HANDLES", "storage", 0, "handles (p.x, p.y, q.x, q.y), the ssbo storage")
POINTS = Binding("POINTS", "storage", 1, "points to evaluate f at")
DEFORMED = Binding("DEFORMED", "storage", 2, "f at the points or mesh vertices (scaled)")
MATRICES = Binding("MATRICES", "storage", 3, "M at the points")
BIN_STARTS = Binding("BIN_STARTS", "storage", 4, "where each spatial bin's handles start")
ERROR_VERTICES = Binding("ERROR_VERTICES", "storage", 5, "the error field at mesh vertices")
ERROR_FIELD = Binding("ERROR_FIELD", "storage", 6, "the error field written by a pass")
WINNER = Binding("WINNER", "storage", 7, "per target pixel, the key of the top triangle")
FIXUPS = Binding("FIXUPS", "storage", 10, "pixels that more than one triangle reached")
CHECK = Binding("CHECK", "storage", 12, "the embedding test's counts and dispatch sizes")
ADAPTIVE_POINTS = Binding("ADAPTIVE_POINTS", "storage", 14, "adaptive: each pixel's source point")
ADAPTIVE_HOT = Binding("ADAPTIVE_HOT", "storage", 15, "adaptive: the tiles near folds, triangles")
ADAPTIVE_TESTS = Binding("ADAPTIVE_TESTS", "storage", 18, "adaptive build: each cell's test")
ADAPTIVE_HANDLES = Binding("ADAPTIVE_HANDLES", "storage", 8, "adaptive build: the point handles")
ADAPTIVE_SPLIT = Binding("ADAPTIVE_SPLIT", "storage", 9, "adaptive build: the cells that split")
VOLUME_LATTICE = Binding("VOLUME_LATTICE", "storage", 11, "volumes: f at a band of the lattice")
VOLUME_KEYS = Binding("VOLUME_KEYS", "storage", 13, "volumes: each output voxel's first cell")
VOLUME_COORDS = Binding("VOLUME_COORDS", "storage", 16, "volumes: each voxel's source point")
VOLUME_SLOPES = Binding("VOLUME_SLOPES", "storage", 17, "volumes: d source / d output per voxel")
FILL = Binding("FILL", "storage", 19, "a buffer being filled with one word (fill_buffer)")
VOLUME_SURVEY = Binding("VOLUME_SURVEY", "storage", 20, "volumes: the box of f over each z layer")
VOLUME_NEIGHBOURS = Binding(
    "VOLUME_NEIGHBOURS", "storage", 31, "volumes: the source points found about a slab"
)
MESH_NORMALS = Binding("MESH_NORMALS", "storage", 22, "3D meshes: vertex normals or their sums")
MESH_FOLDS = Binding("MESH_FOLDS", "storage", 23, "3D meshes: each face's fold flag, a byte")
MESH_FLAT = Binding("MESH_FLAT", "storage", 24, "3D meshes: where J took the plain affine solve")
BATCH_OUTPUT = Binding("BATCH_OUTPUT", "storage", 25, "batches: the chunk's output bytes, labels")
BATCH_CHECK = Binding("BATCH_CHECK", "storage", 26, "batches: each image's embedding test")
BATCH_LISTS = Binding("BATCH_LISTS", "storage", 27, "batches: the images each scan takes")
RESCUE = Binding("RESCUE", "storage", 28, "backward: pixels Newton left, their dispatch")
RESCUE_RUNS = Binding("RESCUE_RUNS", "storage", 21, "backward: the second pass's later runs")
PIECES = Binding("PIECES", "storage", 29, "scans: the dispatch of large primitives' pieces")
BATCH_POINTS = Binding("BATCH_POINTS", "storage", 30, "batches: each image's points to evaluate")
# -- uniform blocks ----------------------------------------------------------------------------
HANDLES_BLOCK = Binding("HANDLES_BLOCK", "uniform", 0, "handles, the ubo storage")
# -- texture units -----------------------------------------------------------------------------
SOURCE = Binding("SOURCE", "texture", 0, "the source image being warped")
COORDS = Binding("COORDS", "texture", 1, "backward: the source point of each output pixel")
MESH = Binding("MESH", "texture", 2, "f at the mesh vertices of a band (RG32F)")
WINNER_TEXTURE = Binding("WINNER_TEXTURE", "texture", 3, "a copy of the winner buffer (R32UI)")
HANDLE_TEXTURE = Binding("HANDLE_TEXTURE", "texture", 4, "handles, the texture storage")
PICTURE = Binding("PICTURE", "texture", 5, "an image or picture drawn onto a viewport")
VALUES = Binding("VALUES", "texture", 6, "a scalar field to colour (value, defined)")
COLOR_TABLE = Binding("COLOR_TABLE", "texture", 7, "a colour map, n x 1 RGBA8")
GLYPHS = Binding("GLYPHS", "texture", 8, "the glyph atlas of on-screen text")
VOLUME_SOURCE = Binding("VOLUME_SOURCE", "texture", 14, "the source volume being warped")
BATCH_MESH = Binding("BATCH_MESH", "texture", 15, "batches: f at every image's mesh, a table")
BATCH_SCALING = Binding("BATCH_SCALING", "texture", 16, "batches: each image's scaling, a table")
LABEL_SOURCES = Binding("LABEL_SOURCES", "texture", 17, "batches: the label images being warped")
VOLUME_JACOBIANS = Binding(
    "VOLUME_JACOBIANS", "texture", 18, "volumes: f's inverse Jacobian and f at a band's points"
)
# 3D meshes' tables (glmls.gl.tables), read by the passes over faces at random
MESH_VERTICES = Binding("MESH_VERTICES", "texture", 19, "3D meshes: the vertices (scaled)")
MESH_FACES = Binding("MESH_FACES", "texture", 20, "3D meshes: the faces' vertex indices")
MESH_RECORDS = Binding("MESH_RECORDS", "texture", 21, "3D meshes: the vertices' records")
# the adaptive mesh's tables (glmls.gl.tables): read item by item, fetched as texels
ADAPTIVE_VERTICES = Binding("ADAPTIVE_VERTICES", "texture", 9, "adaptive: (output, source) points")
ADAPTIVE_TRIANGLES = Binding("ADAPTIVE_TRIANGLES", "texture", 10, "adaptive: vertex ids, leaf")
ADAPTIVE_LEAVES = Binding("ADAPTIVE_LEAVES", "texture", 11, "adaptive: the leaves' patches")
ADAPTIVE_F = Binding("ADAPTIVE_F", "texture", 12, "adaptive build: f - v at each vertex (scaled)")
ADAPTIVE_CELLS = Binding("ADAPTIVE_CELLS", "texture", 13, "adaptive build: the cells to test")
# -- image units -------------------------------------------------------------------------------
INVERSE_MAP = Binding("INVERSE_MAP", "image", 0, "backward: guess in, source points out")
ADAPTIVE_TARGET = Binding("ADAPTIVE_TARGET", "image", 1, "adaptive: the RGBA8 target it colours")
TEXEL_SOURCE = Binding("TEXEL_SOURCE", "image", 2, "the RGBA8 source as r32ui (bind_texels)")
TEXEL_TARGET = Binding("TEXEL_TARGET", "image", 3, "the RGBA8 target as r32ui (bind_texels)")
VOLUME_TARGET = Binding("VOLUME_TARGET", "image", 4, "volumes: the output slab")
BATCH_SOURCE = Binding("BATCH_SOURCE", "image", 5, "batches: the chunk's bytes, a uint32 table")
BATCH_LABEL_IMAGE = Binding(
    "BATCH_LABEL_IMAGE",
    "image",
    6,
    "batches: the labels' bytes (r32ui), or their atlas a scan writes",
)
# the last of the 8 image units NVIDIA's drivers give
VOLUME_JACOBIANS_OUT = Binding(
    "VOLUME_JACOBIANS_OUT", "image", 7, "volumes: the inverse Jacobians being written"
)

ALL = (
    HANDLES,
    POINTS,
    DEFORMED,
    MATRICES,
    BIN_STARTS,
    ERROR_VERTICES,
    ERROR_FIELD,
    WINNER,
    FIXUPS,
    CHECK,
    ADAPTIVE_POINTS,
    ADAPTIVE_HOT,
    ADAPTIVE_TESTS,
    ADAPTIVE_HANDLES,
    ADAPTIVE_SPLIT,
    VOLUME_LATTICE,
    VOLUME_KEYS,
    VOLUME_COORDS,
    VOLUME_SLOPES,
    FILL,
    VOLUME_SURVEY,
    VOLUME_NEIGHBOURS,
    MESH_NORMALS,
    MESH_FOLDS,
    MESH_FLAT,
    BATCH_OUTPUT,
    BATCH_CHECK,
    BATCH_LISTS,
    RESCUE,
    RESCUE_RUNS,
    PIECES,
    BATCH_POINTS,
    HANDLES_BLOCK,
    SOURCE,
    COORDS,
    MESH,
    WINNER_TEXTURE,
    HANDLE_TEXTURE,
    PICTURE,
    VALUES,
    COLOR_TABLE,
    GLYPHS,
    VOLUME_SOURCE,
    BATCH_MESH,
    BATCH_SCALING,
    LABEL_SOURCES,
    VOLUME_JACOBIANS,
    MESH_VERTICES,
    MESH_FACES,
    MESH_RECORDS,
    ADAPTIVE_VERTICES,
    ADAPTIVE_TRIANGLES,
    ADAPTIVE_LEAVES,
    ADAPTIVE_F,
    ADAPTIVE_CELLS,
    INVERSE_MAP,
    ADAPTIVE_TARGET,
    TEXEL_SOURCE,
    TEXEL_TARGET,
    VOLUME_TARGET,
    BATCH_SOURCE,
    BATCH_LABEL_IMAGE,
    VOLUME_JACOBIANS_OUT,
)


def defines() -> dict[str, int]:
    """``BIND_<name>`` -> index for every binding: defined in every glmls program."""
    return {binding.define: binding.index for binding in ALL}


def needed() -> dict[str, int]:
    """For each kind's GL limit, how many binding points the table needs (highest index + 1)."""
    out: dict[str, int] = {}
    for binding in ALL:
        limit = KINDS[binding.kind]
        out[limit] = max(out.get(limit, 0), binding.index + 1)
    return out


def shortfall(info: dict) -> str | None:
    """What a driver whose ``ctx.info`` is ``info`` lacks of the binding points the table
    needs (:func:`needed`), in words; None where it has them all."""
    for limit, count in needed().items():
        offered = info.get(limit)
        if offered is not None and int(offered) < count:
            return (
                f"glmls needs {count} binding points of {limit}, this driver offers {int(offered)}"
            )
    return None


#: GL_R32UI, the image format of :func:`bind_texels`.
_R32UI = 0x8236


def holds_texels(texture: object) -> bool:
    """Is ``texture`` a single-sample RGBA8 texture, whose texels :func:`bind_texels` can
    bind as one uint32 each."""
    return isinstance(texture, moderngl.Texture) and (
        texture.components,
        texture.dtype,
        texture.samples,
    ) == (4, "f1", 0)


def bind_texels(texture: moderngl.Texture, binding: Binding, *, write: bool) -> None:
    """Bind an RGBA8 ``texture`` (:func:`holds_texels`) to image unit ``binding`` as r32ui:
    GLSL's ``layout(r32ui) uimage2D`` then moves each texel whole, with no conversion of each
    channel (GL allows it: both formats are 32 bits a texel). Read-only unless ``write``,
    then write-only."""
    texture.bind_to_image(binding.index, read=not write, write=write, format=_R32UI)
