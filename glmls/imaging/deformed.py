"""The images of a deformation: :meth:`~DeformedImages.warp`,
:meth:`~DeformedImages.coordinate_map` and :meth:`~DeformedImages.bounds`, as methods of
:class:`glmls.MLS` (a base class of it), each a call of its context's shared
:class:`~glmls.gl.WarpPipeline`."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..engine.kernel import MLSKernel
from .frame import Bounds
from .pipeline import WarpPipeline

__all__ = ["DeformedImages"]


class DeformedImages:
    """The image methods of a deformation; a subclass gives :attr:`kernel` and
    :meth:`swapped_kernel` (see :class:`~glmls.imaging.pipeline.Deformation`)."""

    @property
    def kernel(self) -> MLSKernel:
        raise NotImplementedError

    def swapped_kernel(self) -> MLSKernel:
        raise NotImplementedError

    def _pipeline(self) -> WarpPipeline:
        self.kernel.check_alive()
        return WarpPipeline.of(self.kernel.gl)

    def warp(
        self,
        image: object,
        *,
        method: str = "quads",
        interpolation: str = "nearest",
        grid: int = 1,
        background: object = 0,
        border: str = "constant",
        output_shape: Sequence[int] | None = None,
        origin: Sequence[float] | None = None,
        tolerance: float | None = None,
    ) -> np.ndarray:
        """The image deformed by f: a new array of ``image``'s dtype and channels.

        ``image``: H x W or H x W x C (C in 1..4), uint8, uint16, float32 or float64 (computed
        as float32).

        The output canvas: ``output_shape`` (H, W; default the input's) pixels, output pixel
        (column i, row j) showing the deformed plane's point ``origin`` + (i, j) (default
        origin (0, 0)); what f moves off the canvas is cut off. :meth:`bounds` gives the
        canvas that shows the whole deformed image.

        ``method``: ``"quads"`` (forward with polygon interpolation: the mesh of pixel-square
        corners, step ``grid`` pixels, is deformed and each deformed quad filled);
        ``"splat"`` (simple forward: each source pixel v written at round(f(v)), gaps and
        all); ``"backward"`` (each output pixel u samples the source at s with f(s) = u,
        Newton's method from the rasterized inverse of the mesh, ``grid`` that guess's mesh);
        ``"backward-swap"`` (s = the MLS map with p and q swapped, the shortcut of other MLS
        tools; only for comparison, it is not f's inverse).

        ``interpolation``: ``"nearest"`` takes one source pixel's value (no new colours);
        ``"linear"`` interpolates bilinearly (``splat`` ignores it). ``background``: what
        uncovered pixels hold: a scalar, or one value per channel; images with alpha (C = 2
        or 4) get alpha 0 there unless ``background`` gives it.

        ``border``: what lies beyond the source image, with numpy.pad's meanings:
        ``"constant"`` (nothing: the background shows), ``"edge"`` (the edge pixels
        repeated), ``"symmetric"`` (mirrored with the edge pixel: ``a b c | c b a``),
        ``"reflect"`` (mirrored about it: ``a b c | b a``), ``"wrap"`` (the image
        repeated). The backward methods sample by that rule; the forward methods extend the
        mesh past the image, as far as the canvas needs (derived from f, see
        :func:`glmls.imaging.frame.border_margin`), so no canvas pixel keeps the background.

        ``"paper-quads"``: the paper's pseudo-code exactly (squares of four adjacent pixel
        centres, each pixel inside a deformed square coloured by its nearest vertex; ``grid``
        must be 1; ``"linear"`` blends the square's four vertices bilinearly);
        see ``docs/warp.md`` for how it differs from ``"quads"``.

        Fold-overs: where deformed quads overlap, the first cell in row-major scan order of
        the source (smaller row, then column) shows, as the paper's marked pixels keep their
        colour; ``paper-quads`` (its squares), ``splat`` (its pixels) and ``backward`` (its
        first guess) follow the same order.

        ``tolerance`` (pixels, ``quads`` only; ``grid`` must stay 1): the error-bounded
        adaptive mesh instead of the regular one (``docs/adaptive.md``): cells refined until
        the estimated distance between each output pixel's source point and f's inverse is
        within ``tolerance``, down to 1 px cells, and 1/2 or 1/4 px where f stretches.
        ``None`` (default): the regular mesh at ``grid``.
        """
        return self._pipeline().warp(
            self,
            image,
            method=method,
            interpolation=interpolation,
            grid=grid,
            background=background,
            border=border,
            output_shape=output_shape,
            origin=origin,
            tolerance=tolerance,
        )

    def bounds(self, shape: Sequence[int], *, grid: int = 1) -> Bounds:
        """The bounding box of the deformed image of an image of ``shape``: a
        :class:`glmls.Bounds` (``x0, y0, x1, y1``, pixels) whose ``output_shape`` and
        ``origin`` give :meth:`warp` the canvas that shows all of it::

            b = m.bounds(image.shape)
            whole = m.warp(image, output_shape=b.output_shape, origin=b.origin)

        The box of f at the corners of the pixel squares, every ``grid`` pixels (the mesh
        the ``quads`` are drawn with; 1 is closest to f), evaluated on the GPU.
        """
        return self._pipeline().bounds(self, shape, grid=grid)

    def coordinate_map(
        self,
        shape: Sequence[int],
        *,
        method: str = "backward",
        grid: int = 1,
        residual: bool = False,
        border: str = "constant",
        output_shape: Sequence[int] | None = None,
        origin: Sequence[float] | None = None,
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The (H, W, 2) float32 map from output pixels to source points (x, y): f's inverse.

        For each output pixel u = (column, row), the source point s with f(s) = u, solved on
        the GPU (``method="backward"``; ``"backward-swap"`` gives the swapped-handles shortcut
        instead). Points outside the source image are kept (a remapper fills them by its
        border rule): ``cv2.remap(image, xy[..., 0], xy[..., 1], cv2.INTER_LINEAR)``, or per
        channel ``skimage.transform.warp(channel, np.stack([xy[..., 1], xy[..., 0]]))``, or
        ``scipy.ndimage.map_coordinates(channel, [xy[..., 1], xy[..., 0]], mode=...)``.
        ``border``: the rule the remapper will use; any mode but ``"constant"`` makes Newton
        start from the mesh extended past the image (as :meth:`warp` does), so that points
        far outside the image are found too.

        ``output_shape`` and ``origin``: the output canvas, as in :meth:`warp` (default: the
        image of ``shape`` itself).

        ``residual=True`` also returns |f(s) - u| per pixel (float32, pixels; NaN for
        backward-swap). Newton stops below 1e-3 px; pixels where it ends above 0.05 px (no
        inverse found) hold its last iterate.
        """
        xy, res, _ = self._pipeline().coordinate_map(
            self,
            shape,
            method=method,
            grid=grid,
            border=border,
            output_shape=output_shape,
            origin=origin,
        )
        return (xy, res) if residual else xy
