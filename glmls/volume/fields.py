"""What the volume construction deforms by: f at the points of a lattice band, written into a
GL buffer, and f at a list of points, in source voxels.

A :class:`Field` is the construction's view of a 3D MLS for one ``spacing``: positions in
source voxels ((x, y, z) = (i, j, k) for voxel (k, j, i)) are ``v * (dx, dy, dz)`` in the
handles' units. :class:`ReferenceField` evaluates the float64 reference
(:func:`glmls.reference.mls`) on the CPU: the tests' independent f.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

import moderngl
import numpy as np

from .. import reference
from ..core.config import MLSConfig
from .frame import CornerLattice

__all__ = [
    "FOLD_NEAR",
    "FOLD_REACH",
    "NEWTON_ACCEPT",
    "NEWTON_TOLERANCE",
    "Field",
    "ReferenceField",
    "fold_neighbours",
    "newton_inverse",
    "slab_corner",
]

#: A voxel whose Newton residual |f(s) - u| stays above this (voxels) is left uncovered.
NEWTON_ACCEPT = 0.05
#: Newton on f stops below this residual |f(s) - u| (voxels); a preimage this far outside
#: the volume's box [-1/2, n - 1/2] is still in it (``constant`` border), so that one on a
#: face is in whatever side rounding leaves it.
NEWTON_TOLERANCE = 1e-3
#: The backward method's fold pass (:mod:`~glmls.volume.folds`) starts Newton from the points
#: of a voxel's neighbours within this many voxels along each axis ...
FOLD_REACH = 2
#: ... where its own Newton converged outside the volume, only the first this many (the
#: 3 x 3 x 3).
FOLD_NEAR = 26


def fold_neighbours() -> np.ndarray:
    """(124, 3) int64: the offsets (x, y, z) of a voxel's neighbours within
    :data:`FOLD_REACH` along each axis, in the order the fold pass takes them
    (``volume/neighbours.glsl``): nearest first, then by |z|, |y|, |x|, each positive
    before negative."""
    span = range(-FOLD_REACH, FOLD_REACH + 1)
    offsets = [(x, y, z) for z in span for y in span for x in span if (x, y, z) != (0, 0, 0)]
    offsets.sort(
        key=lambda o: (o[0] ** 2 + o[1] ** 2 + o[2] ** 2, *np.abs(o[::-1]), -o[2], -o[1], -o[0])
    )
    return np.array(offsets, dtype=np.int64)


class Field(Protocol):
    """f for the volume construction, in source voxels."""

    #: (dx, dy, dz): handle units per source voxel.
    scale: np.ndarray
    #: The handles' sources p in source voxels, (N, 3): where f's displacement peaks.
    sources: np.ndarray

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """f at ``points`` ((K, 3) float64 source voxels), (K, 3) float64 source voxels."""
        ...

    def fill(
        self, lattice: CornerLattice, first: int, layers: int, target: moderngl.Buffer
    ) -> None:
        """f at z layers ``first`` .. ``first + layers - 1`` of ``lattice``'s points into
        ``target`` from its start: 3 float32 a point, source voxels, layer, row, point
        order."""
        ...

    def refine(
        self,
        coords: moderngl.Buffer,
        size: tuple[int, int, int],
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        *,
        constant: bool,
        first: int | tuple[int, int, int] = 0,
        pending: moderngl.Buffer | None = None,
    ) -> None:
        """Newton's method from the first guesses in ``coords`` (x, y, z, w per voxel of a
        slab of ``size`` (W, H, slices) whose voxel (i, j, k) shows ``origin`` + (i, j,
        ``first`` + k), source voxels, or + (i, j, k) + ``first`` where ``first`` is the
        slab's first voxel (x, y, z); w < 0: no guess), written back as (s, w): w the
        residual |f(s) - u| (voxels) where found (inside a volume of ``shape`` with
        ``constant``), else -1 - residual. ``pending``: scratch room for the voxels left to
        a second pass (:func:`~glmls.volume.kernel_field.pending_bytes`), where the field
        uses one."""
        ...

    def rescue(
        self,
        neighbours: moderngl.Buffer,
        coords: moderngl.Buffer,
        listed: moderngl.Buffer,
        *,
        size: tuple[int, int, int],
        first: tuple[int, int, int],
        window: tuple[tuple[int, int, int], tuple[int, int, int]],
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        constant: bool,
    ) -> None:
        """The fold pass's Newton (:mod:`~glmls.volume.folds`) for the voxels of a slab of
        ``size`` (W, H, slices) from voxel ``first`` (x, y, z), showing ``origin`` + the
        voxel, that ``listed`` names (the list of :class:`~glmls.gl.dispatch.SecondPass`,
        slab voxel numbers): from the points of their neighbours in ``neighbours`` (the
        window, (first voxel, (W, H, slices)), of the points Newton's passes found), nearest
        first, until one ends at a preimage (inside a volume of ``shape`` with ``constant``),
        written into ``coords`` (the slab's points) as :meth:`refine` writes them."""
        ...


class ReferenceField:
    """f of the float64 reference (:func:`glmls.reference.mls`) with (N, 3) handles
    ``src`` -> ``dst`` (handle units) for voxels of ``spacing`` (dz, dy, dx); ``shape``
    (D, H, W) gives the default radius: its diagonal in the handles' units, that of
    (D dz, H dy, W dx), as :class:`~glmls.volume.kernel_field.KernelField`'s."""

    def __init__(
        self,
        src: object,
        dst: object,
        config: MLSConfig | None = None,
        *,
        spacing: tuple[float, float, float] = (1.0, 1.0, 1.0),
        shape: tuple[int, int, int] | None = None,
    ) -> None:
        self.src = np.asarray(src, dtype=np.float64)
        self.dst = np.asarray(dst, dtype=np.float64)
        config = config if config is not None else MLSConfig()
        if config.uses_radius and config.radius is None and shape is not None:
            extent = [float(n) * float(d) for n, d in zip(shape, spacing, strict=True)]
            config = dataclasses.replace(config, radius=math.sqrt(sum(e * e for e in extent)))
        self.config = config
        dz, dy, dx = spacing
        self.scale = np.array([dx, dy, dz], dtype=np.float64)
        self.shape = shape
        self.sources = self.src / self.scale

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if len(points) == 0:
            return np.zeros((0, 3))
        f, _, _ = reference.mls(
            self.src, self.dst, points * self.scale, self.config, shape=self.shape
        )
        return f / self.scale

    def fill(
        self, lattice: CornerLattice, first: int, layers: int, target: moderngl.Buffer
    ) -> None:
        points = lattice.layer_points(first, layers).reshape(-1, 3)
        values = np.empty_like(points)
        for start in range(0, len(points), 1 << 16):  # bounded memory for the reference
            values[start : start + (1 << 16)] = self.evaluate(points[start : start + (1 << 16)])
        target.write(np.ascontiguousarray(values, dtype=np.float32))

    def refine(
        self,
        coords: moderngl.Buffer,
        size: tuple[int, int, int],
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        *,
        constant: bool,
        first: int | tuple[int, int, int] = 0,
        pending: moderngl.Buffer | None = None,
    ) -> None:
        """Newton's method in float64 (:func:`newton_inverse`) from the first guesses in
        ``coords`` ((x, y, z, w) per voxel of a slab of ``size`` (W, H, slices) whose voxel
        (i, j, k) shows ``origin`` + (i, j, ``first`` + k), source voxels, or + (i, j, k) +
        ``first``, the slab's first voxel (x, y, z); w < 0: no guess, start at the voxel),
        written back as the construction's backward pass does."""
        width, height, depth = size
        count = width * height * depth
        raw = np.frombuffer(coords.read(size=count * 16), np.float32).reshape(count, 4)
        k, j, i = np.meshgrid(np.arange(depth), np.arange(height), np.arange(width), indexing="ij")
        u = np.stack([i, j, k], axis=-1).reshape(-1, 3) + slab_corner(first)
        u = u + np.asarray(origin)
        guess = np.where(raw[:, 3:4] >= 0, raw[:, :3].astype(np.float64), u)
        s, residual = newton_inverse(self, u, guess)
        found = residual <= NEWTON_ACCEPT
        if constant:  # the closed box, within Newton's tolerance (as the GPU's pass)
            top = np.array(shape[::-1], dtype=np.float64) - 0.5 + NEWTON_TOLERANCE
            found &= np.all((s >= -0.5 - NEWTON_TOLERANCE) & (s <= top), axis=1)
        w = np.where(found, residual, -1.0 - np.minimum(residual, 1e30))
        out = np.concatenate([s, w[:, None]], axis=1).astype(np.float32)
        coords.write(np.ascontiguousarray(out))

    def rescue(
        self,
        neighbours: moderngl.Buffer,
        coords: moderngl.Buffer,
        listed: moderngl.Buffer,
        *,
        size: tuple[int, int, int],
        first: tuple[int, int, int],
        window: tuple[tuple[int, int, int], tuple[int, int, int]],
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        constant: bool,
    ) -> None:
        """The fold pass's Newton in float64 (:func:`newton_inverse`), the GPU's starts in
        its order (see :class:`Field`)."""
        count = int(np.frombuffer(listed.read(size=16), np.uint32)[3])
        if count == 0:
            return
        items = np.frombuffer(listed.read(size=4 * count, offset=16), np.uint32).astype(np.int64)
        corner, (ww, wh, wd) = np.asarray(window[0]), window[1]
        points = np.frombuffer(neighbours.read(size=ww * wh * wd * 16), np.float32)
        points = points.reshape(wd, wh, ww, 4).astype(np.float64)
        width, height, depth = size
        out = np.frombuffer(coords.read(size=width * height * depth * 16), np.float32)
        out = out.reshape(-1, 4).copy()
        v = np.stack([items % width, items // width % height, items // (width * height)], 1)
        v = v + np.asarray(first)
        u = v + np.asarray(origin, dtype=np.float64)
        own = points[tuple((v - corner)[:, ::-1].T)]
        converged = -1.0 - own[:, 3] <= NEWTON_ACCEPT
        done = np.zeros(count, bool)
        top = np.array(shape[::-1], dtype=np.float64) - 0.5 + NEWTON_TOLERANCE
        for k, offset in enumerate(fold_neighbours()):
            if k == FOLD_NEAR:  # the 3 x 3 x 3 only where the voxel's Newton converged
                done |= converged
            q = v + offset - corner
            inside = np.all((q >= 0) & (q < [ww, wh, wd]), axis=1)
            near = points[tuple(np.clip(q, 0, [ww - 1, wh - 1, wd - 1])[:, ::-1].T)]
            index = np.flatnonzero(~done & inside & (near[:, 3] >= 0))
            if len(index) == 0:
                continue
            s, residual = newton_inverse(self, u[index], near[index, :3])
            found = residual <= NEWTON_ACCEPT
            if constant:
                found &= np.all((s >= -0.5 - NEWTON_TOLERANCE) & (s <= top), axis=1)
            out[items[index[found]]] = np.column_stack([s[found], residual[found]])
            done[index[found]] = True
        coords.write(np.ascontiguousarray(out))


def slab_corner(first: int | tuple[int, int, int]) -> tuple[int, int, int]:
    """A slab's first output voxel (x, y, z): ``first`` itself, or (0, 0, ``first``) for
    the first slice of a slab of whole slices."""
    if isinstance(first, tuple):
        x, y, z = first
        return int(x), int(y), int(z)
    return 0, 0, int(first)


def newton_inverse(
    field: Field,
    targets: np.ndarray,
    guess: np.ndarray,
    *,
    tolerance: float = 1e-9,
    steps: int = 50,
    max_step: float = 4.0,
) -> tuple[np.ndarray, np.ndarray]:
    """f's inverse at ``targets`` ((K, 3) source voxels) by Newton's method in float64 from
    ``guess`` ((K, 3)), the Jacobian by central differences (a thousandth of a voxel), each
    step at most ``max_step`` voxels long. Returns the last iterates and their residuals
    |f(s) - u| (voxels)."""
    s = np.array(guess, dtype=np.float64, copy=True)
    u = np.asarray(targets, dtype=np.float64)
    h = 1e-3
    residual = np.full(len(u), np.inf)
    active = np.ones(len(u), bool)
    for _ in range(steps + 1):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        r = field.evaluate(s[idx]) - u[idx]
        residual[idx] = np.linalg.norm(r, axis=1)
        done = residual[idx] <= tolerance
        active[idx[done]] = False
        idx, r = idx[~done], r[~done]
        if len(idx) == 0:
            break
        jac = np.empty((len(idx), 3, 3))
        for axis in range(3):
            step = np.zeros(3)
            step[axis] = h
            jac[:, :, axis] = (field.evaluate(s[idx] + step) - field.evaluate(s[idx] - step)) / (
                2 * h
            )
        ok = np.abs(np.linalg.det(jac)) > 1e-12
        delta = np.zeros((len(idx), 3))
        delta[ok] = np.linalg.solve(jac[ok], r[ok][:, :, None])[:, :, 0]
        length = np.linalg.norm(delta, axis=1)
        factor = np.where(length > max_step, max_step / np.maximum(length, 1e-300), 1.0)
        s[idx] -= delta * factor[:, None]
        active[idx[~ok]] = False
    return s, residual
