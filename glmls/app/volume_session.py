"""What the volume window computes, free of drawing: the 3D MLS of the controller's handles
and settings, the three deformed slices through the slice point, and the overlays on them
(the error field E_MLS, the folds), each redone only when its inputs change.

A frame costs three slices, not a volume: each slice is a warp whose output canvas is one
voxel thick (``output_shape`` with a depth, height or width of 1 and the ``origin`` on the
plane). An overlay is a field over the whole volume, evaluated on a lattice once per
handle change (the error field E_MLS of eq. 7, or the voxels of the cells where det J <= 0)
and deformed with the slices, as a second channel of the same warps: it is drawn where f
takes each voxel, as in the 2D window, for no more warps than the slices alone.
"""

from __future__ import annotations

import time

import numpy as np

from ..analysis.colormaps import apply_colormap, format_number, picture_limits
from ..analysis.jacobians import cell_jacobians
from ..analysis.stats import error_stats
from ..analysis.volume_field import volume_error_field
from ..gl.context import GLContext
from ..mls import MLS
from .volume_controller import AXES, VolumeController

__all__ = [
    "ERROR_ALPHA",
    "FIELD_GRID",
    "FOLD_RGBA",
    "VolumeSession",
    "check_fits",
    "display_volume",
]

#: The error field's opacity (0-255) from its lowest to its highest colour, and the folds'
#: colour (RGBA, 0-255), over the slices.
ERROR_ALPHA = (40, 200)
FOLD_RGBA = (255, 26, 153, 170)
#: The overlays' fields are evaluated on a lattice of this step at least (voxels).
FIELD_GRID = 4


