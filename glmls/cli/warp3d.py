"""``glmls warp`` on a volume or a mesh: 3D point handles, one input file, the output in the
format of its suffix.

- A volume (NIfTI, a TIFF of more than one page, ``.npy``) is warped by
  :meth:`glmls.MLS.warp` with the voxel spacing of ``--spacing``, else of the file (a NIfTI's
  affine, a TIFF stack's spacing); the output keeps the input's dtype (integers rounded
  and clipped) and, written as NIfTI, the input's affine. The MLS is made with the volume's
  ``shape`` and ``spacing``, so a radius weight without ``--radius`` takes the volume's
  diagonal in the handles' units (those of the spacing); an elastix pair
  of ``index`` files (voxel indices) is put there by the spacing. With ``--world`` (NIfTI
  only) the handles are world coordinates of the file's affine, mapped through its inverse
  to the voxels times the spacing (:func:`glmls.files.world_to_volume`): nibabel's RAS+,
  and for an elastix pair of ``point`` files ITK's LPS (x and y negated).
- A mesh (PLY, OBJ, STL) is deformed by :meth:`glmls.MLS.deform`; the output has the
  deformed vertices and the input's triangles, and stderr says how many vertices and faces
  fold over. A radius weight needs ``--radius`` there; an elastix pair of ``index`` files is
  refused (voxel indices, and a mesh has no voxels).
"""

from __future__ import annotations

import argparse
import dataclasses
import glob
import os
from pathlib import Path

import numpy as np

from ..core.config import MLSConfig
from ..core.handles3 import as_volume_spacing
from ..files.images import DEFAULT_MAX_PIXELS
from ..files.landmarks import elastix_indices, elastix_physical, handle_dimension, read_handles
from ..files.meshes import MESH_SUFFIXES, read_mesh_and_unkept, unwritten, write_mesh
from ..files.volume_dtypes import check_file_background, in_dtype, warped_as
from ..files.volumes import (
    VOLUME_SUFFIXES,
    Volume,
    flat_npy,
    is_volume_file,
    read_volume,
    volume_suffix,
    world_to_volume,
    write_volume,
)
from ..mls import MLS
from .inputs import one_cell_warning, reported_warnings, say
from .options import UsageError, below_a_file, config_from_args, refuse_overwriting
from .progress import Ticker

__all__ = [
    "add_3d_options",
    "check_world",
    "image_options_given",
    "input_kind",
    "parse_spacing",
    "read_3d_handles",
    "refuse_image_options",
    "refuse_sampling_options",
    "run_3d",
    "spacing_text",
    "volume_handle_warnings",
    "voxel_handles",
    "warpable",
    "world_handles",
]


def warpable(data: np.ndarray, name: object, *, time: bool = False) -> np.ndarray:
    """A volume in a dtype the GPU warps: uint8, uint16 and float32 as they are, the other
    real ones (bool, int16, int64, float64, ...) as float32; :class:`UsageError` naming
    ``name`` for others (complex numbers, objects, strings), for values float32 would change
    (:func:`~glmls.files.volume_dtypes.warped_as`), and for more than 4 channels (``time``:
    the channels are a NIfTI time series's time points)."""
    if data.dtype.kind not in "biuf":
        raise UsageError(
            f"{name}: a volume of {data.dtype} values; glmls warps real numbers (bool, "
            "integers, floats)"
        )
    if data.ndim == 4 and data.shape[3] > 4 and time:
        raise UsageError(
            f"{name}: a time series of {data.shape[3]} time points (NIfTI's 4th axis); glmls "
            "warps them as channels, 1 to 4 at a time (split the series into parts of 4 or "
            "fewer time points)"
        )
    if data.ndim == 4 and data.shape[3] > 4:  # before the handles' warnings: one line
        raise UsageError(
            f"{name}: a volume of {data.shape[3]} channels; glmls warps 1 to 4 at a time "
            "(warp the channels in groups of 4 or fewer)"
        )
    try:
        return warped_as(data, name)
    except ValueError as error:  # a value float32 would not hold
        raise UsageError(str(error)) from None


