"""The inputs of the ``glmls`` commands: images named by a file, folder or glob, the bundled
example, handle and reference files, and the MLS they make. Every mistake is a
:class:`~glmls.cli.options.UsageError` naming the file."""

from __future__ import annotations

import argparse
import contextlib
import glob
import sys
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from .. import data
from ..analysis.canvas import as_rgb8
from ..analysis.triangles import check_reference_points
from ..core.config import MLSConfig
from ..core.handleset import HandleSet
from ..core.mesh import MAX_GRID
from ..errors import BorderWarning, ImageWarning, InputFileError
from ..files.images import DEFAULT_MAX_PIXELS, imread, imwrite
from ..files.landmarks import handle_dimension, read_handle_set, read_points
from ..files.profiles import profile_problem, read_icc_profile
from ..files.volumes import flat_npy, is_volume_file
from ..mls import MLS
from .options import (
    UsageError,
    add_max_pixels,
    folder_path,
    handle_warnings,
    positive_int,
    refuse_overwriting,
)

__all__ = [
    "IMAGE_SUFFIXES",
    "add_example_inputs",
    "check_example",
    "example_or_files",
    "figure",
    "image_inputs",
    "kept_profile",
    "make_mls",
    "one_cell_warning",
    "read_image",
    "read_image_handles",
    "reference_or_handles",
    "say",
    "warn_about_handles",
    "warn_about_reference",
    "write_image",
]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")


def image_inputs(pattern: str) -> tuple[list[Path], bool]:
    """The images named by ``pattern`` (a file, a folder or a glob) and whether it is many."""
    path = Path(pattern)
    if path.is_dir():
        files = sorted(  # as folder/* names them: no hidden file (macOS's ._NAME), no folder
            p
            for p in path.iterdir()
            if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith(".") and p.is_file()
        )
        many = True
    elif path.is_file():
        return [path], False
    else:
        many = glob.has_magic(pattern)
        if not many:
            exists = path.exists()  # a device, a pipe: no image file
            raise UsageError(
                f"{pattern}: {'not a file or folder' if exists else 'no such file or folder'}"
            )
        files = sorted(Path(p) for p in glob.glob(pattern) if Path(p).is_file())
    if not files:
        raise UsageError(f"{pattern}: no images found")
    return files, many


def read_image(
    path: Path, max_pixels: int = DEFAULT_MAX_PIXELS, *, prefix: str = "glmls"
) -> np.ndarray:
    """The image of ``path`` (its warnings on stderr, ``prefix: warning: ...``, the prefix
    naming the command); :class:`UsageError` naming the file
    for anything else, a TIFF stack too: imread would give its first page, which among a
    batch of images would be written under the stack's name as if it were all of it."""
    if Path(path).suffix.lower() in (".tif", ".tiff"):
        try:
            stack = is_volume_file(path)
        except InputFileError as error:  # the channels of one image, or no page
            raise UsageError(str(error)) from None
        if stack:
            raise UsageError(
                f"{path}: a volume (a TIFF stack); 2D images only here: warp, analyze and "
                "demo take a volume named on its own, with 3D handles"
            )
    try:
        return _read(path, max_pixels, prefix)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such file") from None
    except ValueError as error:  # imread's messages name the file
        flat = flat_npy(path)
        if flat is not None:
            raise UsageError(flat) from None
        if Path(path).suffix.lower() in (".npy", ".nii", ".gz") and is_volume_file(path):
            raise UsageError(  # not "not an image format": the command takes images only here
                f"{path}: a volume; 2D images only here: warp, analyze and demo take a volume "
                "named on its own, with 3D handles"
            ) from None
        raise UsageError(str(error)) from None
    except OSError as error:
        raise UsageError(f"{path}: cannot read the image: {error.strerror or error}") from None


def _read(path: Path, max_pixels: int, prefix: str) -> np.ndarray:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImageWarning)
        image = imread(path, max_pixels=max_pixels)
    for warning in caught:
        print(f"{prefix}: warning: {warning.message}", file=sys.stderr)
    return image


