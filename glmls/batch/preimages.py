"""Where ``backward-swap`` shows a chunk's keypoints, for all its images in a few dispatches.

Output pixel u of ``backward-swap`` shows s(u), s the MLS map with p and q swapped, so a
source keypoint x lands at s's inverse at x, with the inverse of s's Jacobian there (as
:meth:`~glmls.batch.single.SingleWarper.move`). Here each step is one pass of the chunk's
handles (:class:`~glmls.engine.batched.BatchLattices`): f at the keypoints, Newton on s from
f(x) (``warp/inverse_points.comp.glsl`` with ``MLS_BATCH``; s nearly inverts f, so f(x) is a
close first guess), the damped second dispatch over the points it leaves, and s at the
preimages' probes.

The single path starts Newton from the rasterized inverse of s's mesh, which, where s folds,
picks the preimage of the first mesh cell in scan order, and may find a preimage where Newton
from f(x) finds none. So an image moves its keypoints image by image (the caller's single
path) where s turns a cell over on the fold lattice (:data:`FOLD_GRID`, :data:`FOLD_CELLS`,
:data:`FOLD_MARGIN`), turns over or flattens at a preimage found, or leaves a keypoint
without one; so do images of a compact (``radius``) weight (s the identity beyond the
handles' reach leaves points uncovered, which the mesh's guess tells) and images whose
swapped handles the GPU would hold with their targets moved back by a translation
(:meth:`~glmls.core.handleset.HandleSet.near_targets`: :func:`lone_images`). Elsewhere a
keypoint lands where the single path puts it within float32's rounding and Newton's stopping
(1e-4 px of residual).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..core.config import MLSConfig
from ..core.handles import COORDINATE_LIMIT, fit_offset
from ..core.mesh import MeshLattice
from ..engine.batched import BatchLattices
from ..engine.passes3 import STEP_BOX
from ..gl import bindings
from ..gl.dispatch import LOCAL_SIZE, set_uniforms
from ..imaging.inverse import (
    IDENTITY_FOUND,
    NEWTON_MAX_STEP,
    POINTS_NEWTON_STEPS,
    POINTS_TOLERANCE,
    accept_residual,
)
from .probes import f_at
from .single import probe_points, probed

__all__ = ["FOLD_CELLS", "FOLD_GRID", "FOLD_MARGIN", "lone_images", "swapped_preimages"]

#: The longest step (pixels) of the lattice on which s is tested for folds: at most
#: :data:`FOLD_CELLS` cells along the image's longer side, a pixel at the finest.
FOLD_GRID = 8
FOLD_CELLS = 32
#: How far (pixels) past the image that lattice reaches.
FOLD_MARGIN = 8

_PROGRAM = "warp/inverse_points.comp.glsl"


class _Scalings(NamedTuple):
    """Per point, its image's scaling centre (P, 2) and scale (P,): what
    :func:`~glmls.imaging.inverse.accept_residual` reads of a Scaling."""

    center: np.ndarray
    scale: np.ndarray


def lone_images(config: MLSConfig, src: list[np.ndarray], dst: list[np.ndarray], shape):
    """(N,) bool: the images whose keypoints move image by image: all with a compact weight,
    else those whose swapped handles (``dst`` as the sources) the GPU holds moved back by a
    translation."""
    if config.weight_entry.support == "radius":
        return np.ones(len(src), bool)
    # HandleSet.near_targets of the swapped point handles (checked), without its checks
    return np.array([fit_offset(q, p, shape).any() for p, q in zip(src, dst, strict=True)])


def _units(lattices: BatchLattices) -> np.ndarray:
    """(N,) each image's :func:`~glmls.imaging.inverse.length_unit`, from the values its own
    kernel holds."""
    scales = lattices.scales
    half = np.maximum(lattices.extents() * scales, np.where(scales > 1, scales / 2, 0.0))
    safe = np.where(half > 0, half, 1.0)
    return np.where(half > 0, np.minimum(1.0, safe / STEP_BOX), 1.0)


def _folds(gl, resources, lattices: BatchLattices) -> np.ndarray:
    """(N,) bool: the images whose s turns a cell of the fold lattice over (or flattens it)."""
    grid = min(FOLD_GRID, -(-max(lattices.shape) // FOLD_CELLS))
    lattice = MeshLattice.corners(lattices.shape, grid, margin=FOLD_MARGIN)
    nx, ny = lattice.dims
    stride = nx * ny * 8
    with gl.use():
        target = resources.buffer("swap folds", stride * len(lattices))
        lattices.evaluate(gl, resources, lattice, target, stride)
        gl.mgl.memory_barrier()
        raw = target.read(size=stride * len(lattices))
    v = np.frombuffer(raw, np.float32).reshape(len(lattices), ny, nx, 2).astype(np.float64)
    a, b, c, d = v[:, :-1, :-1], v[:, :-1, 1:], v[:, 1:, 1:], v[:, 1:, :-1]

    def area(p, q, r):
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
            r[..., 0] - p[..., 0]
        )

    flat = (area(a, b, c) <= 0) | (area(a, c, d) <= 0)
    return flat.reshape(len(lattices), -1).any(axis=1)


def _newton(gl, resources, lattices, points, guesses, units, *, rescue: bool):
    """(N, stride, 4) float32: s's inverse at each image's ``points`` ((P_k, 2) pixels) from
    ``guesses`` (the first dispatch: (P_k, 2) pixels; the second: the first's (P_k, 4)
    results, improved in place), ``units`` (N,) the images' length units."""
    count = len(lattices)
    sizes = [len(p) for p in points]
    stride = max(sizes)
    centers = lattices.centers[:, None, :]
    scales = lattices.scales[:, None, None]
    padded = np.zeros((count, stride, 2))
    first = np.zeros((count, stride, 4), np.float32)
    for k, p in enumerate(points):  # the padding repeats the last point
        padded[k, : len(p)], padded[k, len(p) :] = p, p[-1]
        if rescue:
            first[k, : len(p)], first[k, len(p) :] = guesses[k], guesses[k][-1]
        else:
            first[k, : len(p), :2], first[k, len(p) :, :2] = guesses[k], guesses[k][-1]
    items = np.zeros((count, stride, 8), np.float32)
    items[..., :2] = (padded - centers) / scales
    if not rescue:
        items[..., 2:4] = (first[..., :2].astype(np.float64) - centers) / scales
    items[..., 4] = units[:, None]
    defines = {"WARP_NEWTON_STEPS": POINTS_NEWTON_STEPS, "WARP_RESCUE": rescue}
    limit = gl.limits["max_work_groups_x"] * LOCAL_SIZE
    with gl.use():
        source = resources.buffer("swap preimages in", items.nbytes)
        source.write(items)
        out = resources.buffer("swap preimages out", first.nbytes)
        if rescue:
            out.write(first)
        lattice = MeshLattice.corners(lattices.shape)  # the table's lattice rows go unread
        for program, rows in lattices.dispatches(gl, resources, lattice, _PROGRAM, defines):
            uniforms = {"u_count": stride, "u_batch_stride": stride}
            uniforms |= {"u_tolerance": POINTS_TOLERANCE, "u_max_step": NEWTON_MAX_STEP}
            set_uniforms(program, uniforms)
            source.bind_to_storage_buffer(bindings.BATCH_POINTS.index)
            out.bind_to_storage_buffer(bindings.DEFORMED.index)
            for offset in range(0, stride, limit):
                set_uniforms(program, {"u_offset": offset})
                size = min(stride - offset, limit)
                program.run(group_x=-(-size // LOCAL_SIZE), group_y=rows)
        gl.mgl.memory_barrier()
        found = np.frombuffer(out.read(size=first.nbytes), np.float32)
    return found.reshape(first.shape).copy()


def _accepted(lattices, k: np.ndarray, points, found, units) -> np.ndarray:
    """(P,) bool: ``found`` (P, 4: s scaled, residual) within the residual accepted at
    ``points`` (P, 2) of images ``k`` (P,)."""
    center, scale = lattices.centers[k], lattices.scales[k]
    s = found[:, :2].astype(np.float64) * scale[:, None] + center
    with np.errstate(invalid="ignore"):
        accept = accept_residual(_Scalings(center, scale), points, s, unit=units[k])
        return found[:, 2] <= accept


def swapped_preimages(
    gl,
    resources,
    lattices: BatchLattices,
    forward: BatchLattices,
    points: list[np.ndarray],
    chosen: Callable[[list[int], bool], BatchLattices],
) -> list[tuple[np.ndarray, np.ndarray] | None]:
    """Per image of ``lattices`` (the chunk's swapped handles; ``forward``: the same images'
    own), where its ``points`` ((P_k, 2) source pixels, P_k >= 0) land and the local
    Jacobians ((P_k, 2), (P_k, 2, 2)), or None for an image whose keypoints move image by
    image: s folds on the fold lattice or at a preimage found, flattens there, or has no
    preimage found at one of its points (the single path's guess may find one).
    ``chosen(images, swapped)``: the lattices of those images alone."""
    count = len(lattices)
    folded = _folds(gl, resources, lattices)
    units = _units(lattices)
    sizes = np.array([len(p) for p in points])
    busy = [k for k in range(count) if sizes[k] and not folded[k]]
    results: list[tuple[np.ndarray, np.ndarray] | None] = [
        None if folded[k] or sizes[k] else (np.zeros((0, 2)), np.zeros((0, 2, 2)))
        for k in range(count)
    ]
    if not busy:
        return results

    def part(images: list[int], swapped: bool) -> BatchLattices:
        if len(images) == count:
            return lattices if swapped else forward
        return chosen(images, swapped)

    own = [points[k] for k in busy]
    guesses = f_at(  # f at the points: Newton's first guesses
        gl, resources, part(busy, False), own, lambda some: part([busy[j] for j in some], False)
    )
    index = np.array(busy)
    found = _newton(gl, resources, part(busy, True), own, guesses, units[index], rescue=False)
    flat = np.concatenate([found[j, : len(p)] for j, p in enumerate(own)])
    which = np.repeat(np.arange(len(busy)), [len(p) for p in own])
    image = index[which]
    everything = np.concatenate(own)
    left = ~_accepted(lattices, image, everything, flat, units)
    if left.any():  # the damped second dispatch, over the images with points left
        again = sorted(set(which[left].tolist()))
        rows = [np.flatnonzero(left & (which == j)) for j in again]
        redone = _newton(
            gl,
            resources,
            part([busy[j] for j in again], True),
            [everything[r] for r in rows],
            [flat[r] for r in rows],
            units[index[again]],
            rescue=True,
        )
        for j, r in enumerate(rows):
            flat[r] = redone[j, : len(r)]
    center, scale = lattices.centers[image], lattices.scales[image]
    s = flat[:, :2].astype(np.float64) * scale[:, None] + center
    identity = flat[:, 3] == IDENTITY_FOUND  # s leaves x in place: x exactly
    s[identity] = everything[identity]
    ok = _accepted(lattices, image, everything, flat, units)
    ok &= (np.abs(s) <= COORDINATE_LIMIT).all(axis=1)  # else past what f takes
    ends = np.cumsum([len(p) for p in own])
    starts = ends - [len(p) for p in own]
    whole = [j for j in range(len(busy)) if ok[starts[j] : ends[j]].all()]
    if not whole:
        return results
    taken = [busy[j] for j in whole]
    at = f_at(  # s's Jacobian at the preimages found
        gl,
        resources,
        part(taken, True),
        [probe_points(s[starts[j] : ends[j]]) for j in whole],
        lambda some: part([taken[i] for i in some], True),
    )
    for j, values in zip(whole, at, strict=True):
        jacobian = probed(values)[1]
        det = jacobian[:, 0, 0] * jacobian[:, 1, 1] - jacobian[:, 0, 1] * jacobian[:, 1, 0]
        if (det > 1e-12).all():  # else s turns over (another sheet may show) or flattens
            results[busy[j]] = (s[starts[j] : ends[j]], np.linalg.inv(jacobian))
    return results
