"""``glmls analyze`` on a volume (a ``.npy``, NIfTI or TIFF-stack input) with 3D handles: the
3D analysis of :func:`glmls.analysis.volume_report` on the GPU (:class:`glmls.MLS` of (N, 3)
handles), written as ``report.json`` and PNGs. The voxel spacing is ``glmls warp``'s
(``--spacing``, else the file's): the handles are in its units, and the volume is warped,
and f evaluated, where ``glmls warp`` puts its voxels."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..analysis.tetrahedra import SLIVER_QUALITY, delaunay3, tetrahedron_quality
from ..analysis.volume_reporting import VOLUME_PICTURES, volume_report
from ..core.config import MLSConfig
from ..core.handles3 import as_points3
from ..files.parsing import csv_rows, fail, json_list, load_json, number, table
from ..files.volumes import is_volume_file, read_volume
from ..mls import MLS
from ..volume import VolumeOptions
from .inputs import figure, keep_inputs, report_paths, reported_warnings, say
from .options import UsageError, config_from_args
from .progress import Ticker
from .warp3d import (
    check_world,
    read_3d_handles,
    refuse_image_options,
    volume_handle_warnings,
    voxel_handles,
    warpable,
    world_handles,
)

__all__ = [
    "check_reference_3d",
    "is_volume_input",
    "read_reference_3d",
    "run_volume",
]


def is_volume_input(args: argparse.Namespace) -> bool:
    """Whether ``analyze``'s input is a volume (by its suffix; a TIFF by its pages)."""
    return not args.example and args.input is not None and is_volume_file(args.input)


