"""``backward-swap`` of a chunk of images in one submission: the swapped-handles map s (the
MLS map with p and q exchanged) at every output pixel of every image in ONE dispatch of
``warp/inverse.comp.glsl`` (``WARP_SWAP`` with ``MLS_BATCH``) into the atlas of maps, ONE
draw of ``batch/backward.frag.glsl`` sampling the sources there (a second for the masks),
ONE read-back. As the single path, no mesh and no Newton: each image equals its
:func:`glmls.warp`, bit for bit. Keypoints move by s's inverse, as the single path moves
them (:meth:`~glmls.batch.single.SingleWarper.move`), for every image of the chunk in a few
dispatches (:mod:`glmls.batch.preimages`; the images it leaves, image by image)."""

from __future__ import annotations

import numpy as np

from ..core.config import MLSConfig
from ..engine.batched import BatchLattices
from ..gl import bindings
from ..gl.dispatch import LOCAL_SIZE_2D, set_uniforms
from ..imaging.frame import Frame
from ..imaging.inverse import NEWTON_STEPS
from ..imaging.options import WarpOptions
from ..imaging.source import BORDERS, SourceImage
from ..mls import MLS
from .gpu import BatchQuads
from .inputs import BatchInput
from .labels import visible_chunk
from .preimages import lone_images, swapped_preimages
from .single import SingleWarper, in_domain

__all__ = ["swapped_keypoints", "swapped_lattices", "warp_swapped"]


def swapped_lattices(
    config: MLSConfig, src: list[np.ndarray], dst: list[np.ndarray], shape: tuple[int, int]
) -> BatchLattices | None:
    """The images' swapped handles (q as the sources, p as the targets) for one batched
    evaluation, or None where its checks refuse one image's q (float32 merging two of them,
    an affine fit they do not span), which the single path's swapped kernel does not check:
    that image's chunk then takes the single path, as its own warp runs it. The scaling of
    each image is its :class:`~glmls.MLS`'s (the box of p, q and the image, the same either
    way round), the one :meth:`glmls.MLS.swapped_kernel` evaluates in."""
    try:
        return BatchLattices(config, dst, src, shape)
    except ValueError:
        return None


