"""Module-level helpers around :meth:`glmls.MLS.warp`: the one-call shortcut and fold-overs."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .mls import MLS, as_shape, mesh_axes

_WARP_OPTIONS = ("method", "interpolation", "grid", "background")


def warp(image: object, src: object, dst: object, **options: object) -> np.ndarray:
    """Deform ``image`` by the MLS map taking handles ``src`` (p) to ``dst`` (q).

    ``options``: those of :meth:`MLS.warp` (``method``, ``interpolation``, ``grid``,
    ``background``) and of :class:`MLS` (``transform``, ``weight``, ``alpha``, ``s``,
    ``radius``, ``interpolating``, ``ctx``, ``storage``, ``bins``). The default radius is the
    image diagonal. GPU objects are released before returning; keep an :class:`MLS` to warp
    many images.
    """
    warp_options = {k: options.pop(k) for k in _WARP_OPTIONS if k in options}
    array = np.asarray(image)
    shape = array.shape[:2] if array.ndim in (2, 3) and array.size else None
    with MLS(src, dst, shape=shape, **options) as m:  # type: ignore[arg-type]
        return m.warp(array, **warp_options)  # type: ignore[arg-type]


class Foldovers(NamedTuple):
    """Mesh cells that f turns over: ``count`` cells; ``mask`` (H, W) bool marks the source
    pixels of those cells."""

    count: int
    mask: np.ndarray


def foldovers(m: MLS, shape: object, grid: int = 1) -> Foldovers:
    """The cells of the mesh of ``shape`` (step ``grid``) that fold over under f.

    A cell folds when either of the two triangles it is drawn as, (00, 10, 11) and
    (00, 11, 01), has a negative signed area after deformation (this includes every cell whose
    deformed quad has negative area). Where cells fold, the rasterized image shows the one
    drawn last (see :meth:`MLS.warp`).
    """
    height, width = as_shape(shape)
    mesh_axes((height, width), grid)  # validates grid
    _, f = m.mesh((height, width), grid=grid)
    a, b = f[:-1, :-1], f[:-1, 1:]
    c, d = f[1:, 1:], f[1:, :-1]

    def cross(o: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return (x[..., 0] - o[..., 0]) * (y[..., 1] - o[..., 1]) - (x[..., 1] - o[..., 1]) * (
            y[..., 0] - o[..., 0]
        )

    folded = (cross(a, b, c) < 0) | (cross(a, c, d) < 0)
    mask = np.repeat(np.repeat(folded, grid, axis=0), grid, axis=1)[:height, :width]
    return Foldovers(int(folded.sum()), mask)
