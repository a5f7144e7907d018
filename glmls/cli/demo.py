"""``glmls demo``: the real-time window (the paper's interactive system) from the command line.

Exit status: 0 done, 2 bad input (arguments, image, handles or events file), 1 runtime failure
(no display, no OpenGL 4.3), each with a one-line message on stderr.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..core.handleset import HandleSet
from ..errors import InputFileError
from ..files.images import check_writable
from ..files.landmarks import read_points
from .demo_window import fail, replay_events, run_window, start_settings, window_options
from .inputs import read_image, read_image_handles
from .options import (
    UsageError,
    add_config_options,
    add_max_pixels,
    add_warp_options,
    folder_path,
    positive_int,
    refuse_overwriting,
)
from .warp3d import TARGETS_HELP, parse_spacing

__all__ = ["configure", "run"]

HELP = "the real-time window"
EXAMPLES = """
examples:
  glmls demo                                   # the bundled photograph
  glmls demo photo.png --handles h.json
  glmls demo --volume                          # the bundled 64^3 phantom, 3D handles
  glmls demo scan.nii.gz --handles h3d.json    # a volume: three orthogonal slices
  glmls demo scan.nii --handles moving.pts --targets fixed.pts   # elastix points
  glmls demo --record session.json             # save the session's events to replay
  xvfb-run -a glmls demo --replay drag.json --frames 30 --screenshot shot.png
"""
#: The former --construction's names, still accepted: (method, interpolation).
_CONSTRUCTIONS = {
    "quads-nearest": ("quads", "nearest"),
    "quads-linear": ("quads", "linear"),
    "splat": ("splat", "nearest"),
    "backward": ("backward", "linear"),
}


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT, e.g. 900x600, got {text!r}"
        ) from None
    if not (64 <= width <= 16384 and 64 <= height <= 16384):
        raise argparse.ArgumentTypeError(f"window size must be 64..16384 per side, got {text}")
    return width, height


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the window's arguments to ``parser``."""
    parser.description = (
        "Open the real-time MLS window: drag handles, switch transforms, weights and image "
        "constructions, and see the error fields live (F1 in the window lists the keys)."
    )
    parser.add_argument(
        "image",
        metavar="IMAGE",
        nargs="?",
        type=Path,
        help="image to deform (default: the bundled photograph with its handles), or a "
        "volume (.nii, .nii.gz, TIFF stack, any .npy: D x H x W or D x H x W x C): the volume "
        "window",
    )
    parser.add_argument(
        "--volume",
        action="store_true",
        help="the volume window (three orthogonal slices, 3D handles); without IMAGE the "
        "bundled phantom and its handles",
    )
    parser.add_argument(
        "--handles",
        type=Path,
        help="handles file (JSON, CSV, BigWarp's CSV or JSON, elastix's .pts with --targets): "
        "points, segments and polylines",
    )
    parser.add_argument("--targets", type=Path, metavar="DST", help=TARGETS_HELP)
    parser.add_argument(
        "--world",
        action="store_true",
        help="a NIfTI volume's handles are world coordinates of its affine, as for glmls warp",
    )
    parser.add_argument(
        "--spacing",
        type=parse_spacing,
        metavar="DZ,DY,DX",
        help="a volume's voxel size along z, y and x, or one number for all three, as for "
        "glmls warp: the handles' units and the views' aspect (default: the file's: a NIfTI's "
        "affine, a TIFF stack's spacing (ImageJ's, OME's or glmls's); else 1)",
    )
    parser.add_argument(
        "--reference",
        type=Path,
        help="reference points (JSON or CSV) for the angle errors (images only)",
    )
    add_config_options(parser)
    add_warp_options(parser, grid=4, windows=True)
    parser.add_argument(
        "--construction", choices=tuple(_CONSTRUCTIONS), help=argparse.SUPPRESS
    )  # the former name of --method/--interpolation
    parser.add_argument(
        "--replay", type=Path, metavar="EVENTS.json", help="feed recorded events, one per frame"
    )
    parser.add_argument(
        "--record",
        type=Path,
        metavar="EVENTS.json",
        help="save every event of the session (mouse, keys) as a replay file on exit",
    )
    parser.add_argument(
        "--frames",
        type=positive_int,
        metavar="N",
        help="render N frames, then exit (default with --replay or --screenshot: until the "
        "events are done)",
    )
    parser.add_argument(
        "--screenshot", type=Path, metavar="OUT.png", help="save the last frame, then exit"
    )
    parser.add_argument(
        "--out",
        "--out-dir",
        dest="out",
        type=folder_path,
        default=Path("."),
        metavar="DIR",
        help="where the s, j and S keys save",
    )
    parser.add_argument(
        "--window-size",
        type=_size,
        metavar="WxH",
        help="window size, 64 to 16384 pixels per side (default: fitted to the image or volume)",
    )
    add_max_pixels(parser)


