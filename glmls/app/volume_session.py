"""What the volume window computes, free of drawing: the 3D MLS of the controller's handles
and settings, the three deformed slices through the slice point, and the overlays on them
(the error field E_MLS, the folds), each redone only when its inputs change.

A frame costs three slices, not a volume: each slice is a warp whose output canvas is one
voxel thick (``output_shape`` with a depth, height or width of 1 and the ``origin`` on the
plane). The overlays take, for each output voxel of the three planes, its source point
under f (:func:`glmls.volume.volume_coordinate_map`, the backward method's map) and
evaluate there the affine fit's error (eq. 7) or det J, so that they are drawn where f
takes each voxel, as in the 2D window.
"""

from __future__ import annotations

import time

import numpy as np

from ..analysis.colormaps import apply_colormap, color_limits, format_number
from ..analysis.stats import error_stats
from ..analysis.volume_field import fit_residuals
from ..gl.context import GLContext
from ..mls import MLS
from ..volume import volume_coordinate_map
from .volume_controller import AXES, VolumeController

__all__ = ["ERROR_ALPHA", "FOLD_RGBA", "VolumeSession", "display_volume"]

#: The error field's opacity (0-255) from its lowest to its highest colour, and the folds'
#: colour (RGBA, 0-255), over the slices.
ERROR_ALPHA = (40, 200)
FOLD_RGBA = (255, 26, 153, 170)


def display_volume(volume: np.ndarray) -> np.ndarray:
    """A volume as uint8 grey (D, H, W) for the window: the first channel (the mean of
    three or four), from its 0.5th (black) to its 99.5th percentile (white); uint8 grey
    volumes stay as they are.

    Parameters
    ----------
    volume : numpy.ndarray
        (D, H, W) or (D, H, W, C) real values.

    Returns
    -------
    numpy.ndarray
        (D, H, W) uint8.

    Raises
    ------
    ValueError
        For an array that is no volume.

    Examples
    --------
    >>> import numpy as np
    >>> display_volume(np.linspace(0, 1, 8).reshape(2, 2, 2)).ravel().tolist()
    [0, 36, 72, 109, 146, 183, 219, 255]
    """
    array = np.asarray(volume)
    if array.ndim == 4 and 1 <= array.shape[3] <= 4:
        array = array[..., 0] if array.shape[3] < 3 else array[..., :3].mean(axis=3)
    if array.ndim != 3 or min(array.shape) < 1:
        raise ValueError(f"a volume must be D x H x W or D x H x W x C, got {array.shape}")
    if array.dtype == np.uint8:
        return np.ascontiguousarray(array)
    values = array.astype(np.float32)
    low, high = np.percentile(values, [0.5, 99.5])
    span = float(high - low) if high > low else 1.0
    return np.round(np.clip((values - low) / span, 0, 1) * 255).astype(np.uint8)


def _plane(view: int, shape: tuple[int, int, int], point) -> tuple[tuple, tuple]:
    """(output_shape, origin) of the one-voxel-thick canvas of ``view``'s plane."""
    normal = AXES[view][2]
    size = list(shape)
    size[2 - normal] = 1
    origin = [0.0, 0.0, 0.0]
    origin[normal] = float(point[normal])
    return tuple(size), tuple(origin)


def _as_view(block: np.ndarray, view: int) -> np.ndarray:
    """A one-voxel-thick output (D', H', W'[, ...]) as the view's picture (rows, columns)."""
    if view == 0:
        return block[0]
    if view == 1:
        return block[:, 0]
    return np.swapaxes(block[:, :, 0], 0, 1)