@contextlib.contextmanager
def reported_warnings(prefix: str) -> Iterator[None]:
    """glmls's warnings inside the block (a border mode that could not fill the canvas) as
    one line each on stderr, ``prefix: warning: ...``, instead of Python's two."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BorderWarning)
        yield
    for warning in caught:
        print(f"{prefix}: warning: {warning.message}", file=sys.stderr)


def write_image(path: Path, image: np.ndarray, *, icc_profile: bytes | None = None) -> None:
    imwrite(path, image, icc_profile=icc_profile)  # whole or not at all


def kept_profile(source: Path, target: Path, channels: int, prefix: str) -> bytes | None:
    """``source``'s ICC colour profile, for writing ``target`` (an image of ``channels``)
    with it; None where it has none, or (said on stderr) where ``target`` cannot keep it."""
    profile = read_icc_profile(source)
    if profile is None:
        return None
    problem = profile_problem(target, profile, channels)
    if problem:
        print(f"{prefix}: warning: {source}: its colour profile is not kept: {problem}",
              file=sys.stderr)  # fmt: skip
        return None
    return profile


def make_mls(handles: HandleSet, config: MLSConfig, shape) -> MLS:
    """The MLS of ``handles`` (points and segments) with ``config``; :class:`UsageError` if
    the configuration cannot take them (affine on handles along one line)."""
    try:
        return MLS.from_config(
            handles.src,
            handles.dst,
            config,
            shape=shape,
            src_segments=handles.src_segments,
            dst_segments=handles.dst_segments,
        )
    except (TypeError, ValueError) as error:
        raise UsageError(f"handles: {error}") from None


def say(args: argparse.Namespace, message: str) -> None:
    """A message on stderr unless ``--quiet``."""
    if not args.quiet:
        print(message, file=sys.stderr)


def figure(value: float | None) -> str:
    """A statistic for a one-line summary: four significant digits, "n/a" where undefined."""
    return "n/a" if value is None else f"{value:.4g}"


def one_cell_warning(grid: int | None, shape: tuple[int, ...]) -> str | None:
    """The warning for a ``--grid`` not smaller than the image (H, W) or volume (D, H, W) of
    ``shape``: its mesh is one cell; None where the grid is finer (or 1, or not given), or
    beyond the largest grid (the warp refuses it, in the one line of an error)."""
    if grid is None or not (1 < grid <= MAX_GRID and grid >= max(shape)):
        return None
    if len(shape) == 2:
        height, width = shape
        return (
            f"--grid {grid} is not smaller than the {width} x {height} image: the mesh is one "
            "cell, whose corners alone follow f (the handles inside it move nothing)"
        )
    depth, height, width = shape
    return (
        f"--grid {grid} is not smaller than the {width} x {height} x {depth} volume: the "
        "lattice is one cell, whose corners alone follow f (the handles inside it move "
        "nothing)"
    )


def warn_about_handles(args: argparse.Namespace, handles: HandleSet, shape) -> None:
    """Warnings on stderr (not errors) for handles (their source points and segment ends)
    that look like another convention."""
    points, ends = handles.source_points(), handles.segments > 0
    messages = handle_warnings(points, shape[:2], segment_ends=ends)
    one_cell = one_cell_warning(getattr(args, "grid", 1), shape[:2])
    if getattr(args, "tolerance", None) is None and one_cell is not None:
        messages.append(one_cell)
    for message in messages:
        say(args, f"glmls {args.command}: warning: {message}")


def warn_about_reference(args: argparse.Namespace, reference: np.ndarray, shape) -> None:
    """Warnings on stderr (not errors) for reference points that look like another convention
    than the image's pixels, as :func:`warn_about_handles` gives for the handles."""
    for message in handle_warnings(reference, shape[:2], reference=True):
        say(args, f"glmls {args.command}: warning: {message}")


def reference_or_handles(args: argparse.Namespace, reference, handles: HandleSet) -> np.ndarray:
    """``reference``, or where none was given the distinct source points and segment ends
    (in their order), said on stderr."""
    if reference is not None:
        return reference
    points = handles.source_points()
    _, first = np.unique(points, axis=0, return_index=True)
    what = "handles (points and segment ends)" if handles.segments else "handles"
    say(args, f"{args.command}: no --reference given: the source {what} are the reference points")
    return points[np.sort(first)]


def check_reference(args: argparse.Namespace, reference: np.ndarray, fallback: str) -> None:
    """:class:`UsageError` naming where the reference points came from (``--reference``, else
    ``fallback``) if they make no triangulation; before any work is started."""
    try:
        check_reference_points(reference)
    except ValueError as error:
        where = args.reference or fallback
        fault = str(error).replace("reference_points: ", "").replace("reference_points", "points")
        raise UsageError(f"{where}: {fault}") from None


def check_picture(image: np.ndarray, name: str) -> None:
    """:class:`UsageError` naming the file if the analysis cannot picture ``image`` (NaN or
    infinite values); before any work is started."""
    try:
        as_rgb8(image, name)
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None


