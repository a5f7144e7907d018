"""One call that analyses a deformation of one volume: statistics, timings and pictures."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..core.config import MLSConfig, check_flag, check_real
from ..core.handles3 import volume_diagonal
from ..errors import DtypeError
from ..files.volumes import Volume
from ..forking import renderer
from ..volume.options import VolumeOptions
from . import colormaps
from .jacobians import CellJacobians, cell_jacobians
from .reporting import SavedReport, StageClock, cmap_name
from .stats import error_stats
from .tetrahedra import (
    SLIVER_QUALITY,
    TetrahedronErrors,
    check_tetrahedron_options,
    tetrahedron_errors,
)
from .volume_field import Deformation3D, volume_deformation, volume_error_field
from .volume_lattice import (
    as_points3,
    check_grid3,
    check_handles3,
    deformation_spacing,
    spacing_scale,
)
from .volume_pictures import check_slices, render_volume_slices

__all__ = ["VOLUME_PICTURES", "VolumeReport", "volume_report"]

#: The pictures :func:`volume_report` may draw, in its order (``deformed`` where it has a
#: deformed volume); ``save`` writes each as ``NAME.png``.
VOLUME_PICTURES = (
    "input_handles",
    "deformed",
    "error_field",
    "error_field_colorbar",
    "jacobian_det",
    "jacobian_det_colorbar",
    "folds",
)


@dataclasses.dataclass(frozen=True, eq=False)
class VolumeReport(SavedReport):
    """What :func:`volume_report` found: statistics, timings and pictures of a 3D deformation.

    Attributes
    ----------
    summary : dict
        JSON-ready: the volume's size, the configuration and handles, the analysis
        settings, timings in seconds, the statistics of the error field, the tetrahedra and
        the cells' Jacobians (with the fold count), and under ``warp`` the options that
        made the deformed volume (None where they are unknown or there is none).
    images : dict of str to numpy.ndarray
        Picture name -> (h, w, 3) uint8 picture (:func:`render_volume_slices`).
    field : numpy.ndarray
        The MLS error field (eq. 7), (D, H, W) float64.
    tetrahedra : TetrahedronErrors or None
        The reference tetrahedra's errors; None where the handles, taken as the reference
        points, form no tetrahedron.
    jacobians : CellJacobians
        det J, the singular value ratio and the folds per cell.
    deformed : numpy.ndarray or None
        The deformed volume (given, or ``m.warp(volume)``), None without either.

    Examples
    --------
    >>> z, y, x = np.mgrid[0:12, 0:12, 0:12]
    >>> volume = (100 + 80 * np.sin(x / 2.0) * np.cos(y / 3.0)).astype(np.uint8)
    >>> src = np.array([[2.0, 2, 2], [9, 2, 2], [2, 9, 2], [2, 2, 9], [9, 9, 9]])
    >>> dst = src + [1.0, 0, 0]
    >>> m = glmls.analysis.ReferenceDeformation(src, dst)
    >>> found = glmls.analysis.volume_report(volume, m, grid=3)
    >>> found.summary["volume"]["depth"], found.summary["jacobians"]["folds"]
    (12, 0)
    >>> found.to_json().splitlines()[:2]
    ['{', '  "volume": {']
    """

    summary: dict
    images: dict[str, np.ndarray]
    field: np.ndarray
    tetrahedra: TetrahedronErrors | None
    jacobians: CellJacobians
    deformed: np.ndarray | None = None

    to_json = SavedReport.to_json  # listed among this class's methods
    save = SavedReport.save


def _check_volume(volume: object, name: str) -> np.ndarray:
    if isinstance(volume, Volume):
        raise TypeError(
            f"{name} is a glmls.Volume: give its .data (and its spacing, spacing=volume.spacing, "
            "for handles in its physical units)"
        )
    array = np.asarray(volume)
    if array.ndim not in (3, 4) or 0 in array.shape or (array.ndim == 4 and array.shape[3] > 4):
        raise ValueError(f"{name} must be (D, H, W) or (D, H, W, C), got shape {array.shape}")
    if array.dtype.kind not in "biuf":
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    # NaN and infinite voxels of a float volume (outside a scan's field of view) are kept: the
    # analyses do not read the voxels, the pictures draw them apart, and the warp keeps them.
    # The pictures draw numbers and the GPU warps no bool: a mask is its 0/1 in float32, as
    # the other dtypes the GPU does not take are warped
    return array.astype(np.float32) if array.dtype.kind == "b" else array


def _shown(array: np.ndarray) -> np.ndarray:
    """A volume as the pictures draw it: grey (D, H, W), or uint8 RGB (D, H, W, 3)."""
    if array.ndim == 3:
        return array
    if array.shape[3] in (3, 4) and array.dtype == np.uint8:
        return array[..., :3]
    return array.mean(axis=3) if array.shape[3] > 1 else array[..., 0]


def _distinct(points: np.ndarray) -> np.ndarray:
    """The distinct rows of ``points``, in their order."""
    _, first = np.unique(points, axis=0, return_index=True)
    return points[np.sort(first)]


def _default_points(src: np.ndarray, tetrahedra: object) -> np.ndarray:
    """The reference points where none are given: the handles ``m.src`` as they are, which
    the user's ``tetrahedra`` index, else their distinct rows (Delaunay takes no point
    twice)."""
    return src if tetrahedra is not None else _distinct(src)


def _grey_limits(array: np.ndarray) -> tuple[float | None, float | None]:
    if array.ndim == 4 or array.dtype == np.uint8:
        return None, None
    return colormaps.color_limits(array)  # of the finite voxels


def volume_report(
    volume: object,
    m: Deformation3D,
    reference_points: object = None,
    *,
    grid: int = 1,
    jacobian_grid: int | None = None,
    tetrahedra: object = None,
    min_quality: float = SLIVER_QUALITY,
    angle: str = "degrees",
    eps: float = 1e-6,
    cmap: object = "viridis",
    percentile: float | None = None,
    slices: object = None,
    near: float | None = None,
    deformed: object = None,
    warp: bool = True,
    warp_options: VolumeOptions | None = None,
    spacing: object = None,
    out_dir: str | Path | None = None,
    on_stage: Callable[[str], None] | None = None,
) -> VolumeReport:
    """Analyse the deformation ``m`` of a volume as section 5 of the paper does an image's.

    Computes the MLS error field (eq. 7) over the volume and its statistics (eqs. 8, 9),
    the reference tetrahedra's distance and angular errors (:func:`tetrahedron_errors`),
    det J, the singular value ratio and the folds per cell (:func:`cell_jacobians`), and
    draws, each as three orthogonal slices and a projection
    (:func:`render_volume_slices`): ``input_handles`` (the volume, with the handles),
    ``deformed`` (the deformed volume, with the handles, where there is one),
    ``error_field``, ``jacobian_det`` (det J per cell, its projection the minimum) and
    ``folds`` (the folded cells in red over the volume), with a ``*_colorbar`` for each
    colour picture.

    Parameters
    ----------
    volume : array_like
        (D, H, W) or (D, H, W, C) real values (a bool mask as 0 and 1); NaN and infinite
        voxels (not all of them) are counted in the summary's ``volume`` and drawn apart
        (:func:`render_volume_slices`).
    m : glmls.MLS or ReferenceDeformation
        The deformation, of (N, 3) handles ``m.src`` -> ``m.dst``.
    reference_points : array_like, optional
        The points r of the tetrahedra, (N, 3); by default the distinct source handles
        (the tetrahedra are then left out where they form none), or, with ``tetrahedra``,
        the source handles ``m.src`` as they are, repeated ones included.
    grid : int, optional
        The error field at every voxel (1), or every ``grid`` voxels, interpolated.
    jacobian_grid : int, optional
        The step of the cells of det J and of the folds (default: ``grid``).
    tetrahedra : array_like, optional
        (T, 4) indices into the reference points (into ``m.src`` where none are given): the
        user's tetrahedra instead of Delaunay's.
    min_quality : float, optional
        The radius ratio below which a tetrahedron is a sliver (:func:`tetrahedron_errors`).
    angle : {"degrees", "paper"}, optional
        The tetrahedra's angular measure.
    eps : float, optional
        Eq. (11)'s epsilon.
    cmap : str or array_like, optional
        The colour map of the error and det J pictures.
    percentile : float, optional
        Robust upper bound of the error field's colour scale (None: the maximum).
    slices : tuple of int, optional
        (z, y, x) voxel indices of the pictures' slices (default: the centre).
    near : float, optional
        How far from a slice, in voxels, a handle is drawn on it.
    deformed : array_like, optional
        The deformed volume, when made elsewhere (the volume's (D, H, W)); else
        ``m.warp(volume)`` where ``m`` has a ``warp`` method (and ``warp`` is true), a
        volume of another real dtype than uint8, uint16, float32 and float64 (int16, bool,
        ...) warped as float32; else none.
    warp : bool, optional
        Whether to warp the volume with ``m.warp`` when no ``deformed`` is given.
    warp_options : glmls.volume.VolumeOptions, optional
        How the deformed volume is made: the options ``m.warp(volume)`` takes (default
        ``VolumeOptions()``: quads, nearest, grid 1, constant border), or, with ``deformed``,
        those it was made with; the summary's ``warp`` records them (null for a ``deformed``
        given without them). Its ``spacing`` is ``spacing``'s, its frame the volume's:
        another ``spacing``, ``output_shape`` or ``origin`` is a ValueError.
    spacing : (float, float, float), optional
        (dz, dy, dx) of the voxels, the handles and reference points in its units, as
        :meth:`glmls.MLS.warp` takes it: voxel (k, j, i) is the point (i dx, j dy, k dz).
        The error field (then in square handle units) and J are evaluated there, the
        volume warped with it and the pictures drawn in its proportions (default:
        ``m.spacing``, that of ``glmls.MLS(..., spacing=...)``, else 1 each, the handles in
        voxels; another than ``m.spacing`` is a ValueError).
    out_dir : str or pathlib.Path, optional
        Also write ``report.json`` and the PNGs there (:meth:`VolumeReport.save`).
    on_stage : callable, optional
        Called with each stage's name as it begins, for progress.

    Returns
    -------
    VolumeReport
        The summary, the pictures, the error field and the errors.

    Raises
    ------
    ValueError
        For a bad volume (or one of no finite voxel), grid, slices, angle measure,
        ``min_quality``, ``eps``, ``near``, reference points or tetrahedra, ``warp_options``
        that would not make the volume's frame, or a ``spacing`` of another length than 3,
        with a value that is not a finite number > 0, or other than ``m.spacing``.
    TypeError
        For an ``m`` without the handles ``m.src``, ``m.dst`` and the fits ``m.matrices``
        (a plain function of points, which :func:`cell_jacobians` and
        :func:`tetrahedron_errors` take), a ``warp`` that is not a bool, ``warp_options``
        that are no :class:`~glmls.volume.VolumeOptions`, a volume that is not real numbers,
        ``tetrahedra`` that are not integers, or a ``spacing`` that is not a sequence of real
        numbers.

    Examples
    --------
    >>> z, y, x = np.mgrid[0:12, 0:12, 0:12]
    >>> volume = (100 + 80 * np.sin(x / 2.0) * np.cos(y / 3.0)).astype(np.uint8)
    >>> src = np.array([[2.0, 2, 2], [9, 2, 2], [2, 9, 2], [2, 2, 9], [9, 9, 9]])
    >>> dst = src.copy()
    >>> dst[4] = [7.0, 7, 7]
    >>> m = glmls.analysis.ReferenceDeformation(src, dst)
    >>> found = glmls.analysis.volume_report(volume, m, grid=3)
    >>> sorted(found.images)[:3]
    ['error_field', 'error_field_colorbar', 'folds']
    >>> found.field.shape, found.summary["tetrahedra"]["tetrahedra"] > 0
    ((12, 12, 12), True)
    """
    warp = check_flag("warp", warp)
    check_handles3(m)  # the error field's need, before any work
    array = _check_volume(volume, "volume")
    if array.dtype.kind == "f" and not np.isfinite(array).any():
        raise ValueError("volume holds no finite value: every voxel is NaN or infinite")
    dims = array.shape[:3]
    step = check_grid3(grid)
    cell_step = step if jacobian_grid is None else check_grid3(jacobian_grid, "jacobian_grid")
    # checked now: a bad option must not pass for source handles that form no tetrahedron
    check_tetrahedron_options(min_quality, angle, eps)
    eps, min_quality = float(eps), float(min_quality)  # numbers now, as the summary holds them
    if percentile is not None:
        percentile = colormaps.check_percentile("percentile", percentile)
    if near is not None:
        near = check_real("near", near, low=0, what="a finite number >= 0 (voxels)")
    if not isinstance(warp, (bool, np.bool_)):
        raise TypeError(f"warp must be True or False, got {warp!r}")
    at = check_slices(dims, slices)
    given = None if deformed is None else _check_volume(deformed, "deformed")
    if given is not None and given.shape[:3] != dims:  # now, not after the analysis
        raise ValueError(
            f"deformed has shape {given.shape}; expected the volume's {dims} (D, H, W) "
            f"voxels: the pictures show both at the same slices"
        )
    src, dst = as_points3(m.src, "m.src"), as_points3(m.dst, "m.dst")
    spacing = deformation_spacing(m, spacing)
    scale = spacing_scale(spacing)
    made = _check_warp_options(warp_options, dims, scale)
    measured = volume_deformation(m, dims, spacing)  # f as m.warp(volume) has it
    clock = StageClock(on_stage)

    clock.begin("error field")
    field = volume_error_field(measured, dims, grid=step, spacing=spacing)
    clock.end("error_field")

    clock.begin("tetrahedra")
    found: TetrahedronErrors | None = None
    skipped = None
    try:
        found = tetrahedron_errors(
            measured,
            _default_points(src, tetrahedra) if reference_points is None else reference_points,
            tetrahedra=tetrahedra,
            min_quality=min_quality,
            angle=angle,
            eps=eps,
        )
    except ValueError as error:
        if reference_points is not None or tetrahedra is not None:  # the user's, not the handles'
            raise
        skipped = f"the source handles as reference points: {error}"
    clock.end("tetrahedron_errors")

    clock.begin("jacobians")
    cells = cell_jacobians(measured, dims, grid=cell_step, spacing=spacing)
    clock.end("jacobians")

    warped = None
    if given is not None:
        warped = given
    elif warp and callable(getattr(m, "warp", None)):
        clock.begin("warp")
        try:
            # only the options that differ from the defaults: any m.warp(volume) takes none
            plain = VolumeOptions()
            options = {
                f.name: getattr(made, f.name)
                for f in dataclasses.fields(made)
                if f.name != "spacing" and getattr(made, f.name) != getattr(plain, f.name)
            }
            if spacing is not None:
                options["spacing"] = tuple(scale[::-1])
            # int16, int64 ... warped as float32 (what the GPU warps: uint8, uint16, float32
            # and float64; a bool mask is float32 since _check_volume)
            takes = array.dtype in (np.uint8, np.uint16, np.float32, np.float64)
            source = array if takes else array.astype(np.float32)
            warped = _check_volume(m.warp(source, **options), "m.warp(volume)")  # type: ignore[attr-defined]
        except NotImplementedError:  # a deformation that cannot warp volumes
            warped = None
        clock.end("warp")

    clock.begin("pictures")
    shown = _shown(array)
    lo, hi = _grey_limits(shown)
    view = {"slices": at, "near": near, "spacing": tuple(scale[::-1].tolist())}  # true shape
    drawn = {"src": src / scale, "dst": dst / scale}  # the handles in voxels
    voxels = bool((scale == 1.0).all())  # E_MLS in square voxels, else square handle units
    images = {"input_handles": render_volume_slices(shown, vmin=lo, vmax=hi, **drawn, **view)}
    if warped is not None:
        images["deformed"] = render_volume_slices(_shown(warped), vmin=lo, vmax=hi, **drawn, **view)
    unit = float(scale.min())  # E_MLS in square handle units where those are not voxels
    f_lo, f_hi = colormaps.picture_limits("E_MLS", field, percentile=percentile, unit=unit)
    images["error_field"] = render_volume_slices(
        field, cmap=cmap, vmin=f_lo, vmax=f_hi, **drawn, **view
    )
    images["error_field_colorbar"] = colormaps.colorbar(
        cmap, f_lo, f_hi, length=256, label=f"E_MLS ({'voxel' if voxels else 'unit'}^2)"
    )
    index = np.ix_(*(np.arange(n) // cell_step for n in dims))
    det = cells.det[index]
    d_lo, d_hi = colormaps.picture_limits("det_j", det)
    images["jacobian_det"] = render_volume_slices(
        det, cmap=cmap, vmin=d_lo, vmax=d_hi, projection="min", **view
    )
    images["jacobian_det_colorbar"] = colormaps.colorbar(
        cmap, d_lo, d_hi, length=256, label="det J"
    )
    images["folds"] = render_volume_slices(shown, mask=cells.mask, vmin=lo, vmax=hi, **view)
    clock.end("render")
    clock.finish()

    config = getattr(m, "config", None)
    summary: dict[str, object] = {
        "volume": {
            "depth": dims[0],
            "height": dims[1],
            "width": dims[2],
            "channels": 1 if array.ndim == 3 else array.shape[3],
            "nan_voxels": int(np.isnan(array).sum()) if array.dtype.kind == "f" else 0,
            "infinite_voxels": int(np.isinf(array).sum()) if array.dtype.kind == "f" else 0,
        },
        "configuration": (dataclasses.asdict(config) if dataclasses.is_dataclass(config) else {})
        | {
            "radius_used": _radius_used(config, dims, tuple(scale[::-1].tolist())),
            "handles": len(src),
            "src": src.tolist(),
            "dst": dst.tolist(),
        },
        "analysis": {
            "grid": step,
            "jacobian_grid": cell_step,
            "angle": angle,
            "eps": eps,
            "min_quality": min_quality,
            "reference_points": "handles" if reference_points is None else "given",
            "spacing": scale[::-1].tolist(),
            "cmap": cmap_name(cmap),
            "percentile": percentile,
            "slices": {"z": at[0], "y": at[1], "x": at[2]},
            "error_field_limits": [f_lo, f_hi],
            "det_limits": [d_lo, d_hi],
        },
        "timings_s": clock.timings,
        # E_MLS is a squared distance in the handles' units: voxels where a voxel is 1 x 1 x 1
        "error_field": error_stats(field) | {"unit": "voxel^2" if voxels else "(handle units)^2"},
        "tetrahedra": found.stats() if found is not None else {"skipped": skipped},
        "jacobians": cells.stats(),
        "deformed": warped is not None,
        # how deformed.png was made: unknown for a deformed volume given without its options
        "warp": (
            None
            if warped is None or (given is not None and warp_options is None)
            else _warp_settings(made, dims, scale)
        ),
    }
    gl_renderer = renderer(m)
    if gl_renderer is not None:
        summary["gl_renderer"] = gl_renderer
    result = VolumeReport(summary, images, field, found, cells, warped)
    if out_dir is not None:
        result.save(out_dir)
    return result


def _check_warp_options(
    options: object, dims: tuple[int, int, int], scale: np.ndarray
) -> VolumeOptions:
    """``options`` (None: the defaults) if they make a volume in the analysed volume's frame
    and spacing, where the pictures show it: ``ValueError`` naming the field that does not,
    ``TypeError`` for another type than :class:`VolumeOptions`."""
    if options is not None and not isinstance(options, VolumeOptions):
        raise TypeError(
            f"warp_options must be a glmls.volume.VolumeOptions, got {type(options).__name__}"
        )
    options = VolumeOptions() if options is None else options
    steps = tuple(scale[::-1].tolist())
    for name, value, frame in (
        ("output_shape", options.output_shape, tuple(dims)),
        ("origin", options.origin, (0.0, 0.0, 0.0)),
        ("spacing", options.spacing, steps),
    ):
        if value is not None and tuple(value) != frame:
            raise ValueError(
                f"warp_options.{name} is {tuple(value)}; the report's deformed volume is drawn "
                f"in the volume's frame, {name} {frame} (or None)"
            )
    return options


def _warp_settings(
    options: VolumeOptions, dims: tuple[int, int, int], scale: np.ndarray
) -> dict[str, object]:
    """The summary's ``warp``: every option that shaped the deformed volume, as used."""
    background = options.background
    return {
        "method": options.method,
        "interpolation": options.interpolation,
        "grid": options.lattice_step,
        "border": options.border,
        "background": list(background) if isinstance(background, tuple) else background,
        "output_shape": list(dims),
        "origin": [0.0, 0.0, 0.0],
        "spacing": scale[::-1].tolist(),
    }


def _radius_used(config: object, dims: tuple[int, int, int], spacing: object) -> float | None:
    """The radius the analysis evaluated with (handle units): the configured one, else a
    radius weight's default, the diagonal of the analysed volume at ``spacing`` (dz, dy, dx;
    None: voxels); None for a weight without a radius."""
    if not isinstance(config, MLSConfig) or not config.uses_radius or config.radius is not None:
        return getattr(config, "radius", None)
    return volume_diagonal(dims, spacing)  # type: ignore[arg-type]
