"""``glmls warp``: deform one image, or many (a folder or a glob), by MLS."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..files.images import check_writable
from ..files.landmarks import read_handle_set
from .inputs import (
    image_inputs,
    make_mls,
    read_image,
    reported_warnings,
    say,
    warn_about_handles,
    write_image,
)
from .options import (
    UsageError,
    add_config_options,
    add_max_pixels,
    add_warp_options,
    config_from_args,
    fit_background,
    parse_background,
)
from .progress import Progress, Ticker

HELP = "deform images by MLS"
EXAMPLES = """
examples:
  glmls warp photo.png out.png --handles handles.json --transform similarity
  glmls warp 'frames/*.png' warped/ --handles landmarks.csv --method backward --keep-going
  glmls warp photo.png out.png --handles handles.json --border edge
  glmls warp photo.png whole.png --handles handles.json --fit
  glmls warp photo.png out.png --handles lines.csv    # points, segments and polylines
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="IN", help="an image, a folder or a glob")
    parser.add_argument(
        "output",
        metavar="OUT",
        help="the output image; a folder (made if needed) for many images, or ending in /",
    )
    parser.add_argument(
        "--handles",
        metavar="H",
        required=True,
        help="handles file (JSON, CSV or BigWarp): points, segments and polylines",
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
    add_config_options(parser)
    add_warp_options(parser)


def targets(output: str, files: list[Path], many: bool) -> list[Path]:
    """Where each input goes: OUT itself, or OUT/name where OUT is a folder (many inputs, an
    existing folder, or a name ending in /). Unwritable formats are refused before any work."""
    out = Path(output)
    folder = many or out.is_dir() or output.endswith(("/", os.sep))
    if folder and out.exists() and not out.is_dir():
        raise UsageError(f"{out}: must be a folder when IN names several images")
    paths = [out / f.name for f in files] if folder else [out]
    for path in paths:
        try:
            check_writable(path)
        except ValueError as error:
            raise UsageError(str(error)) from None
    return paths


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    handles = read_handle_set(args.handles)
    files, many = image_inputs(args.input)
    outputs = targets(args.output, files, many)
    failed, warned = [], set()
    with Progress(len(files), "warp", quiet=args.quiet or not many) as bar:
        for source, target in zip(files, outputs, strict=True):
            try:
                image = read_image(source, args.max_pixels)
                channels = 1 if image.ndim == 2 else image.shape[2]
                try:
                    check_writable(target, image.dtype, channels)
                except ValueError as error:
                    raise UsageError(str(error)) from None
                if image.shape[:2] not in warned:
                    warn_about_handles(args, handles, image.shape)
                    warned.add(image.shape[:2])
                options = {
                    "method": args.method,
                    "interpolation": args.interpolation,
                    "grid": args.grid,
                    "background": fit_background(args.background, channels),
                    "border": args.border,
                }
                with make_mls(handles, config, image.shape) as m:
                    ticker = Ticker(f"warp {source}", quiet=args.quiet or many)
                    with ticker, reported_warnings(f"glmls warp: {source}"):
                        try:
                            if args.fit:
                                bounds = m.bounds(image.shape, grid=args.grid)
                                options["output_shape"] = bounds.output_shape
                                options["origin"] = bounds.origin
                            result = m.warp(image, **options)
                            if args.fit and not many:
                                (h, w), (x0, y0) = bounds.output_shape, bounds.origin
                                say(args, f"warp: {w} x {h} pixels from ({x0:g}, {y0:g})")
                        except (TypeError, ValueError) as error:
                            raise UsageError(f"{source}: {error}") from None
                write_image(target, result)
            except UsageError as error:
                if not args.keep_going:
                    raise
                failed.append(source)
                say(args, f"glmls warp: skipped {error}")
            else:
                print(target)
            bar.advance()
    if failed:
        say(args, f"glmls warp: {len(failed)} of {len(files)} images failed")
        return 1
    return 0