def display_volume(volume: np.ndarray) -> np.ndarray:
    """A volume as uint8 grey (D, H, W) for the window: the first channel (the mean of
    three or four), from the 0.5th (black) to the 99.5th percentile (white) of its finite
    values (NaN black, infinities at the ends); where the two are equal (a constant volume),
    from the lower of 0 and that value to the higher of 1 and it; uint8 grey volumes stay as
    they are.

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
    # float32 where it holds the values; float64 (and int32, int64) keep their range and
    # precision (1e300s, or 1000 + 1e-4 steps, would be infinities or one value in float32)
    work = np.float32 if np.can_cast(array.dtype, np.float32) else np.float64
    finite = array[np.isfinite(array)]  # NaN (masked voxels) would make every percentile NaN
    low, high = np.percentile(finite.astype(work), [0.5, 99.5]) if finite.size else (0.0, 1.0)
    low, high = float(low), float(high)
    if high <= low:  # (nearly) constant: as an image, within [0, 1] or stretched to reach it
        low, high = min(0.0, low), max(1.0, high)
    shown = np.empty(array.shape, np.uint8)
    for z, slab in enumerate(array):  # a slab at a time: no float copy of the whole volume
        values = (slab.astype(np.float64) - low) / (high - low)
        shown[z] = np.round(np.clip(np.nan_to_num(values, nan=0.0), 0, 1) * 255)
    return shown


def check_fits(gl: GLContext, shape: tuple[int, int, int]) -> None:
    """Refuse a volume of ``shape`` (D, H, W) that the window on ``gl`` cannot show: its
    slices (H x W) past the GL 3D texture limit (:func:`glmls.volume.warp_volume` builds
    those in boxes, a pass each, too slow for slices that follow a drag live), or a side past
    the 2D texture limit, which no view's picture holds.

    Parameters
    ----------
    gl : glmls.gl.GLContext
        The window's context.
    shape : tuple of int
        (D, H, W) of the volume.

    Raises
    ------
    ValueError
        Naming the volume's size and the limit it passes.

    Examples
    --------
    >>> check_fits(glmls.gl.get_context(), (64, 64, 64))  # fits: nothing said
    >>> check_fits(glmls.gl.get_context(), (1, 100_000, 8))
    Traceback (most recent call last):
    ...
    ValueError: a volume of 8 x 100000 x 1 voxels (x, y, z): ...
    """
    depth, height, width = shape
    size = f"a volume of {width} x {height} x {depth} voxels (x, y, z)"
    side = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
    if max(height, width) > side:
        raise ValueError(
            f"{size}: the window deforms slices of at most {side} x {side} voxels (x, y) on "
            "this device; crop or downsample it"
        )
    flat = gl.limits["max_texture_size"]
    if max(shape) > flat:
        raise ValueError(
            f"{size}: the window shows at most {flat} voxels a side on this device; crop or "
            "downsample it"
        )


def _plane(view: int, shape: tuple[int, int, int], point, scale) -> tuple[tuple, tuple]:
    """(output_shape, origin) of the one-voxel-thick canvas of ``view``'s plane, the origin
    in handle units (``scale``: handle units per voxel along x, y, z)."""
    normal = AXES[view][2]
    size = list(shape)
    size[2 - normal] = 1
    origin = [0.0, 0.0, 0.0]
    origin[normal] = float(point[normal] * scale[normal])
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
        #: Per view, why its slice could not be deformed ("" if it was): it shows the volume
        #: as it is until f, the overlay or its plane changes.
        self.slice_errors = ["", "", ""]
        self.timings: dict[str, float] = {}
        #: The readout's lines of the overlay shown.
        self.lines: list[str] = []
        self._config: object = None
        self._slices: list[tuple[tuple, np.ndarray]] = [((), np.zeros((0, 0, 1), np.uint8))] * 3
        self._overlays: tuple[tuple, list[np.ndarray] | None] = ((), None)
        self._field: tuple[tuple, np.ndarray | None] = ((), None)

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
                mls = self._mls(config)
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

    def _mls(self, config) -> MLS:
        """A new MLS of the controller's handles, with the volume's shape and, in handle
        units other than voxels, its spacing (as ``glmls warp``): a radius weight's default
        radius is the volume's diagonal in those units. The overlays' analyses take that
        spacing from the MLS, as ``glmls.analysis`` does: the same folds and error field."""
        c = self.controller
        spacing = None if c.grid.isotropic else c.grid.spacing
        return MLS.from_config(c.src, c.dst, config, shape=self.shape, spacing=spacing, ctx=self.gl)

    def field(self) -> np.ndarray | None:
        """The overlay's field over the whole volume, (D, H, W) uint8, or None without one:
        the error field E_MLS (:func:`~glmls.analysis.volume_error_field`, 0 to 255 from
        its minimum to its 99th percentile) or the voxels of the folded cells
        (:func:`~glmls.analysis.cell_jacobians`, 255), on the lattice of the slices' grid
        (every :data:`FIELD_GRID` voxels at least) for the current handles."""
        c = self.controller
        if c.overlay == "none" or self.mls is None:
            self.lines = []
            self.timings["analysis"] = 0.0  # none made: not the last overlay's time
            return None
        grid = max(c.settings.grid, FIELD_GRID)
        key = (self.revision, c.overlay, grid)
        if key == self._field[0]:
            return self._field[1]
        start = time.perf_counter()
        if c.overlay == "error":
            values = volume_error_field(self.mls, self.shape, grid=grid)
            unit = 1.0 if c.grid.isotropic else float(min(c.grid.spacing))
            low, high = picture_limits("E_MLS", values, percentile=99.0, unit=unit)
            span = high - low if high > low else 1.0
            field = np.round(np.clip((values - low) / span, 0.0, 1.0) * 255).astype(np.uint8)
            stats = error_stats(values)
            units = "voxels" if c.grid.isotropic else "units"
            self.lines = [
                f"E_MLS over the volume ({units}^2, grid {grid}):",
                f"  mean {_number(stats['mean'])} std {_number(stats['std'])}",
                f"  min {_number(stats['min'])} max {_number(stats['max'])}",
            ]
        else:
            cells = cell_jacobians(self.mls, self.shape, grid=grid)
            field = np.where(cells.mask, np.uint8(255), np.uint8(0))
            self.lines = [f"folds (det J <= 0): {cells.count} of {cells.det.size} cells"]
        self._field = (key, field)
        self.timings["analysis"] = time.perf_counter() - start
        return field

    def slices(self) -> list[np.ndarray]:
        """The three deformed slices (axial, coronal, sagittal), each (rows, columns) uint8,
        through the controller's slice point; the undeformed ones without a valid MLS. A
        slice is made again only when f, the overlay or its own plane changed: moving the
        slice point along one axis costs one slice. With an overlay, its :meth:`field`
        rides along as a second channel of the same warp."""
        c = self.controller
        field = self.field()
        start = time.perf_counter()
        made = False
        for view in range(3):
            normal = AXES[view][2]
            key = (self.revision, c.point[normal], self.mls is None, self._field[0], field is None)
            if self._slices[view][0] != key:
                self._slices[view] = (key, self._deformed(view, field))
                made = True
        if made:  # the readout keeps the last slices' time
            self.timings["slices"] = time.perf_counter() - start
        return [picture[..., 0] for _, picture in self._slices]

    @property
    def slice_error(self) -> str:
        """Why a view shows its slice undeformed although f is valid ("" if none does)."""
        return next((error for error in self.slice_errors if error), "")

    def _deformed(self, view: int, field: np.ndarray | None) -> np.ndarray:
        """:meth:`_slice`, or the plane undeformed where the warp refuses it (a lattice
        past the GL limits): the window stays, and :attr:`slice_error` says why."""
        try:
            picture = self._slice(view, field)
        except ValueError as error:
            self.slice_errors[view] = str(error)
            return self._slice(view, None, deform=False)
        self.slice_errors[view] = ""
        return picture

    def _slice(self, view: int, field: np.ndarray | None, *, deform: bool = True) -> np.ndarray:
        """(rows, columns, channels): the picture, then the field if given."""
        c, s = self.controller, self.controller.settings
        volume = self.volume if field is None else np.stack([self.volume, field], axis=3)
        if self.mls is None or not deform:
            index = [slice(None)] * 3
            normal = AXES[view][2]
            index[2 - normal] = slice(c.point[normal], c.point[normal] + 1)
            block = volume[tuple(index)]
        else:
            size, origin = _plane(view, self.shape, c.point, c.grid.scale)
            block = self.mls.warp(
                volume,
                method=s.method,
                interpolation=s.interpolation,
                grid=s.grid,
                border=s.border,
                output_shape=size,
                origin=origin,
                spacing=c.grid.spacing,
            )
        picture = _as_view(block, view)
        return np.ascontiguousarray(picture if picture.ndim == 3 else picture[..., None])

    def overlays(self) -> list[np.ndarray] | None:
        """The overlay shown, per view an RGBA (rows, columns, 4) uint8 picture, or None:
        the deformed slices of :meth:`field` in colour."""
        c = self.controller
        self.slices()
        if c.overlay == "none" or self.mls is None:
            return None
        key = tuple(k for k, _ in self._slices)
        if key == self._overlays[0]:
            return self._overlays[1]
        pictures = []
        for _, picture in self._slices:
            if picture.shape[2] < 2:
                return None
            values = picture[..., 1]
            rgba = np.zeros((*values.shape, 4), np.uint8)
            if c.overlay == "error":
                share = values.astype(np.float32) / 255.0
                rgba[..., :3] = apply_colormap(share, cmap="linear", vmin=0.0, vmax=1.0)
                rgba[..., 3] = np.round(ERROR_ALPHA[0] + (ERROR_ALPHA[1] - ERROR_ALPHA[0]) * share)
            else:
                rgba[values >= 128] = FOLD_RGBA
            pictures.append(rgba)
        self._overlays = (key, pictures)
        return pictures

    def release(self) -> None:
        """Release the MLS."""
        if self.mls is not None:
            self.mls.release()
            self.mls = None


def _number(value: object) -> str:
    return "-" if value is None else format_number(float(value))  # type: ignore[arg-type]