class VolumeSession:
    """The 3D MLS on the window's context ``gl`` for ``controller``'s handles and settings,
    and the pictures of a ``volume`` (D, H, W) uint8 (:func:`display_volume`) it shows."""

    def __init__(self, gl: GLContext, controller: VolumeController, volume: np.ndarray) -> None:
        self.gl = gl
        self.controller = controller
        self.volume = volume
        self.shape: tuple[int, int, int] = volume.shape[:3]
        self.mls: MLS | None = None
        self.revision = -1
        #: Why the last change of handles failed ("" if not): the last valid f stays.
        self.error = ""
        self.timings: dict[str, float] = {}
        #: The readout's lines of the overlay shown.
        self.lines: list[str] = []
        self._config: object = None
        self._slices: list[tuple[tuple, np.ndarray]] = [((), np.zeros((0, 0), np.uint8))] * 3
        self._overlays: tuple[tuple, list[np.ndarray] | None] = ((), None)

    def sync(self) -> None:
        """Bring the MLS up to the controller's revision (a new MLS when the configuration
        changed); on invalid handles the last valid f stays and :attr:`error` says why."""
        c = self.controller
        if c.revision == self.revision and self.mls is not None:
            return
        start = time.perf_counter()
        config = c.settings.config
        try:
            if len(c.src) == 0:
                raise ValueError("no handles: shift + click in a view adds one")
            if self.mls is None or config != self._config:
                mls = MLS.from_config(c.src, c.dst, config, shape=self.shape, ctx=self.gl)
                if self.mls is not None:
                    self.mls.release()
                self.mls, self._config = mls, config
            else:
                self.mls.set_handles(c.src, c.dst)
            self.error = ""
        except ValueError as error:
            self.error = str(error)
        self.revision = c.revision
        self.timings["handles"] = time.perf_counter() - start

    def slices(self) -> list[np.ndarray]:
        """The three deformed slices (axial, coronal, sagittal), each (rows, columns) uint8,
        through the controller's slice point; the undeformed ones without a valid MLS. A
        slice is made again only when f or its own plane changed: moving the slice point
        along one axis costs one slice."""
        c = self.controller
        start = time.perf_counter()
        for view in range(3):
            normal = AXES[view][2]
            key = (self.revision, c.point[normal], self.mls is None)
            if self._slices[view][0] != key:
                self._slices[view] = (key, self._slice(view))
        self.timings["slices"] = time.perf_counter() - start
        return [picture for _, picture in self._slices]

    def _slice(self, view: int) -> np.ndarray:
        c, s = self.controller, self.controller.settings
        if self.mls is None:
            index = [slice(None)] * 3
            normal = AXES[view][2]
            index[2 - normal] = slice(c.point[normal], c.point[normal] + 1)
            block = self.volume[tuple(index)]
        else:
            size, origin = _plane(view, self.shape, c.point)
            block = self.mls.warp(
                self.volume,
                method=s.method,
                interpolation="linear",
                grid=s.grid,
                border="edge",
                output_shape=size,
                origin=origin,
            )
        return np.ascontiguousarray(_as_view(block, view))

    def overlays(self) -> list[np.ndarray] | None:
        """The overlay shown, per view an RGBA (rows, columns, 4) uint8 picture, or None."""
        c = self.controller
        if c.overlay == "none" or self.mls is None:
            self.lines = []
            return None
        key = (self.revision, c.point, c.overlay)
        if key == self._overlays[0]:
            return self._overlays[1]
        start = time.perf_counter()
        sources, covered = [], []
        for view in range(3):
            size, origin = _plane(view, self.shape, c.point)
            points, _, found = volume_coordinate_map(
                self.mls,
                self.shape,
                grid=c.settings.grid,
                border="edge",  # as the slices: voxels that f moves the border past count
                output_shape=size,
                origin=origin,
            )
            sources.append(_as_view(points, view))
            covered.append(_as_view(found, view))
        flat = np.concatenate([s.reshape(-1, 3) for s in sources]).astype(np.float64)
        inside = np.concatenate([k.ravel() for k in covered])
        if c.overlay == "error":
            matrices, shifts = self.mls.matrices(flat)
            values = fit_residuals(self.mls.src, self.mls.dst, matrices, shifts)
            rgba = self._error_pictures(values, inside)
        else:
            _, jacobian = self.mls.jacobian(flat)  # type: ignore[attr-defined]
            folded = (np.linalg.det(jacobian) <= 0) & inside
            rgba = np.zeros((len(flat), 4), np.uint8)
            rgba[folded] = FOLD_RGBA
            self.lines = [f"folds (det J <= 0): {int(folded.sum())} of {int(inside.sum())} voxels"]
        pictures, at = [], 0
        for s in sources:
            rows, columns = s.shape[:2]
            pictures.append(rgba[at : at + rows * columns].reshape(rows, columns, 4))
            at += rows * columns
        self._overlays = (key, pictures)
        self.timings["analysis"] = time.perf_counter() - start
        return pictures

    def _error_pictures(self, values: np.ndarray, inside: np.ndarray) -> np.ndarray:
        shown = values[inside]
        if shown.size == 0:
            self.lines = ["E_MLS: no voxel of the planes is covered"]
            return np.zeros((len(values), 4), np.uint8)
        low, high = color_limits(shown, percentile=99.0)
        rgba = np.zeros((len(values), 4), np.uint8)
        rgba[:, :3] = apply_colormap(values, cmap="linear", vmin=low, vmax=high)
        share = np.clip((values - low) / (high - low if high > low else 1.0), 0.0, 1.0)
        alpha = ERROR_ALPHA[0] + (ERROR_ALPHA[1] - ERROR_ALPHA[0]) * share
        rgba[inside, 3] = np.round(alpha[inside]).astype(np.uint8)
        stats = error_stats(shown)
        self.lines = [
            "E_MLS on the planes (voxels^2):",
            f"  mean {_number(stats['mean'])} std {_number(stats['std'])}",
            f"  min {_number(stats['min'])} max {_number(stats['max'])}",
        ]
        return rgba

    def release(self) -> None:
        """Release the MLS."""
        if self.mls is not None:
            self.mls.release()
            self.mls = None


def _number(value: object) -> str:
    return "-" if value is None else format_number(float(value))  # type: ignore[arg-type]
