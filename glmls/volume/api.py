"""The public entry points of volume warping: :func:`warp_volume`, :func:`volume_bounds`,
:func:`volume_coordinate_map`."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.config import check_choice
from ..core.handles3 import as_volume_spacing, chosen_spacing
from ..engine.kernel import check_loop_budget
from ..engine.kernel3 import MLSKernel3
from .construction import VolumeWarper
from .frame import VolumeBounds
from .kernel_field import KernelField
from .options import SlabOptions, VolumeOptions, volume_shape
from .source import check_volume

__all__ = ["volume_bounds", "volume_coordinate_map", "warp_volume"]


def _kernel(mls: object) -> MLSKernel3:
    kernel = mls if isinstance(mls, MLSKernel3) else getattr(mls, "kernel", None)
    if kernel is None:  # no MLS at all (a 2D one has a kernel, of the other kind)
        raise TypeError(
            f"mls must be a glmls.MLS of (N, 3) handles or its kernel, got {type(mls).__name__}"
        )
    if not isinstance(kernel, MLSKernel3):
        raise ValueError(
            "volumes are warped by a 3D MLS ((N, 3) handles); this one has 2D handles, "
            "which warp images H x W or H x W x C"
        )
    kernel.check_alive()
    return kernel


def _spacing(mls: object, given: tuple[float, float, float] | None) -> tuple[float, float, float]:
    """The spacing of a volume operation given ``given`` (checked) on ``mls``: the MLS's own
    when None (else 1 each); ValueError where it differs from the MLS's own."""
    chosen = chosen_spacing(given, getattr(mls, "spacing", None))  # a kernel has none
    return chosen if chosen is not None else (1.0, 1.0, 1.0)


def _options(mls: object, options: VolumeOptions | None, keywords: dict) -> VolumeOptions:
    options = VolumeOptions.of(options, **keywords)
    return dataclasses.replace(options, spacing=_spacing(mls, options.spacing))


def warp_volume(
    mls: object,
    volume: object,
    *,
    options: VolumeOptions | None = None,
    slabs: SlabOptions | None = None,
    **keywords: object,
) -> np.ndarray:
    """The volume deformed by a 3D MLS, built on the GPU slab by slab.

    Parameters
    ----------
    mls : glmls.MLS or MLSKernel3
        A 3D MLS ((N, 3) handles, (x, y, z) = (column, row, slice) in the units of
        ``spacing``), or its GPU kernel.
    volume : array_like
        D x H x W or D x H x W x C (C in 1..4), uint8, uint16, float32 or float64
        (computed as float32).
    options : VolumeOptions or None
        The construction (default: ``VolumeOptions()``), whose fields ``keywords`` replace.
    slabs : SlabOptions or None
        How large each output slab and lattice band may be (default: ``SlabOptions()``);
        any choice gives the same volume.
    **keywords
        Fields of :class:`VolumeOptions`: ``method`` (``"quads"``, the cells method, or
        ``"backward"``), ``interpolation``, ``grid``, ``border``, ``background``,
        ``output_shape`` (D, H, W), ``origin`` (x, y, z), ``spacing`` (dz, dy, dx): the
        MLS's ``spacing`` when not given (else 1 each; another than the MLS's is a
        ValueError). A radius weight of an MLS given no radius takes the diagonal of
        ``volume`` in the handles' units: that of (D dz, H dy, W dx).

    Returns
    -------
    numpy.ndarray
        A new array of ``volume``'s dtype and channels, of ``output_shape`` (default: the
        volume's).

    Raises
    ------
    ValueError
        For a 2D image or a 2D MLS, a bad option, a ``spacing`` other than the MLS's, an
        output beyond this machine's memory, or a volume whose extent in the handles' units
        (D dz, H dy, W dx) passes the coordinate range (1e6). Volumes and outputs beyond
        the GL 3D texture limit (2048 voxels a side at least) or a storage buffer are built
        in pieces (:class:`SlabOptions`), to the same voxels.
    TypeError
        For an ``mls`` that is no MLS, a bad dtype, a keyword that is no option, ``slabs``
        that is no :class:`SlabOptions`, or a ``spacing`` that is not a sequence of real
        numbers.

    Warns
    -----
    glmls.BorderWarning
        Where, with a border mode other than ``constant``, the lattice of cells extended as
        far as it may go (16.7 million points) still leaves canvas voxels uncovered: those
        keep the background.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> from glmls.volume import warp_volume
    >>> volume = np.arange(4 * 5 * 6, dtype=np.uint8).reshape(4, 5, 6)
    >>> src = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
    >>> m = glmls.MLS(src, src + [1, 0, 0])
    >>> out = warp_volume(m, volume)  # every voxel one column to the right
    >>> out[0, 0].tolist()
    [0, 0, 1, 2, 3, 4]
    >>> m.warp(volume, method="backward")[0, 0].tolist()  # the same function
    [0, 0, 1, 2, 3, 4]
    >>> m.release()
    """
    kernel = _kernel(mls)
    options = _options(mls, options, keywords)
    if slabs is not None and not isinstance(slabs, SlabOptions):
        raise TypeError(f"slabs must be a glmls.volume.SlabOptions, got {slabs!r}")
    array = check_volume(volume)
    if options.method == "backward":
        _check_newton(kernel)
    field = KernelField(kernel, options.spacing, array.shape[:3])
    return VolumeWarper.of(kernel.gl).warp(field, array, options, slabs)