def parse_spacing(text: str) -> tuple[float, float, float]:
    """``DZ,DY,DX`` (three finite numbers > 0, checked by
    :func:`~glmls.core.handles3.as_volume_spacing`), or one number for all three."""
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected DZ,DY,DX numbers, got {text!r}") from None
    try:
        return as_volume_spacing(values * 3 if len(values) == 1 else values)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


TARGETS_HELP = (
    "the targets' elastix point file (.pts; elastix's fixed points), where --handles names the "
    "sources' (the moving points)"
)


def add_3d_options(parser: argparse.ArgumentParser) -> None:
    """``--targets`` (an elastix pair) and ``--spacing`` (volumes)."""
    group = parser.add_argument_group("volumes and meshes")
    group.add_argument("--targets", metavar="DST", help=TARGETS_HELP)
    group.add_argument(
        "--world",
        action="store_true",
        help="the handles (and reference points) are world coordinates of a NIfTI volume's "
        "affine (nibabel's, RAS+; an elastix pair of 'point' files: ITK's, LPS): mapped "
        "through its inverse to the voxels times the spacing",
    )
    group.add_argument(
        "--spacing",
        type=parse_spacing,
        metavar="DZ,DY,DX",
        help="a volume's voxel size along z, y and x, or one number for all three (default: "
        "the file's: a NIfTI's affine, a TIFF stack's spacing (ImageJ's, OME's or glmls's); "
        "else 1)",
    )


def input_kind(pattern: str) -> str:
    """``"volume"``, ``"mesh"`` or ``"image"`` (images, folders and globs) for ``IN``."""
    if glob.has_magic(str(pattern)) and not Path(pattern).exists():
        return "image"  # a glob, even of volumes' names: images one by one (or refused so)
    suffix = volume_suffix(pattern)
    if suffix in MESH_SUFFIXES:
        return "mesh"
    if suffix in (".nii", ".nii.gz", ".npy"):
        return "volume"
    if suffix in (".tif", ".tiff") and Path(pattern).is_file():
        return "volume" if is_volume_file(pattern) else "image"
    return "image"


def _target(args: argparse.Namespace, kind: str) -> Path:
    """OUT, or OUT/IN's name where OUT is a folder; its suffix checked before any work."""
    source, out = Path(args.input), Path(args.output)
    if out.is_dir() or args.output.endswith(("/", os.sep)):
        out = out / source.name
    suffixes = VOLUME_SUFFIXES if kind == "volume" else MESH_SUFFIXES
    if volume_suffix(out) not in suffixes:
        suffix = volume_suffix(out) or "(no suffix)"
        raise UsageError(f"{out}: a {kind} is written as {', '.join(suffixes)}, not {suffix}")
    return out