def read_reference_3d(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Reference points (K, 3) from JSON ``{"points": [[x, y, z], ...]}`` or a CSV with the
    header ``x,y,z``, and the user's own reference tetrahedra (T, 4), indices into them, from
    the key ``"tetrahedra"`` of a JSON file (None where it has none, or for a CSV: the
    points' Delaunay tetrahedra are measured); ``InputFileError`` naming the place of a
    fault."""
    path = Path(path)
    tetrahedra = None
    if path.suffix.lower() == ".json":
        data = load_json(path)
        if "points" not in data:
            raise fail(path, "top level", 'missing the key "points"')
        rows = json_list(path, '"points"', data["points"], "[x, y, z] points")
        values = []
        for index, row in enumerate(rows):
            where = f'"points"[{index}]'
            if not isinstance(row, list) or len(row) != 3:
                raise fail(path, where, "expected an [x, y, z] point")
            values.append([number(path, where, v) for v in row])
        points = np.array(values, dtype=np.float64).reshape(-1, 3)
        if "tetrahedra" in data:
            tetrahedra = _tetrahedra(path, data["tetrahedra"], len(points))
    else:
        rows = csv_rows(path)
        if not rows:
            raise fail(path, "content", "no points")
        line, header = rows[0]
        if [h.lower() for h in header] != ["x", "y", "z"]:
            raise fail(path, f"line {line}", f"expected the header x,y,z, got {','.join(header)}")
        points = table(path, rows[1:], 3)
    if len(points) == 0:
        raise fail(path, "content", "no points")
    return points, tetrahedra


def _tetrahedra(path: Path, value: object, count: int) -> np.ndarray:
    """A reference file's ``"tetrahedra"``: (T, 4) indices into its ``count`` points."""
    rows = json_list(path, '"tetrahedra"', value, "[i, j, k, l] tetrahedra")
    for index, row in enumerate(rows):
        if not (isinstance(row, list) and len(row) == 4) or not all(
            type(v) is int and 0 <= v < count for v in row
        ):
            raise fail(
                path,
                f'"tetrahedra"[{index}]',
                f"expected 4 point indices, integers in 0..{count - 1}, got {row!r}",
            )
        if len(set(row)) != 4:  # no volume: the analysis would refuse it without the file
            raise fail(path, f'"tetrahedra"[{index}]', f"{row!r} repeats a vertex")
    if not rows:
        raise fail(path, '"tetrahedra"', "no tetrahedron")
    return np.array(rows, dtype=np.int64)


def check_reference_3d(
    path: str | Path, points: np.ndarray | None, tetrahedra: np.ndarray | None = None
) -> None:
    """:class:`UsageError` naming ``path`` for reference points (K, 3) that make no
    tetrahedra (too few, repeated, on one plane, or every Delaunay tetrahedron a sliver,
    which the analysis leaves out) or lie beyond glmls's coordinate range; before any work
    is started."""
    if points is None:
        return
    try:
        # the range first: delaunay3 tests it after the plane, and one far point makes the
        # others look flat
        as_points3(points, "reference_points")
        if tetrahedra is not None:  # the user's own: the analysis counts their slivers
            return
        r, simplices = delaunay3(points)
    except ValueError as error:
        raise UsageError(f"{path}: {error}") from None
    quality = tetrahedron_quality(r[simplices])
    if not (quality >= SLIVER_QUALITY).any():  # the command line has no min_quality to lower
        count = len(simplices)
        raise UsageError(
            f"{path}: no tetrahedron to measure: the {count} Delaunay "
            f"{'tetrahedron is a sliver' if count == 1 else 'tetrahedra are all slivers'} "
            f"(radius ratio 3 r / R at most {float(quality.max()):.3g}, below "
            f"{SLIVER_QUALITY}: the points lie near a plane); spread the reference points"
        )


def _deformation(src: np.ndarray, dst: np.ndarray, config: MLSConfig, shape, spacing) -> MLS:
    """glmls.MLS of the 3D handles (on the GPU) with the volume's ``shape`` and ``spacing``: a
    radius weight's default radius is the volume's diagonal in the handles' units, for the
    analysis and the warp alike; :class:`UsageError` if it cannot take them."""
    try:
        return MLS.from_config(src, dst, config, shape=shape, spacing=spacing)
    except (TypeError, ValueError) as error:
        raise UsageError(f"handles: {error}") from None


def _warped(
    m: object, volume: np.ndarray, args: argparse.Namespace, made: VolumeOptions, spacing
) -> np.ndarray | None:
    warp = getattr(m, "warp", None)
    if not callable(warp):
        say(args, "analyze: no deformed volume: this deformation cannot warp volumes")
        return None
    options: dict[str, object] = {
        "method": made.method,
        "interpolation": made.interpolation,
        "border": made.border,
        "grid": made.grid,
    }
    if spacing is not None:
        options["spacing"] = spacing
    try:
        return np.asarray(warp(volume, **options))
    except (TypeError, ValueError, NotImplementedError) as error:
        say(args, f"analyze: no deformed volume: {error}")
        return None


def run_volume(args: argparse.Namespace) -> int:
    """``glmls analyze VOLUME --handles H3 --out DIR``."""
    if args.handles is None:
        raise UsageError("missing --handles (a file of 3D handles for a volume)")
    check_world(args)
    refuse_image_options(args, "volume")
    config = config_from_args(args)
    try:  # the warp's options, before any work: a volume takes fewer methods than an image
        made = VolumeOptions(
            method=args.method,
            interpolation=args.interpolation,
            border=args.border,
            grid=args.grid,
        )
    except (TypeError, ValueError) as error:
        raise UsageError(f"{args.input}: {error}") from None
    source = read_volume(args.input)
    time = source.nifti is not None and source.nifti.time_step is not None
    # as glmls warp does: a mask as float32
    volume = warpable(source.data, args.input, time=time)
    if volume.dtype.kind == "f" and not np.isfinite(volume).any():  # before any work
        raise UsageError(f"{args.input}: no finite voxel: every voxel is NaN or infinite")
    spacing = args.spacing or source.spacing
    src, dst = voxel_handles(args, *read_3d_handles(args, "volume"), spacing)
    reference, tetrahedra = read_reference_3d(args.reference) if args.reference else (None, None)
    src, dst, reference = world_handles(args, source, spacing, src, dst, reference)
    check_reference_3d(args.reference, reference, tetrahedra)
    for message in volume_handle_warnings(args, src, volume.shape, spacing, source.affine):
        say(args, f"glmls analyze: warning: {args.input}: {message}")
    if reference is None:
        say(args, "analyze: no --reference given: the source handles are the reference points")
    keep_inputs(args, report_paths(args.out, VOLUME_PICTURES))  # before any work
    ticker = Ticker("analyze", quiet=args.quiet)
    m = _deformation(src, dst, config, volume.shape[:3], spacing)
    with m, ticker as tick, reported_warnings("analyze"):
        try:
            tick.stage("warp")
            deformed = _warped(m, volume, args, made, spacing)
            result = volume_report(
                volume,
                m,
                reference,
                tetrahedra=tetrahedra,
                grid=args.analysis_grid,
                angle=args.angle,
                cmap=args.cmap,
                deformed=deformed,
                warp=False,
                warp_options=made,  # for report.json's "warp": how deformed.png was made
                spacing=spacing,
                on_stage=tick.stage,
            )
        except (TypeError, ValueError) as error:
            raise UsageError(str(error)) from None
    result.summary["input"] = str(args.input)
    for path in result.save(args.out):
        print(path)
    summary = result.summary
    field, cells, tetrahedra = summary["error_field"], summary["jacobians"], summary["tetrahedra"]
    unit = field["unit"]
    say(
        args,
        f"analyze: E_MLS median {figure(field['median'])} {unit}, trimmed mean "
        f"{figure(field['trimmed_mean'])}, mean {figure(field['mean'])} "
        f"(std {figure(field['std'])})",
    )
    if "angle" in tetrahedra:
        angle = tetrahedra["angle"]
        say(
            args,
            f"analyze: {tetrahedra['tetrahedra']} tetrahedra ({tetrahedra['slivers']} slivers "
            f"left out), angular error ({args.angle}) median {figure(angle['median'])}, "
            f"mean {figure(angle['mean'])}; {tetrahedra['inverted']} inverted",
        )
    else:
        say(args, f"analyze: no tetrahedra: {tetrahedra['skipped']}")
    say(
        args,
        f"analyze: det J median {figure(cells['det']['median'])}, min "
        f"{figure(cells['det']['min'])}; folds {cells['folds']} of {cells['cells']} cells "
        f"(grid {cells['grid']})",
    )
    return 0
