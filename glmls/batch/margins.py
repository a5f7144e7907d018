"""The margins of a batch's meshes past their images, for a border mode other than
``constant``: each image's own, as its single warp finds it
(:func:`~glmls.imaging.frame.border_margin`), every image's ring of mesh points evaluated in
one pass per step of the search."""

from __future__ import annotations

import warnings

import numpy as np

from ..core.config import MLSConfig
from ..core.mesh import MeshLattice
from ..engine.batched import BatchLattices
from ..errors import BorderWarning
from ..gl.context import GLContext
from ..gl.resources import Resources
from ..imaging.frame import Frame, margin_shortfall, search_margins
from .inputs import BatchInput

__all__ = ["batch_margins", "warn_short"]

#: Images whose rings one pass evaluates, at most: a large batch's search runs slice by
#: slice, its GPU memory bounded.
SEARCH_IMAGES = 4096


def batch_margins(
    gl: GLContext,
    config: MLSConfig,
    batch: BatchInput,
    indices: list[int],
    lattice: MeshLattice,
    frame: Frame,
) -> tuple[dict[int, list[int]], dict[int, int]]:
    """The batch's images ``indices`` (one shape) by the margin (pixels) that their mesh of
    ``lattice`` needs past the image so that, with a border mode, the deformed mesh covers
    ``frame``: the margin the single warp of each finds; and the images (index: margin)
    that even the largest margin leaves short of covering the canvas (:func:`warn_short`)."""
    parts: dict[int, list[int]] = {}
    short: dict[int, int] = {}
    resources = Resources(gl, "the batch margins")
    try:
        for start in range(0, len(indices), SEARCH_IMAGES):
            chosen = indices[start : start + SEARCH_IMAGES]
            src, dst = [batch.src[i] for i in chosen], [batch.dst[i] for i in chosen]
            lattices = BatchLattices(config, src, dst, lattice.shape)
            handles = list(zip(src, dst, strict=True))
            found = _search(gl, resources, lattices, lattice, frame, handles)
            for i, (margin, encloses_frame) in zip(chosen, found, strict=True):
                if not encloses_frame:
                    short[i] = margin
                parts.setdefault(margin, []).append(i)
    finally:
        resources.release()
    return parts, short


def warn_short(short: dict[int, int], done: list, stacklevel: int) -> None:
    """The :class:`~glmls.errors.BorderWarning` of each image of ``short`` (index: margin,
    from :func:`batch_margins`) that the batched path warped (``done[i]`` not None; the
    single pipeline warns for the others itself), naming the image."""
    for i, margin in sorted(short.items()):
        if done[i] is not None:
            message = f"images[{i}]: {margin_shortfall(margin)}"
            warnings.warn(message, BorderWarning, stacklevel=stacklevel + 1)


def _search(
    gl: GLContext,
    resources: Resources,
    lattices: BatchLattices,
    lattice: MeshLattice,
    frame: Frame,
    handles: list[tuple[np.ndarray, np.ndarray]],
) -> list[tuple[int, bool]]:
    """:func:`~glmls.imaging.frame.search_margins` of every image (``handles``: each one's
    source and target points), each step's rings in one
    :meth:`~glmls.engine.batched.BatchLattices.evaluate_points`."""
    empty = np.zeros((0, 2))

    def evaluate(rings: list[np.ndarray | None]) -> list[np.ndarray | None]:
        points = [empty if r is None else r for r in rings]
        return lattices.evaluate_points(gl, resources, points, lattice.shape)  # type: ignore[return-value]

    return search_margins(evaluate, len(lattices), lattice, frame, handles=handles)
