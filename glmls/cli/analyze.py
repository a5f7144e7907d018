"""``glmls analyze``: the error analysis of one deformation (the paper's section 5)."""

from __future__ import annotations

import argparse

from ..analysis.reporting import picture_names, report
from ..analysis.triangles import ANGLE_MEASURES
from .analyze_mesh import is_mesh_input, run_mesh
from .analyze_volume import is_volume_input, run_volume
from .inputs import (
    add_example_inputs,
    check_example,
    check_picture,
    check_reference,
    example_or_files,
    figure,
    keep_inputs,
    make_mls,
    reference_or_handles,
    report_paths,
    reported_warnings,
    say,
    warn_about_handles,
    warn_about_reference,
)
from .options import (
    UsageError,
    add_config_options,
    add_warp_options,
    config_from_args,
    warp_options_from_args,
)
from .progress import Ticker
from .warp3d import add_3d_options, check_world

HELP = "error analysis of one deformation"
EXAMPLES = """
examples:
  glmls analyze --example --out out/example
  glmls analyze photo.png --handles h.json --reference r.json --out report/
  glmls analyze volume.nii.gz --handles h3.json --analysis-grid 4 --out report/   # 3D
  glmls analyze mesh.ply --handles h3.json --out report/   # a mesh: at its vertices
"""


def configure(parser: argparse.ArgumentParser) -> None:
    add_example_inputs(parser, reference_required=False)
    parser.add_argument(
        "--angle",
        choices=ANGLE_MEASURES,
        default="degrees",
        help="angular error: degrees (mean change of the corner angles) or paper (eq. 11)",
    )
    add_config_options(parser)
    add_warp_options(parser)
    add_3d_options(parser)


def run(args: argparse.Namespace) -> int:
    check_example(args)
    if is_volume_input(args):  # a volume (.npy, NIfTI, TIFF stack): the 3D analysis
        return run_volume(args)
    if is_mesh_input(args):  # a mesh or point cloud (PLY, OBJ, STL): at its vertices
        return run_mesh(args)
    if args.spacing is not None:
        raise UsageError(f"--spacing: for volumes, not for images ({args.input or 'the example'})")
    check_world(args)
    config = config_from_args(args)
    warp_options = warp_options_from_args(args)
    image, handles, reference, name = example_or_files(args, need_reference=False)
    warn_about_handles(args, handles, image.shape)
    if reference is not None:  # the handles' own warnings cover them where they stand in
        warn_about_reference(args, reference, image.shape)
    reference = reference_or_handles(args, reference, handles)
    check_reference(
        args, reference, "the source handles (the reference points without --reference)"
    )
    check_picture(image, name)
    keep_inputs(args, report_paths(args.out, picture_names()))  # before any work
    ticker = Ticker("analyze", quiet=args.quiet)
    with make_mls(handles, config, image.shape) as m, ticker as tick, reported_warnings("analyze"):
        try:
            result = report(
                image,
                m,
                reference,
                grid=args.analysis_grid,
                angle=args.angle,
                warp_options=warp_options,
                fit=args.fit,
                cmap=args.cmap,
                on_stage=tick.stage,
            )
        except ValueError as error:
            raise UsageError(str(error)) from None
    result.summary["input"] = name
    paths = result.save(args.out)
    for path in paths:
        print(path)
    summary = result.summary
    field, angle = summary["error_field"], summary["triangles"]["angle"]
    unit = " deg" if args.angle == "degrees" else ""
    # the median and the trimmed mean first: one near-degenerate triangle moves the mean
    say(
        args,
        f"analyze: E_MLS median {figure(field['median'])} px^2, trimmed mean "
        f"{figure(field['trimmed_mean'])}, mean {figure(field['mean'])} "
        f"(std {figure(field['std'])})",
    )
    say(
        args,
        f"analyze: angular error ({args.angle}) median {figure(angle['median'])}{unit}, "
        f"trimmed mean {figure(angle['trimmed_mean'])}, mean {figure(angle['mean'])}; "
        f"fold-overs {summary['foldovers']['cells']} cells",
    )
    if "construction" in summary:
        built = summary["construction"]
        say(
            args,
            f"analyze: construction error (0-1) median {figure(built['median'])}, "
            f"trimmed mean {figure(built['trimmed_mean'])}, mean {figure(built['mean'])}",
        )
    return 0
