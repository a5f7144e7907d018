"""``glmls warp``: deform one image, or many (a folder or a glob), by MLS; or one volume or
mesh (:mod:`.warp3d`).

Each image is written whole or not at all, as it finishes. A run stopped by a failing image
(without ``--keep-going``) or by anything else keeps the images already written (and those
that workers still running finish), and leaves no temporary file (a worker stopped while it
wrote one leaves it: the run removes it) and none of the folders it made if they are empty."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import os
import sys
from pathlib import Path

from ..analysis.jobs import check_jobs, check_scheduler, run_jobs
from ..core.config import MLSConfig
from ..core.handleset import HandleSet
from ..files.atomic import missing_folders, remove_leftovers
from ..files.images import WRITABLE, check_writable
from ..imaging.options import WarpOptions
from ..imaging.source import check_image
from .inputs import (
    image_inputs,
    kept_profile,
    make_mls,
    read_image,
    read_image_handles,
    reported_warnings,
    say,
    warn_about_handles,
    write_image,
)
from .options import (
    UsageError,
    add_config_options,
    add_jobs_options,
    add_max_pixels,
    add_warp_options,
    below_a_file,
    config_from_args,
    fit_background,
    parse_background,
    refuse_overwriting,
    warp_options_from_args,
)
from .progress import Progress, Ticker
from .warp3d import add_3d_options, check_world, input_kind, run_3d

HELP = "deform images, volumes and meshes by MLS"
EXAMPLES = """
examples:
  glmls warp photo.png out.png --handles handles.json --transform similarity
  glmls warp 'frames/*.png' warped/ --handles landmarks.csv --method backward --keep-going
  glmls warp photo.png out.png --handles handles.json --border edge
  glmls warp photo.png whole.png --handles handles.json --fit
  glmls warp photo.png out.png --handles lines.csv    # points, segments and polylines
  glmls warp frames/ warped/ --handles h.json --jobs 4                # 4 worker processes
  glmls warp frames/ warped/ --handles h.json --scheduler tcp://head:8786   # a Dask cluster
  glmls warp brain.nii.gz warped.nii.gz --handles landmarks3d.csv   # a volume, 3D handles
  glmls warp stack.tif out.tif --handles bigwarp.csv --spacing 2,0.5,0.5 --interpolation linear
  glmls warp scan.nii out.nii --handles moving.pts --targets fixed.pts   # elastix points
  glmls warp bunny.ply out.ply --handles h3d.json   # a mesh; stderr says the folds
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "input",
        metavar="IN",
        help="an image, a folder or a glob of images; or a volume (.nii, .nii.gz, a TIFF of "
        "several pages, .npy) or a mesh (.ply, .obj, .stl)",
    )
    parser.add_argument(
        "output",
        metavar="OUT",
        help="the output image, volume or mesh, its format by its suffix; a folder (made if "
        "needed) for many images, or ending in /",
    )
    parser.add_argument(
        "--handles",
        metavar="H",
        required=True,
        help="handles file (JSON, CSV, BigWarp's CSV or JSON, elastix's .pts with --targets): "
        "2D points, segments and polylines for images, 3D points for volumes and meshes",
    )
    parser.add_argument(
        "--background",
        type=parse_background,
        default=0.0,
        help="value of uncovered pixels: one number or one per channel (grey images in a "
        "batch take a colour's first value)",
    )
    parser.add_argument(
        "--keep-going",
        action="store_true",
        help="with many images: skip one that fails, say why, and exit 1 at the end",
    )
    add_max_pixels(parser)
    add_jobs_options(parser)
    add_config_options(parser)
    add_warp_options(parser)
    add_3d_options(parser)


def targets(output: str, files: list[Path], many: bool) -> list[Path]:
    """Where each input goes: OUT itself, or OUT/name where OUT is a folder (many inputs, an
    existing folder, or a name ending in /; NAME.png for an input in a format glmls reads
    but does not write, a GIF, as ``glmls augment`` names its copies). Unwritable formats
    named in OUT are refused before any work."""
    out = Path(output)
    folder = many or out.is_dir() or output.endswith(("/", os.sep))
    fault = below_a_file(out, itself=folder)
    if fault is not None:
        why = " (IN names several images: OUT is their folder)" if many and out.is_file() else ""
        raise UsageError(fault + why)
    paths = [out / written_name(f) for f in files] if folder else [out]
    seen: dict[Path, Path] = {}
    for source, path in zip(files, paths, strict=False):  # a glob over several folders
        if path in seen:
            raise UsageError(
                f"{seen[path]} and {source} have one name: their outputs ({path}) would "
                "overwrite each other"
            )
        seen[path] = source
    for path in paths:
        try:
            check_writable(path)
        except ValueError as error:
            raise UsageError(str(error)) from None
    return paths


def written_name(source: Path) -> str:
    """The name of ``source``'s output in a folder: its own, or ``NAME.png`` where glmls
    does not write its format."""
    return source.name if source.suffix.lower() in WRITABLE else source.stem + ".png"


def inputs_read(args: argparse.Namespace, files: list[Path]) -> dict[Path, str]:
    """The files ``glmls warp`` reads, which no output may overwrite: IN's, --handles and
    --targets."""
    read = {path: "an input image" for path in files}
    for option, name in (("--handles", args.handles), ("--targets", args.targets)):
        if name is not None:
            read.setdefault(Path(name), f"the {option} file")
    return read


@dataclasses.dataclass(frozen=True)
class WarpTask:
    """One image of ``glmls warp``, as sent to a worker process (picklable)."""

    source: Path
    target: Path
    handles: HandleSet
    config: MLSConfig
    options: WarpOptions  # the background: the batch's, fitted to each image's channels
    fit: bool
    many: bool
    max_pixels: int
    quiet: bool
    capture: bool  # in a worker: give back what it says on stderr, for the caller to print


