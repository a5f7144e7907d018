"""How a batch's chunk is scanned and coloured on the GPU path (:mod:`.gpu`): the test of
which meshes are embeddings, the scan of every image's cells (keys, or for bilinear
embeddings the colours themselves), and the sources as texture arrays for the scan and the
fill draw."""

from __future__ import annotations

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import ScanPieces, run_1d, set_uniforms
from ..gl.resources import Resources
from ..imaging.source import SourceImage, as_rgba8, texture_form

__all__ = [
    "SourceArrays",
    "array_form",
    "check_embeddings",
    "embedding_flags",
    "image_format",
    "runs",
    "scan",
]

#: The scans' lists before the test: no image listed, indirect dispatches of none.
_NO_LISTS = np.array([0, 1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 0], np.uint32).tobytes()


def check_embeddings(gl: GLContext, resources: Resources, values, lattice, count: int):
    """Which of the chunk's ``count`` meshes on ``lattice`` (in the mesh table) are
    embeddings: ``batch/check.comp.glsl``'s counts in the ``check`` buffer, and the images
    listed for the scan of the embeddings and for that of the others (``batch/lists.glsl``)
    in the ``lists`` buffer, returned (the scans' indirect dispatches); both bound."""
    check = resources.buffer("check", 16 * count)
    check.write(bytes(16 * count))
    lists = resources.buffer("lists", len(_NO_LISTS) + 8 * count)
    lists.write(_NO_LISTS)
    check.bind_to_storage_buffer(bindings.BATCH_CHECK.index)
    lists.bind_to_storage_buffer(bindings.BATCH_LISTS.index)
    columns, rows = lattice.dims
    per_image = (columns - 1) * (rows - 1) + 2 * (columns - 1) + 2 * (rows - 1)
    gl.mgl.memory_barrier()
    for stage, items in ((1, per_image * count), (2, count)):
        tests = gl.compute("batch/check.comp.glsl", {"BATCH_CHECK_STAGE": stage})
        set_uniforms(tests, values)
        run_1d(tests, items, max_groups=gl.limits["max_work_groups_x"])
        gl.mgl.memory_barrier()
    return lists


def embedding_flags(gl: GLContext, resources: Resources, count: int) -> np.ndarray:
    """(N,) bool: the meshes of the last :func:`check_embeddings` that it did not show to be
    embeddings (read back)."""
    gl.mgl.memory_barrier()
    raw = resources.cached("check").read(size=16 * count)
    counts = np.frombuffer(raw, np.uint32).reshape(count, 4)
    star = (counts[:, 1] == 0) & (counts[:, 2] == 1)
    return (counts[:, 0] != 0) | ~(star | (counts[:, 3] == 1))


def runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """The runs (first, end) of consecutive True in ``flags``."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()
    return list(zip(starts, ends, strict=True))


def image_format(texture: moderngl.Texture) -> str:
    """The GLSL image format of an RGBA8 or RGBA32F atlas."""
    return "rgba8" if texture.dtype == "f1" else "rgba32f"


def scan(
    gl: GLContext,
    resources: Resources,
    values,
    lattice: MeshLattice,
    count: int,
    keys_form: tuple[bool, bool, int],
    targets,
    *,
    fused: bool,
) -> np.ndarray | None:
    """The keys of the chunk's triangles in the winner buffer (``batch/cells.comp.glsl``;
    ``keys_form``: (keys carry the nearest source pixel, bilinear, the WARP_BORDER code of
    the border rule)). Bilinear and ``fused``, ``targets`` the atlas and the labels' atlas
    (or None): the meshes shown to be embeddings are coloured by the scan itself, without
    keys, the others keep theirs; returns which images have keys then ((N,) bool), else
    None (every image has)."""
    nearest_keys, linear, border = keys_form
    pieces = ScanPieces(gl)  # large cells on llvmpipe (common/pieces.glsl)
    if not (linear and fused):
        program = gl.compute("batch/cells.comp.glsl", {"WARP_CELLS_SOURCE": nearest_keys})
        set_uniforms(program, values)
        cells = (lattice.dims[0] - 1) * (lattice.dims[1] - 1)
        pieces.run_1d(program, cells * count, max_groups=gl.limits["max_work_groups_x"])
        return None
    lists = check_embeddings(gl, resources, values, lattice, count)
    atlas, label_atlas = targets
    defines = {"WARP_CELLS_SOURCE": nearest_keys, "BATCH_CELLS_LINEAR": True}
    defines["WARP_BORDER"] = border
    defines["BATCH_ATLAS_FORMAT"] = image_format(atlas)
    atlas.bind_to_image(bindings.TEXEL_TARGET.index, read=False, write=True)
    if label_atlas is not None:
        defines["BATCH_CELLS_LABELS"] = True
        defines["BATCH_LABEL_FORMAT"] = image_format(label_atlas)
        label_atlas.bind_to_image(bindings.BATCH_LABEL_IMAGE.index, read=False, write=True)
    for part in (1, 2):  # the embeddings, then the others, each as listed on the GPU
        program = gl.compute("batch/cells.comp.glsl", defines | {"BATCH_CELLS_PASS": part})
        set_uniforms(program, values)
        pieces.start(program)
        program.run_indirect(lists, offset=16 * (part - 1))
        pieces.finish(program)
    return embedding_flags(gl, resources, count)


class SourceArrays:
    """A chunk's sources as texture arrays on ``gl``, kept per role (the images, the label
    images) and form for the next chunk; :meth:`release` frees them. An array holds at least
    the chunk's layers: a chunk of fewer images of the same form (the parts of a group by
    their meshes' margins, a group's last chunk) writes into the first layers of the one
    kept, instead of making another (llvmpipe took ~3.5 ms to make one of 50 MB)."""

    def __init__(self, gl: GLContext) -> None:
        self._gl = gl
        self._arrays: dict[tuple, moderngl.TextureArray] = {}

    def release(self) -> None:
        for array in self._arrays.values():
            array.release()
        self._arrays.clear()

    def upload(self, sources: list[SourceImage], role: str = "images") -> moderngl.TextureArray:
        """A texture array holding ``sources`` in its first layers, one of the two forms of
        ``role`` last used (a chunk's images and its labels, drawn together, each have their
        own)."""
        (width, height), components, dtype = array_form(sources[0])
        key = (role, width, height, components, dtype)
        array = self._arrays.get(key)
        if array is None or array.layers < len(sources):
            kept = [k for k in self._arrays if k[0] == role and k != key]
            if len(kept) >= 2:
                self._arrays.pop(kept[0]).release()
            if array is not None:
                self._arrays.pop(key).release()
            array = self._gl.mgl.texture_array(
                (width, height, len(sources)), components, dtype=dtype
            )
            array.repeat_x = array.repeat_y = False
            self._arrays[key] = array
        array.write(_texture_stack(sources), viewport=(0, 0, 0, width, height, len(sources)))
        return array

    def bind(self, sources, labels, linear: bool) -> None:
        """The chunk's images (and label images) uploaded and bound for the scan and the
        fill draw."""
        array = self.upload(sources)
        mode = moderngl.LINEAR if linear else moderngl.NEAREST
        array.filter = (mode, mode)
        array.use(bindings.SOURCE.index)
        if labels is not None:
            self.upload(labels, "labels").use(bindings.LABEL_SOURCES.index)


def array_form(source: SourceImage) -> tuple[tuple[int, int], int, str]:
    """(size, components, dtype) of a layer of the texture array that holds ``source``: its
    :func:`~glmls.imaging.source.texture_form`, except that an 8-bit image of one or two
    channels (a label image, a grey one) keeps them (R8, RG8: a quarter or a half of the
    bytes to upload, none to convert). The batch's shaders read the arrays by ``texelFetch``
    alone, which gives the missing channels 0 and alpha 1, as the RGBA8 texel of
    :func:`~glmls.imaging.source.as_rgba8` holds them: the same values."""
    size, components, dtype = texture_form(source)
    if source.normalized and source.channels in (1, 2):
        return size, source.channels, dtype
    return size, components, dtype


def _texture_stack(sources: list[SourceImage]) -> np.ndarray:
    """The sources' layers (:func:`array_form`) one after the other: RGB converted to RGBA
    image by image straight into the stack (one pass over the pixels, not a stack and then
    a conversion), the others stacked as they are."""
    first = sources[0]
    if not (first.normalized and first.channels == 3):
        return np.stack([s.data for s in sources])
    height, width = first.shape
    stack = np.empty((len(sources), height, width, 4), np.uint8)
    for layer, source in zip(stack, sources, strict=True):
        as_rgba8(source.data, layer)
    return stack