def read_3d_handles(args: argparse.Namespace, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """The 3D handles of ``--handles`` (and ``--targets``) for ``IN``, a volume or a mesh;
    :class:`UsageError` naming both for a file of 2D handles."""
    ndim = handle_dimension(args.handles, dst=args.targets)
    flat = flat_npy(args.input) if kind == "volume" and ndim != 3 else None
    if flat is not None:
        raise UsageError(flat)
    if ndim != 3:
        raise UsageError(
            f"{args.handles}: 2D handles (x, y), but {args.input} is a {kind}: it takes 3D "
            "handles (x, y, z)"
        )
    if kind == "mesh" and elastix_indices(args.handles, dst=args.targets):
        # only a volume's spacing turns an index into a place: a mesh has no voxels
        raise UsageError(
            f"{args.handles}: elastix voxel indices ('index'), but {args.input} is a mesh, "
            "which has no voxels to put them at: give 'point' files in the mesh's coordinates"
        )
    return read_handles(args.handles, dst=args.targets, ndim=3)


def check_world(args: argparse.Namespace, source: Path | None = None) -> None:
    """``--world`` only with a NIfTI volume (the file whose affine defines the world:
    ``source``, else ``IN``), and not with an elastix pair of voxel indices;
    :class:`UsageError` otherwise."""
    if not getattr(args, "world", False):
        return
    name = source or args.input or "the example"
    if volume_suffix(name) not in (".nii", ".nii.gz"):
        raise UsageError(
            f"--world: {name} has no affine to map world coordinates by (only NIfTI volumes, "
            ".nii and .nii.gz, have one); give the handles in "
            + {"volume": "voxels times the spacing", "mesh": "the mesh's own coordinates"}.get(
                input_kind(name), "pixels"
            )
        )
    if elastix_indices(args.handles, dst=args.targets):
        raise UsageError(
            f"--world: {args.handles} holds elastix voxel indices ('index'), not world "
            "coordinates ('point')"
        )


def world_handles(
    args: argparse.Namespace, volume: Volume, spacing, src, dst, *points, source=None
):
    """The handles ``src``, ``dst`` and other ``points`` (each (N, 3), or None) as they are,
    or with ``--world`` mapped from world coordinates through the inverse of the volume's
    affine to (i dx, j dy, k dz) of ``spacing`` (:func:`glmls.files.world_to_volume`): RAS+
    (nibabel's), except the handles of an elastix pair of ``point`` files, which are ITK's
    physical points, LPS (x and y negated). ``source``: the volume's file (``IN`` by
    default)."""
    if not getattr(args, "world", False):
        return (src, dst, *points)
    source = source or args.input
    check_world(args, source)
    if volume.affine is None:  # a NIfTI file always has one: checked all the same
        raise UsageError(f"--world: {source} has no affine")
    lps = elastix_physical(args.handles, dst=args.targets)
    try:
        return tuple(
            None if p is None else world_to_volume(p, volume.affine, spacing=spacing, lps=lps)
            for p in (src, dst)
        ) + tuple(
            None if p is None else world_to_volume(p, volume.affine, spacing=spacing)
            for p in points
        )
    except ValueError as error:
        raise UsageError(f"--world: {source}: {error}") from None


def _inside(points: np.ndarray, shape, scale: np.ndarray) -> np.ndarray:
    """Which (x, y, z) points lie in the box of the voxels of ``shape`` (D, H, W), each voxel
    (i, j, k) at (i, j, k) times ``scale`` (dx, dy, dz)."""
    size = np.array(shape[:3][::-1], dtype=np.float64)
    low, high = -0.5 * scale, (size - 0.5) * scale
    return ((points >= low) & (points <= high)).all(axis=1)


def volume_handle_warnings(args: argparse.Namespace, src, shape, spacing, affine) -> list[str]:
    """Warnings for source handles of which more than half lie outside the volume, in the
    frame of the warp (voxel (k, j, i) at (i dx, j dy, k dz)), with a hint where another
    convention would put most of them inside: voxel indices given with a spacing other than
    1, or world coordinates of a NIfTI affine given without ``--world``."""
    points = np.asarray(src, dtype=np.float64)
    scale = np.ones(3) if spacing is None else np.array(spacing[::-1], dtype=np.float64)
    inside = _inside(points, shape, scale)
    sheared = _shear_warning(args, affine) + _stretch_warning(args, affine, spacing)
    if not len(points) or inside.mean() >= 0.5:
        return sheared
    depth, height, width = shape[:3]
    units = "" if spacing is None else f" of spacing (dz, dy, dx) = {spacing_text(spacing)}"
    hint = ""
    if getattr(args, "world", False):
        hint = (
            "; --world took them as world coordinates (RAS+) of the file's affine: ITK's LPS "
            "(elastix) has x and y of the opposite signs"
        )
        if elastix_physical(args.handles, dst=args.targets):
            hint = (
                "; --world took them as world coordinates of the file's affine in ITK's LPS "
                "(elastix's 'point' files), x and y the negated RAS+ ones"
            )
    elif not np.allclose(scale, 1.0) and _inside(points, shape, np.ones(3)).mean() > 0.5:
        hint = (
            "; in voxel indices? the handles are in the units of the spacing, voxel "
            "(i, j, k) at (i dx, j dy, k dz)"
        )
    elif affine is not None:
        lps = elastix_physical(args.handles, dst=args.targets)  # ITK's world, as --world
        voxels = world_to_volume(points, affine, spacing=(1.0, 1.0, 1.0), lps=lps)
        if _inside(voxels, shape, np.ones(3)).mean() > 0.5:
            hint = "; world coordinates of the file's affine? add --world"
    return [
        f"{int((~inside).sum())} of {len(points)} handles lie outside the {width} x {height} "
        f"x {depth} volume{units}{hint}",
        *sheared,
    ]


def _shear_warning(args: argparse.Namespace, affine) -> list[str]:
    """With ``--world``, the warning for an affine whose columns are not orthogonal: the
    warp's frame is then a shear of the world, in which distances and angles differ from the
    world's, so that a rigid or similarity fit is rigid in the frame, not in the world."""
    if not getattr(args, "world", False) or affine is None:
        return []
    columns = np.asarray(affine, dtype=np.float64)[:3, :3]
    units = columns / np.linalg.norm(columns, axis=0)
    lean = np.abs(units.T @ units - np.eye(3)).max()  # cosines between the voxel axes
    if lean <= 1e-4:
        return []
    return [
        f"--world: the affine is sheared (its voxel axes {np.degrees(np.arcsin(lean)):.3g} "
        "degrees off square): the warp works in (i dx, j dy, k dz), the world sheared, where "
        "distances differ from the world's and a rigid or similarity fit is rigid in that "
        "frame, not in the world"
    ]


def _stretch_warning(args: argparse.Namespace, affine, spacing) -> list[str]:
    """With ``--world``, the warning for a spacing (``--spacing``) out of proportion with the
    affine's voxel sizes (the lengths of its columns): the warp's frame is then the world
    stretched more along some axes than others, as a sheared one (a spacing in proportion,
    in other units, only scales it)."""
    if not getattr(args, "world", False) or affine is None or spacing is None:
        return []
    sizes = np.linalg.norm(np.asarray(affine, dtype=np.float64)[:3, :3], axis=0)[::-1]
    ratios = np.asarray(spacing, dtype=np.float64) / sizes
    if ratios.max() <= ratios.min() * (1 + 1e-4):
        return []
    return [
        f"--world: the spacing (dz, dy, dx) = {spacing_text(spacing)} is out of proportion "
        f"with the affine's voxel sizes {spacing_text(sizes)}: the warp works in "
        "(i dx, j dy, k dz), the world stretched unevenly, where distances differ from the "
        "world's and a rigid or similarity fit is rigid in that frame, not in the world"
    ]


def voxel_handles(args: argparse.Namespace, src, dst, spacing):
    """(src, dst) in the handles' units: an elastix pair of ``index`` files (voxel indices)
    times the spacing, (i dx, j dy, k dz); other handles as they are."""
    if spacing is None or not elastix_indices(args.handles, dst=args.targets):
        return src, dst
    scale = np.array(spacing[::-1], dtype=np.float64)
    return src * scale, dst * scale


def _mls(src: np.ndarray, dst: np.ndarray, config: MLSConfig, **volume: object) -> MLS:
    """glmls.MLS of ``config``; ``volume``: a volume's ``shape`` and ``spacing``, whose
    diagonal in the handles' units is a radius weight's default radius (the image
    diagonal's counterpart)."""
    settings = {f.name: getattr(config, f.name) for f in dataclasses.fields(MLSConfig)}
    try:
        return MLS(src, dst, **settings, **volume)
    except (TypeError, ValueError) as error:
        raise UsageError(f"handles: {error}") from None


def image_options_given(args: argparse.Namespace) -> list[str]:
    """Those of ``--fit``, ``--tolerance`` (the image construction's), ``--keep-going``,
    ``--jobs`` and ``--scheduler`` (a batch of images') and ``--max-pixels`` (an image
    file's bound) given, which a volume or mesh refuses; a command without one of them has
    it not given."""
    given = (
        ("--max-pixels", getattr(args, "max_pixels", DEFAULT_MAX_PIXELS) != DEFAULT_MAX_PIXELS),
        ("--fit", getattr(args, "fit", False)),
        ("--tolerance", getattr(args, "tolerance", None) is not None),
        ("--keep-going", getattr(args, "keep_going", False)),
        ("--jobs", getattr(args, "jobs", 1) != 1),
        ("--scheduler", getattr(args, "scheduler", None) is not None),
    )
    return [option for option, value in given if value]


def refuse_image_options(args: argparse.Namespace, kind: str) -> None:
    """:class:`UsageError` for an option of :func:`image_options_given` on a ``kind``
    ("volume", "mesh") of ``args.input``."""
    given = image_options_given(args)
    if given:
        raise UsageError(f"{', '.join(given)}: for images, not for a {kind} ({args.input})")


def _refuse_other_options(args: argparse.Namespace, kind: str) -> None:
    refuse_image_options(args, kind)
    if kind != "mesh":
        return
    if args.spacing is not None:
        raise UsageError(f"--spacing: for volumes, not for a mesh ({args.input})")
    refuse_sampling_options(args)


def refuse_sampling_options(
    args: argparse.Namespace, others: tuple[tuple[str, object, object], ...] = ()
) -> None:
    """:class:`UsageError` naming the options of sampling a picture given for a mesh, whose
    vertices f moves itself (``others``: more (option, value, default) of the command)."""
    sampling = [
        option
        for option, value, default in (
            ("--background", getattr(args, "background", 0.0), 0.0),
            ("--method", args.method, "quads"),
            ("--interpolation", args.interpolation, "nearest"),
            ("--border", args.border, "constant"),
            ("--grid", args.grid, None),
            *others,
        )
        if value != default
    ]
    if sampling:
        raise UsageError(
            f"{', '.join(sampling)}: for images and volumes, not for a mesh ({args.input}), "
            "whose vertices f moves itself"
        )


def run_3d(args: argparse.Namespace, kind: str) -> int:
    """``glmls warp`` on one volume or mesh."""
    _refuse_other_options(args, kind)
    check_world(args)
    config = config_from_args(args)
    target = _target(args, kind)
    fault = below_a_file(target, itself=False)  # now, not after the warp
    if fault is not None:
        raise UsageError(fault)
    read = {Path(args.input): f"the input {kind}", Path(args.handles): "the --handles file"}
    if args.targets is not None:
        read.setdefault(Path(args.targets), "the --targets file")
    refuse_overwriting([target], read)
    src, dst = read_3d_handles(args, kind)
    if kind == "volume":
        _warp_volume(args, config, src, dst, target)
    else:
        _deform_mesh(args, config, src, dst, target)
    print(target, flush=True)
    return 0


def _volume_options(args: argparse.Namespace, spacing) -> dict:
    options: dict = {
        "method": args.method,
        "interpolation": args.interpolation,
        "border": args.border,
        "grid": args.grid,
        "background": args.background,
    }
    if spacing is not None:
        options["spacing"] = spacing
    return options


def _warp_volume(args, config: MLSConfig, src, dst, target: Path) -> None:
    volume = read_volume(args.input)
    spacing = args.spacing or volume.spacing
    dtype = volume.data.dtype
    time = volume.nifti is not None and volume.nifti.time_step is not None
    data = warpable(volume.data, args.input, time=time)
    if volume_suffix(target) in (".tif", ".tiff") and data.shape[0] == 1:
        raise UsageError(
            f"{target}: a volume of one slice would be a TIFF of one page, which reads back "
            "as an image; write it as .nii, .nii.gz or .npy"
        )
    options = _volume_options(args, spacing)
    try:  # that of the file's dtype, which the float32 warp of an int16 volume cannot check
        check_file_background(args.background, dtype, args.input)
    except ValueError as error:
        raise UsageError(str(error)) from None
    src, dst = voxel_handles(args, src, dst, spacing)
    src, dst = world_handles(args, volume, spacing, src, dst)
    messages = volume_handle_warnings(args, src, data.shape, spacing, volume.affine)
    one_cell = one_cell_warning(getattr(args, "grid", 1), data.shape[:3])
    if args.method == "quads" and one_cell is not None:
        messages.append(one_cell)
    for message in messages:
        say(args, f"glmls warp: warning: {args.input}: {message}")
    with _mls(src, dst, config, shape=data.shape[:3], spacing=spacing) as m:
        ticker = Ticker(f"warp {args.input}", quiet=args.quiet)
        with ticker, reported_warnings(f"glmls warp: {args.input}"):
            try:
                result = np.asarray(m.warp(data, **options))
            except (TypeError, ValueError, NotImplementedError) as error:
                raise UsageError(f"{args.input}: {error}") from None
    result = in_dtype(result, dtype)
    depth, height, width = result.shape[:3]
    where = "" if spacing is None else f", spacing (dz, dy, dx) = {spacing_text(spacing)}"
    say(args, f"warp: volume {width} x {height} x {depth} voxels (x, y, z){where}")
    affine = volume.affine if volume_suffix(target) in (".nii", ".nii.gz") else None
    write_volume(target, Volume(result, spacing=spacing, affine=affine, nifti=volume.nifti))


def spacing_text(spacing) -> str:
    """``(dz, dy, dx)`` for a message, each to 7 significant digits: a NIfTI header holds its
    affine in float32, whose 0.8 reads back as 0.800000011920929."""
    return "(" + ", ".join(repr(float(f"{float(v):.7g}")) for v in spacing) + ")"


def _count(folds: object) -> int:
    """A fold count from a count, a mask or a list of indices."""
    array = np.asarray(folds)
    if array.ndim == 0:
        return int(array)
    return int(array.sum()) if array.dtype == np.bool_ else len(array)


def _deform_mesh(args, config: MLSConfig, src, dst, target: Path) -> None:
    if config.uses_radius and config.radius is None:
        raise UsageError(
            f"--weight {config.weight} needs --radius R for a mesh (in the units of its "
            "coordinates): a mesh has no image or volume diagonal to default to"
        )
    mesh, unkept = read_mesh_and_unkept(args.input)
    if not len(mesh.faces) and volume_suffix(target) == ".stl":
        raise UsageError(
            f"{target}: {args.input} is a point cloud (no faces); STL holds triangles only: "
            "write it as .ply or .obj"
        )
    with _mls(src, dst, config) as m:
        with reported_warnings(f"glmls warp: {args.input}"):
            try:
                deformed = m.deform(mesh)
            except (TypeError, ValueError) as error:
                raise UsageError(f"{args.input}: {error}") from None
    vertices, faces = _count(deformed.vertex_folds), _count(deformed.face_folds)
    say(
        args,
        f"warp: mesh of {len(mesh.vertices)} vertices and {len(mesh.faces)} faces; folded: "
        f"{vertices} vertices, {faces} faces",
    )
    if faces:
        say(
            args,
            f"glmls warp: warning: {args.input}: {faces} of {len(mesh.faces)} faces fold over "
            "(turned inside out): the deformation is not one-to-one there",
        )
    # the carried normals where the input had its own: a file gains none it did not have
    normals = None if mesh.normals is None else getattr(deformed, "normals", None)
    write_mesh(
        target,
        np.asarray(deformed.vertices),
        faces=mesh.faces,
        colors=mesh.colors,
        uv=mesh.uv,
        face_uv=mesh.face_uv,
        normals=normals,
    )
    unkept = (*unwritten(target, mesh), *unkept)
    if unkept:
        say(args, f"warp: {target} does not carry the input's {', '.join(unkept)}")