def warp_swapped(
    quads: BatchQuads,
    lattices: BatchLattices,
    sources: list[SourceImage],
    options: WarpOptions,
    frame: Frame,
    background: tuple[float, float, float, float],
    lattice,
    labels: tuple[list[SourceImage], tuple[float, float, float, float]] | None = None,
    into: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
):
    """The chunk's images warped by ``backward-swap`` (``lattices``: their
    :func:`swapped_lattices`; ``lattice``: the images' mesh, whose points the pass does not
    read; ``labels``: the chunk's label images and their background, sampled nearest at the
    same maps; ``into``: as :meth:`BatchQuads.warp`'s), as :meth:`BatchQuads.backward`
    returns. The maps stay in the ``coords`` atlas
    (:meth:`BatchQuads.backward_coords`)."""
    gl = quads.ctx
    mgl = gl.mgl
    height, width = sources[0].shape
    out_w, out_h = frame.size
    atlas = (out_w, out_h * len(sources))
    border = BORDERS.index(options.border)
    with gl.use():
        # every texel of the atlas's rows is stored by the pass: no fill first
        framebuffer = quads.resources.framebuffer("coords", atlas, "f4", tall=True)
        coords = framebuffer.color_attachments[0]
        defines = {"WARP_SWAP": True, "WARP_NEWTON_STEPS": NEWTON_STEPS, "WARP_BORDER": border}
        uniforms = {**frame.uniforms(), "u_source_size": (width, height)}
        groups = [-(-n // LOCAL_SIZE_2D) for n in frame.size]
        parts = lattices.parts(gl, quads.resources, lattice, "warp/inverse.comp.glsl", defines)
        for (program,), rows in parts:
            set_uniforms(program, uniforms)
            mgl.memory_barrier()
            coords.bind_to_image(bindings.INVERSE_MAP.index, read=True, write=True)
            program.run(group_x=groups[0], group_y=groups[1], group_z=rows)
        mgl.memory_barrier()
        maps = (coords, atlas, frame)
        return quads.sample_maps(sources, maps, options, background, labels, into)


def swapped_keypoints(
    warper: SingleWarper,
    batch: BatchInput,
    chunk: list[int],
    mls_options: dict,
    canvas: tuple[Frame, WarpOptions],
    shown: tuple[np.ndarray, np.ndarray],
    passes: tuple | None = None,
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The ``backward-swap`` chunk's keypoints moved by s's inverse, as the single path moves
    them, each valid where the chunk's maps ``shown`` ((N, H, W, 2) source points, (N, H, W)
    covered) show it (:func:`~glmls.batch.labels.visible_chunk`, the chunk at once): two
    lists of the images' (P_i, 2) points and (P_i,) flags. ``canvas``: the frame and the
    options. ``passes``: the context, its resources and the chunk's
    :func:`swapped_lattices`, which move every image's keypoints in a few dispatches
    (:func:`~glmls.batch.preimages.swapped_preimages`); the images that it leaves (a fold of
    s, a compact weight, far targets; or every image, without ``passes``) move image by
    image, each by its own :class:`~glmls.MLS` of ``mls_options``."""
    frame, options = canvas
    shape = batch.images[chunk[0]].shape[:2]
    origin = np.asarray(frame.origin)
    points = [batch.keypoints[i] for i in chunk]  # type: ignore[index]
    found = _batched(batch, chunk, mls_options, shape, points, passes)
    moved, jacobians, insides = [], [], []
    for k, i in enumerate(chunk):
        if found[k] is None:
            with MLS(batch.src[i], batch.dst[i], shape=shape, **mls_options) as mls:
                out, jacobian, inside = warper.move(mls, shape, options, frame, points[k])
        else:
            out, jacobian = found[k]  # type: ignore[misc]
            inside = in_domain(points[k], shape, options.border)
        moved.append(out - origin)
        jacobians.append(jacobian)
        insides.append(inside)
    sizes = [len(p) for p in points]
    images = np.repeat(np.arange(len(chunk)), sizes)
    every = (np.concatenate(points).reshape(-1, 2), images, np.concatenate(moved).reshape(-1, 2))
    jacobian = np.concatenate(jacobians).reshape(-1, 2, 2)
    valid = visible_chunk(*every, jacobian, *shown, np.concatenate(insides))
    return moved, np.split(valid, np.cumsum(sizes)[:-1])


def _batched(batch, chunk, mls_options, shape, points, passes) -> list:
    """:func:`~glmls.batch.preimages.swapped_preimages` of the chunk, None for each image it
    leaves to the single path (all, without ``passes`` or where the images' own handles
    fail :class:`BatchLattices`'s checks)."""
    alone: list = [None] * len(chunk)
    if passes is None or not any(len(p) for p in points):
        return alone
    gl, resources, lattices = passes
    src, dst = [batch.src[i] for i in chunk], [batch.dst[i] for i in chunk]
    config = lattices.config
    lone = lone_images(config, src, dst, shape)
    if lone.all():
        return alone
    try:
        forward = BatchLattices(config, src, dst, shape)
    except ValueError:  # a p the checks refuse: its chunk's keypoints move as one warp's
        return alone
    taken = np.flatnonzero(~lone).tolist()

    def chosen(images: list[int], swapped: bool) -> BatchLattices:
        ps, qs = [src[taken[k]] for k in images], [dst[taken[k]] for k in images]
        return (
            BatchLattices(config, qs, ps, shape)
            if swapped
            else BatchLattices(config, ps, qs, shape)
        )

    if len(taken) < len(chunk):
        lattices, forward = (
            chosen(list(range(len(taken))), True),
            chosen(list(range(len(taken))), False),
        )
    found = swapped_preimages(gl, resources, lattices, forward, [points[k] for k in taken], chosen)
    for k, result in zip(taken, found, strict=True):
        alone[k] = result
    return alone