def _check_newton(kernel: MLSKernel3) -> None:
    """``ValueError`` where the driver could not run the Newton pass over every handle,
    raised before f on the cells' lattice, which with that many handles takes long."""
    check_loop_budget(kernel.gl, "volume/newton.comp.glsl", kernel.count)


def volume_coordinate_map(
    mls: object,
    shape: object,
    options: VolumeOptions | None = None,
    **keywords: object,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The backward method's map: for each output voxel u its source point s with f(s) = u.

    Parameters
    ----------
    mls : glmls.MLS or MLSKernel3
        A 3D MLS, or its GPU kernel.
    shape : tuple of int
        (D, H, W) of the source volume, or its (D, H, W, C) with channels.
    options : VolumeOptions or None
        Its ``grid`` (None: 2, the backward method's), ``border``, ``output_shape``,
        ``origin`` and ``spacing`` apply (the spacing as :func:`warp_volume`'s); its other
        fields are not used.
    **keywords
        Fields of :class:`VolumeOptions` replacing those of ``options``: ``grid``,
        ``border``, ``output_shape``, ``origin``, ``spacing``, and ``method`` if it is
        ``"backward"`` (the map is that method's); ``interpolation`` and ``background``,
        which the map does not use, are refused.

    Returns
    -------
    map : numpy.ndarray
        (D, H, W, 3) float32 source points (x, y, z), handle units.
    residual : numpy.ndarray
        (D, H, W) float32 |f(s) - u|, voxels.
    covered : numpy.ndarray
        (D, H, W) bool: a source point was found (inside the volume, for ``constant``).

    Raises
    ------
    ValueError
        For a 2D MLS, a bad ``shape`` or option, a ``spacing`` other than the MLS's, or a
        volume whose extent in the handles' units passes the coordinate range (1e6).
    TypeError
        For an ``mls`` that is no MLS, a keyword that is no option or that the map does not
        use (``interpolation``, ``background``), or a ``spacing`` that is not a sequence of
        real numbers.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> from glmls.volume import volume_coordinate_map
    >>> src = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
    >>> m = glmls.MLS(src, src + [1, 0, 0])
    >>> points, residual, covered = volume_coordinate_map(m, (4, 5, 6))
    >>> points[0, 0, 3].tolist(), bool(covered[0, 0, 0])
    ([2.0, 0.0, 0.0], False)
    >>> m.release()
    """
    kernel = _kernel(mls)
    # the backward method's map, with that method's grid where none is given
    options = _options(mls, options, _map_keywords(keywords) | {"method": "backward"})
    size = volume_shape(shape)
    _check_newton(kernel)
    field = KernelField(kernel, options.spacing, size)
    return VolumeWarper.of(kernel.gl).coordinate_map(field, size, options)  # type: ignore[arg-type]


def _map_keywords(keywords: dict) -> dict:
    """:func:`volume_coordinate_map`'s ``keywords`` less ``method``: the map is the backward
    method's (``method="backward"`` is accepted, another is a ``ValueError``); ``TypeError``
    naming ``interpolation`` or ``background``, which it would not use (it samples
    nothing)."""
    unused = sorted({"interpolation", "background"} & set(keywords))
    if unused:
        raise TypeError(
            f"coordinate_map() takes no {' or '.join(unused)}: the map holds the source "
            "points of the backward method, and samples nothing"
        )
    keywords = dict(keywords)
    check_choice("method", keywords.pop("method", "backward"), ("backward",))
    return keywords


def volume_bounds(
    mls: object,
    shape: object,
    *,
    grid: int = 1,
    spacing: object = None,
) -> VolumeBounds:
    """The bounding box of the deformed volume: f at the corners of the voxel cubes.

    Parameters
    ----------
    mls : glmls.MLS or MLSKernel3
        A 3D MLS, or its GPU kernel.
    shape : tuple of int
        (D, H, W) of the volume, or its (D, H, W, C) with channels.
    grid : int, default 1
        The step of the lattice of corners, voxels.
    spacing : (float, float, float) or None, default None
        (dz, dy, dx) of the voxels, handle units (None: the MLS's ``spacing``, else 1
        each).

    Returns
    -------
    VolumeBounds
        Whose ``output_shape`` and ``origin`` give the canvas that shows all of it.

    Raises
    ------
    ValueError
        For a 2D MLS, a bad ``shape`` or ``grid``, a ``spacing`` of another length than 3 or
        with a value that is not a finite number > 0, or one other than the MLS's, or a
        volume whose extent in the handles' units passes the coordinate range (1e6).
    TypeError
        For an ``mls`` that is no MLS, or a ``spacing`` that is not a sequence of real
        numbers.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> from glmls.volume import volume_bounds
    >>> src = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
    >>> m = glmls.MLS(src, src + [1, 0, 0])
    >>> b = volume_bounds(m, (4, 5, 6))
    >>> b.output_shape, b.origin
    ((4, 5, 6), (1.0, 0.0, 0.0))
    >>> m.release()
    """
    kernel = _kernel(mls)
    size = volume_shape(shape)
    steps = _spacing(mls, None if spacing is None else as_volume_spacing(spacing))
    field = KernelField(kernel, steps, size)
    box = VolumeWarper.of(kernel.gl).bounds(field, size, grid)  # type: ignore[arg-type]
    scale = field.scale
    low, high = box[:3] * scale, box[3:] * scale
    return VolumeBounds(*(float(v) for v in (*low, *high)), spacing=steps)