@dataclasses.dataclass(frozen=True)
class WarpOutcome:
    """What became of one image: its shape (for the handle warnings), the error that
    skipped it (``None``: written), lines to say (unless ``--quiet``), stderr's text, and
    whether the error is a failure to write (exit status 1) rather than a mistake (2)."""

    target: Path
    shape: tuple[int, ...] | None
    error: str | None
    notes: tuple[str, ...] = ()
    stderr: str = ""
    unwritten: bool = False


def warp_file(task: WarpTask) -> WarpOutcome:
    """Read, warp and write one image (in this process or a worker's); a mistake in the
    input is an outcome with ``error``, not an exception, so that ``--keep-going`` decides."""
    if not task.capture:
        return _warp_file(task)
    buffer = io.StringIO()
    with contextlib.redirect_stderr(buffer):
        outcome = _warp_file(task)
    return dataclasses.replace(outcome, stderr=buffer.getvalue())


def _warp_file(task: WarpTask) -> WarpOutcome:
    shape, notes = None, []
    try:
        image = read_image(task.source, task.max_pixels, prefix="glmls warp")
        shape = image.shape
        channels = 1 if image.ndim == 2 else image.shape[2]
        try:
            check_image(image, str(task.source))  # before the output: no suffix takes int16
            check_writable(task.target, image.dtype, channels)
        except (TypeError, ValueError) as error:
            raise UsageError(str(error)) from None
        options = task.options
        with make_mls(task.handles, task.config, image.shape) as m:
            ticker = Ticker(f"warp {task.source}", quiet=task.quiet or task.many)
            with ticker, reported_warnings(f"glmls warp: {task.source}"):
                try:
                    background = fit_background(options.background, channels)
                    options = dataclasses.replace(options, background=background)
                    if task.fit:
                        bounds = m.bounds(image.shape, grid=options.grid)
                        options = dataclasses.replace(
                            options, output_shape=bounds.output_shape, origin=bounds.origin
                        )
                    result = m.warp(image, options=options)
                    if task.fit and not task.many:
                        (h, w), (x0, y0) = bounds.output_shape, bounds.origin
                        notes.append(f"warp: {w} x {h} pixels from ({x0:g}, {y0:g})")
                except (TypeError, ValueError) as error:
                    raise UsageError(f"{task.source}: {error}") from None
        channels = 1 if result.ndim == 2 else result.shape[2]
        profile = kept_profile(task.source, task.target, channels, "glmls warp")
        write_image(task.target, result, icc_profile=profile)
    except UsageError as error:
        return WarpOutcome(task.target, shape, str(error), tuple(notes))
    except OSError as error:  # its message names the output: no "item N" before it
        return WarpOutcome(task.target, shape, str(error), tuple(notes), unwritten=True)
    return WarpOutcome(task.target, shape, None, tuple(notes))


def run(args: argparse.Namespace) -> int:
    if not args.output.strip():  # Path("") is the working folder: not what "" says
        raise UsageError("OUT is empty: give the file or folder to write into (. for this one)")
    kind = input_kind(args.input)
    if kind != "image":
        return run_3d(args, kind)
    if args.spacing is not None:
        raise UsageError(f"--spacing: for volumes, not for images ({args.input})")
    check_world(args)
    config = config_from_args(args)
    try:
        jobs, scheduler = check_jobs(args.jobs), check_scheduler(args.scheduler)
    except (ImportError, TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    handles = read_image_handles(args.handles, dst=args.targets, image=args.input, many=True)
    files, many = image_inputs(args.input)
    outputs = targets(args.output, files, many)
    refuse_overwriting(outputs, inputs_read(args, files))
    renamed = {  # said once written: a file that is no image is skipped instead
        index
        for index, (source, target) in enumerate(zip(files, outputs, strict=True))
        if target.suffix.lower() != source.suffix.lower() and target.name == written_name(source)
    }
    options = warp_options_from_args(args)
    capture = jobs > 1 or scheduler is not None
    tasks = [
        WarpTask(
            source,
            target,
            handles,
            config,
            options,
            fit=args.fit,
            many=many,
            max_pixels=args.max_pixels,
            quiet=args.quiet,
            capture=capture,
        )
        for source, target in zip(files, outputs, strict=True)
    ]
    failed, warned = [], set()
    with Progress(len(files), "warp", quiet=args.quiet or not many) as bar:

        def finished(index: int, outcome: WarpOutcome) -> None:
            sys.stderr.write(outcome.stderr)
            if outcome.shape is not None and outcome.shape[:2] not in warned:
                warn_about_handles(args, handles, outcome.shape)
                warned.add(outcome.shape[:2])
            for note in outcome.notes:
                say(args, note)
            if outcome.error is not None:
                if not args.keep_going:  # stops the batch: the items not started never start
                    raise (OSError if outcome.unwritten else UsageError)(outcome.error)
                failed.append(files[index])  # an error: said even with --quiet
                print(f"glmls warp: skipped {outcome.error}", file=sys.stderr)
            else:
                if index in renamed:
                    source = files[index]
                    say(
                        args,
                        f"glmls warp: {source}: glmls writes no {source.suffix}; written as "
                        f"{outcome.target}",
                    )
                print(outcome.target, flush=True)
            bar.advance()

        made = missing_folders(outputs)
        try:
            run_jobs(warp_file, tasks, jobs=jobs, scheduler=scheduler, on_result=finished)
        except BaseException:  # the images written stay; no temporary file, no empty folder
            remove_leftovers(outputs, made)
            raise
    if failed:
        print(f"glmls warp: {len(failed)} of {len(files)} images failed", file=sys.stderr)
        return 1
    return 0