def add_example_inputs(parser: argparse.ArgumentParser, *, reference_required: bool) -> None:
    """IN, --handles, --reference, --example, --out, --analysis-grid and --cmap."""
    parser.add_argument(
        "input",
        metavar="IN",
        nargs="?",
        help="the image"
        if reference_required
        else "the image, or a volume (.nii, .nii.gz, a TIFF of several pages, .npy) or a mesh "
        "(.ply, .obj, .stl) with 3D handles",
    )
    parser.add_argument(
        "--handles",
        metavar="H",
        help="handles file (JSON, CSV or BigWarp): points, segments and polylines",
    )
    parser.add_argument(
        "--reference",
        metavar="R",
        help="reference points file (JSON or CSV)"
        + ("" if reference_required else "; default: the source handles"),
    )
    parser.add_argument(
        "--example", action="store_true", help="use the bundled photograph, handles and points"
    )
    parser.add_argument(
        "--out", metavar="DIR", type=folder_path, required=True, help="output folder"
    )
    add_max_pixels(parser)
    parser.add_argument(
        "--analysis-grid",
        type=positive_int,
        default=1 if not reference_required else 4,
        help="mesh step of the error field in pixels",
    )
    parser.add_argument(
        "--cmap",
        choices=("viridis", "linear"),
        default="viridis",
        help="colour map: viridis, or the paper's two-colour linear map",
    )


def check_example(args: argparse.Namespace) -> None:
    """:class:`UsageError` for --example with the inputs it stands for (IN, --handles,
    --reference, --targets), which it would otherwise leave unread."""
    if not args.example:
        return
    given = [
        f"{name} {value}"
        for name, value in (
            ("IN", getattr(args, "input", None)),
            ("--handles", getattr(args, "handles", None)),
            ("--reference", getattr(args, "reference", None)),
            ("--targets", getattr(args, "targets", None)),
        )
        if value is not None
    ]
    if given:
        raise UsageError(
            "--example replaces IN, --handles and --reference (the bundled photograph and its "
            f"points); leave out {', '.join(given)}"
        )


def read_image_handles(path, *, dst=None, image: object, many: bool = False) -> HandleSet:
    """The 2D handles of ``path`` (and ``dst``, an elastix pair's targets) for ``image``
    (its name, for the message; ``many``: a name of several images); :class:`UsageError` for
    a file of 3D handles."""
    if handle_dimension(path, dst=dst) != 2:
        which = "names images: they take" if many else "is an image: it takes"
        name = str(image)
        if Path(name).is_dir() or (glob.has_magic(name) and not Path(name).exists()):
            which = (  # a folder or a glob of volumes: they are not read as such
                "names images: a folder or a glob takes 2D images (a volume or a mesh is "
                "named on its own), which take"
            )
        hint = ""
        if str(image).lower().endswith((".tif", ".tiff")) and Path(str(image)).is_file():
            # a volume of one slice, saved as a stack, is a TIFF of one page
            hint = (
                " (a TIFF of one page is an image; a volume of one slice is read from .nii, "
                ".nii.gz or .npy)"
            )
        raise UsageError(
            f"{path}: 3D handles (x, y, z), but {image} {which} 2D handles (x, y){hint}"
        )
    return read_handle_set(path, dst=dst)


#: The options that name files a command reads, and what each file is.
_READ = (
    ("input", "the input"),
    ("handles", "the --handles file"),
    ("targets", "the --targets file"),
    ("reference", "the --reference file"),
)


def keep_inputs(args: argparse.Namespace, outputs: list[Path]) -> None:
    """:class:`UsageError` for one of ``outputs`` that is a file the command reads (IN,
    --handles, --targets, --reference), which writing it would destroy."""
    read = {
        Path(value): what
        for option, what in _READ
        if isinstance(value := getattr(args, option, None), str)
    }
    refuse_overwriting(outputs, read)


def report_paths(folder: str | Path, images: Iterable[str]) -> list[Path]:
    """The files a report's ``save(folder)`` writes: ``report.json`` and its pictures
    (``images``: their names, or a report's dict of them)."""
    folder = Path(folder)
    return [folder / "report.json", *(folder / f"{name}.png" for name in images)]


def example_or_files(args: argparse.Namespace, *, need_reference: bool):
    """(image, handles, reference or None, name) from --example or the given files;
    ``handles`` is a :class:`~glmls.core.handleset.HandleSet`."""
    check_example(args)
    if args.example:
        return (
            data.astronaut(),
            HandleSet.validate(*data.astronaut_handles()),
            data.astronaut_reference_points(),
            "astronaut (bundled example)",
        )
    missing = [o for o, v in (("IN", args.input), ("--handles", args.handles)) if v is None]
    if need_reference and args.reference is None:
        missing.append("--reference")
    if missing:
        raise UsageError(f"missing {', '.join(missing)} (or use --example)")
    image = read_image(Path(args.input), args.max_pixels, prefix=f"glmls {args.command}")
    handles = read_image_handles(args.handles, dst=getattr(args, "targets", None), image=args.input)
    reference = read_points(args.reference) if args.reference else None
    return image, handles, reference, str(args.input)