def _inputs(args: argparse.Namespace):
    """(image, name, handles, reference) from the arguments, ``handles`` a
    :class:`~glmls.core.handleset.HandleSet`; raises ValueError/OSError."""
    from .. import data

    if args.image is None:
        image, name = data.astronaut(), "astronaut"
        src, dst = data.astronaut_handles()
        reference = data.astronaut_reference_points()
    else:
        try:
            image = read_image(args.image, args.max_pixels, prefix="glmls demo")
        except UsageError as error:
            raise InputFileError(str(error)) from None
        name = args.image.stem
        src = dst = np.zeros((0, 2))
        reference = np.zeros((0, 2))
    handles = HandleSet.validate(src, dst)
    if args.handles is not None:
        handles = read_image_handles(args.handles, dst=args.targets, image=args.image or name)
    if args.reference is not None:
        reference = read_points(args.reference)
    return image, name, handles, reference


def image_settings(args: argparse.Namespace):
    """The image window's first :class:`~glmls.app.controller.Settings`: the options given,
    its own defaults for those left out (``--border``, ``--interpolation``)."""
    from ..app.controller import Settings

    return Settings(**start_settings(args, "fit", "tolerance"))


def run(args: argparse.Namespace) -> int:
    """Run the window for parsed arguments; returns the exit status."""
    from ..app.window import App
    from .demo_volume import run_volume, volume_inputs

    if args.construction is not None:  # the former name of --method/--interpolation
        args.method, args.interpolation = _CONSTRUCTIONS[args.construction]
    if args.targets is not None and args.handles is None:
        return fail(2, "--targets: with --handles (the source points), as for glmls warp")
    if args.screenshot is not None:  # an RGB uint8 picture; before the window opens
        try:
            check_writable(args.screenshot, np.uint8, 3)
        except ValueError as error:
            return fail(2, f"--screenshot: {error}")
    try:  # both are written on exit: over a file the window read, they would replace it
        refuse_overwriting(
            [path for path in (args.screenshot, args.record) if path is not None],
            {
                Path(value): what
                for value, what in (
                    (args.image, "the input"),
                    (args.handles, "the --handles file"),
                    (args.targets, "the --targets file"),
                    (args.reference, "the --reference file"),
                    (args.replay, "the --replay file"),
                )
                if value is not None
            },
        )
    except UsageError as error:
        return fail(2, str(error))
    try:
        volume = volume_inputs(args)
    except (ValueError, TypeError) as error:
        return fail(2, str(error))
    if volume is not None:
        return run_volume(args, volume)
    try:
        image, name, handles, reference = _inputs(args)
        events = replay_events(args)
        settings = image_settings(args)
        app = App(
            image,
            handles.src,
            handles.dst,
            src_segments=handles.src_segments,
            dst_segments=handles.dst_segments,
            reference=reference,
            settings=settings,
            name=name,
            **window_options(args),
        )
    except (ValueError, TypeError) as error:
        return fail(2, str(error))
    return run_window(app, args, events)
