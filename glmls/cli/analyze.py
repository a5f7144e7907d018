"""``glmls analyze``: the error analysis of one deformation (the paper's section 5)."""

from __future__ import annotations

import argparse

from ..analysis.report import report
from .inputs import (
    add_example_inputs,
    example_or_files,
    make_mls,
    reference_or_handles,
    reported_warnings,
    say,
    warn_about_handles,
)
from .options import UsageError, add_config_options, add_warp_options, config_from_args
from .progress import Ticker

HELP = "error analysis of one deformation"
EXAMPLES = """
examples:
  glmls analyze --example --out out/example
  glmls analyze photo.png --handles h.json --reference r.json --out report/
"""


def configure(parser: argparse.ArgumentParser) -> None:
    add_example_inputs(parser, reference_required=False)
    add_config_options(parser)
    add_warp_options(parser)


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    image, handles, reference, name = example_or_files(args, need_reference=False)
    warn_about_handles(args, handles, image.shape)
    reference = reference_or_handles(args, reference, handles)
    ticker = Ticker("analyze", quiet=args.quiet)
    with make_mls(handles, config, image.shape) as m, ticker as tick, reported_warnings("analyze"):
        try:
            result = report(
                image,
                m,
                reference,
                grid=args.analysis_grid,
                method=args.method,
                interpolation=args.interpolation,
                warp_grid=args.grid,
                border=args.border,
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
    field, angle = result.summary["error_field"], result.summary["triangles"]["angle"]
    say(
        args,
        f"analyze: E_MLS mean {field['mean']:.4g} px^2 (std {field['std']:.4g}); "
        f"angular error mean {angle['mean']:.4g}; "
        f"fold-overs {result.summary['foldovers']['cells']} cells",
    )
    return 0
