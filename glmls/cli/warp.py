"""``glmls warp``: deform one image, or many (a folder or a glob), by MLS."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..files.landmarks import read_handles
from .inputs import image_inputs, make_mls, read_image, write_image
from .options import (
    UsageError,
    add_config_options,
    add_warp_options,
    config_from_args,
    parse_background,
)
from .progress import Progress

HELP = "deform images by MLS"
EXAMPLES = """
examples:
  glmls warp photo.png out.png --handles handles.json --transform similarity
  glmls warp 'frames/*.png' warped/ --handles landmarks.csv --method backward
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="IN", help="an image, a folder or a glob")
    parser.add_argument("output", metavar="OUT", help="the output image (a folder for many)")
    parser.add_argument("--handles", metavar="H", required=True, help="handles file")
    parser.add_argument(
        "--background",
        type=parse_background,
        default=0.0,
        help="value of uncovered pixels: one number or one per channel (default 0)",
    )
    add_config_options(parser)
    add_warp_options(parser)


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    src, dst = read_handles(args.handles)
    files, many = image_inputs(args.input)
    out = Path(args.output)
    if many and out.exists() and not out.is_dir():
        raise UsageError(f"{out}: must be a folder when IN names several images")
    targets = [out / f.name for f in files] if many or out.is_dir() else [out]
    options = {
        "method": args.method,
        "interpolation": args.interpolation,
        "grid": args.grid,
        "background": args.background,
    }
    with Progress(len(files), "warp", quiet=args.quiet or not many) as bar:
        for source, target in zip(files, targets, strict=True):
            image = read_image(source)
            with make_mls(src, dst, config, image.shape) as m:
                try:
                    result = m.warp(image, **options)
                except (TypeError, ValueError) as error:
                    raise UsageError(f"{source}: {error}") from None
            write_image(target, result)
            print(target)
            bar.advance()
    return 0
