"""``glmls demo`` on a volume: the volume window (three orthogonal slices, 3D handles).

The volume window opens for ``glmls demo VOLUME`` (NIfTI ``.nii``/``.nii.gz``, a TIFF stack,
or a ``.npy`` array: a volume, as for ``glmls warp`` and ``glmls analyze``), for ``glmls demo
--volume [VOLUME]`` (without a file: the bundled phantom and its handles), and for ``glmls
demo --handles H3D`` with a file of 3D handles and no image (the phantom, those handles).
An elastix pair is ``--handles MOVING.pts --targets FIXED.pts``, as for ``glmls warp``.

The voxel spacing is ``glmls warp``'s: ``--spacing DZ,DY,DX``, else the file's (a NIfTI's
affine, a TIFF stack's spacing), else 1; the handles are in its units (voxel (i, j, k) at
(i dx, j dy, k dz)), the views show the physical aspect and ``s`` saves the deformed volume
in the input's format with its spacing (and a NIfTI's affine). The phantom's own handles,
given in its voxels, are scaled by ``--spacing``. With ``--world`` (a NIfTI volume) the
handles are world coordinates of its affine, as for ``glmls warp``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from ..errors import InputFileError
from ..files.landmarks import handle_dimension, read_handles
from ..files.volumes import Volume, is_volume_file, read_volume, volume_suffix
from .demo_window import fail, replay_events, run_window, start_settings, window_options
from .warp3d import image_options_given, volume_handle_warnings, voxel_handles, world_handles

__all__ = ["run_volume", "volume_inputs"]


def _three_d_handles(path: Path | None, targets: Path | None) -> bool:
    if path is None:
        return False
    try:
        src, _ = read_handles(path, dst=targets)
    except (InputFileError, OSError):
        return False  # the 2D reader says what is wrong with it
    return src.shape[1] == 3


def volume_inputs(
    args: argparse.Namespace,
) -> tuple[Volume, str, np.ndarray, np.ndarray] | None:
    """(volume, name, src, dst) when the arguments ask for the volume window, else None;
    the volume a :class:`~glmls.Volume` with ``--spacing``'s spacing, else the file's.
    ``InputFileError`` (a ``ValueError``) for a bad volume or handles file, ``ValueError``
    for ``--spacing`` with a 2D image."""
    from .. import data

    # as glmls warp and analyze decide, so that the image reader, which refuses what this
    # takes for a volume, never sees one
    wanted = args.volume or (args.image is not None and is_volume_file(args.image))
    if not wanted and not (args.image is None and _three_d_handles(args.handles, args.targets)):
        for given, option in ((args.spacing is not None, "--spacing"), (args.world, "--world")):
            if given:
                raise ValueError(
                    f"{option}: for volumes, not for images ({args.image or 'the photograph'})"
                )
        return None
    if args.image is None:
        volume, name = Volume(data.phantom(), spacing=args.spacing), "phantom"
        src, dst = data.phantom_handles()
        if args.spacing is not None:  # the phantom's handles are in its voxels
            scale = np.array(args.spacing[::-1])
            src, dst = src * scale, dst * scale
    else:
        volume, name = read_volume(args.image), args.image.name.split(".")[0]
        if args.spacing is not None:  # the file's affine and header fields kept, for s
            volume = dataclasses.replace(volume, spacing=args.spacing)
        src = dst = np.zeros((0, 3))
    if args.handles is not None:  # an elastix pair of voxel indices: times the spacing
        if handle_dimension(args.handles, dst=args.targets) == 2:  # as glmls warp says it
            raise ValueError(
                f"{args.handles}: 2D handles (x, y), but {args.image or 'the phantom'} is a "
                "volume: it takes 3D handles (x, y, z)"
            )
        src, dst = read_handles(args.handles, dst=args.targets, ndim=3)
        src, dst = voxel_handles(args, src, dst, volume.spacing)
        if args.world and args.image is None:
            raise ValueError(
                "--world: the phantom has no affine to map world coordinates by (only NIfTI "
                "volumes, .nii and .nii.gz, have one)"
            )
        src, dst = world_handles(args, volume, volume.spacing, src, dst, source=args.image)
    elif args.world:
        raise ValueError("--world: says how to read --handles, which are not given")
    return volume, name, src, dst


def _save_as(args: argparse.Namespace) -> str:
    """The deformed volume's format: the input's (a ``.npy`` for the phantom)."""
    return ".npy" if args.image is None else volume_suffix(args.image)


def volume_settings(args: argparse.Namespace):
    """The volume window's first :class:`~glmls.app.volume_controller.VolumeSettings`: the
    options given, its own defaults for those left out (``--border`` edge,
    ``--interpolation`` linear); ``ValueError`` for an option it cannot take (a 2D method,
    ``--fit``, ``--tolerance``, ``--reference``, ``--max-pixels``, a grid other than 1, 2, 4,
    8, 16)."""
    from ..app.volume_controller import VOLUME_METHODS, VolumeSettings

    images_only = image_options_given(args) + ([] if args.reference is None else ["--reference"])
    if images_only:
        raise ValueError(f"{', '.join(images_only)}: for images, not for the volume window")
    if args.method not in VOLUME_METHODS:
        raise ValueError(
            f"--method {args.method}: the volume window builds {' or '.join(VOLUME_METHODS)}"
        )
    return VolumeSettings(**start_settings(args))


def run_volume(args: argparse.Namespace, inputs: tuple) -> int:
    """Run the volume window for parsed arguments and :func:`volume_inputs`; the exit status.
    Where more than half of the source handles lie outside the volume, stderr says so,
    in ``glmls warp``'s words."""
    from ..app.volume_window import VolumeApp

    volume, name, src, dst = inputs
    try:
        events = replay_events(args)
        settings = volume_settings(args)
        app = VolumeApp(
            volume,
            src,
            dst,
            save_as=_save_as(args),
            settings=settings,
            name=name,
            **window_options(args),
        )
    except (ValueError, TypeError) as error:
        return fail(2, str(error))
    if args.handles is not None:  # as glmls warp says it
        messages = volume_handle_warnings(args, src, volume.shape, volume.spacing, volume.affine)
        for message in messages:
            print(f"glmls demo: warning: {args.image or name}: {message}", file=sys.stderr)
    return run_window(app, args, events)
