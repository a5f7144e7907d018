"""``glmls study``: the tune over an image set, and whether one configuration wins everywhere
(the paper's further studies)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import data
from ..analysis.jobs import check_jobs, check_scheduler
from ..analysis.studies import STUDY_OUTPUTS, check_item_names, study
from ..analysis.tuning import MAX_TRIALS
from .inputs import say
from .options import (
    UsageError,
    add_jobs_options,
    folder_path,
    nonnegative_int,
    parse_config_specs,
    refuse_overwriting,
)
from .progress import Progress
from .tune import trial_count

HELP = "tune every image of a set and compare the winners"
EXAMPLES = """
examples:
  glmls study --out out/study                      # the bundled set of six photographs
  glmls study set.json --out study/ --jobs 4 --configs 'rigid:*' 'similarity:gaussian'
  glmls study set.json --out study/ --scheduler tcp://head:8786    # on a Dask cluster

A manifest is {"items": [{"name": ..., "image": ..., "handles": ..., "reference": ...}]},
paths relative to the manifest (docs/study.md).
"""


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "manifest",
        metavar="MANIFEST",
        nargs="?",
        help="the image set (JSON; default: the bundled set of six photographs)",
    )
    parser.add_argument(
        "--out", metavar="DIR", type=folder_path, required=True, help="output folder"
    )
    parser.add_argument(
        "--configs",
        nargs="+",
        metavar="SPEC",
        help="transform:weight[:name=value,...], * for all; a radius left out is sized by "
        "each image's diagonal (default: the tune's search space)",
    )
    parser.add_argument(
        "--trials",
        type=trial_count,
        metavar="N",
        help=f"trials (deformations) per configuration and image, 1 to {MAX_TRIALS} "
        "(default: the tune's)",
    )
    parser.add_argument(
        "--seed", type=nonnegative_int, default=0, help="seed of the random deformations (>= 0)"
    )
    add_jobs_options(parser)


def run(args: argparse.Namespace) -> int:
    try:
        jobs, scheduler = check_jobs(args.jobs), check_scheduler(args.scheduler)
    except (ImportError, TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    if args.manifest is None:
        items, source = data.study_set(), "the bundled set"
    else:
        items, source = data.read_manifest(Path(args.manifest)), args.manifest
    out = Path(args.out)
    written = [*STUDY_OUTPUTS, *(f"{item.name}/ranking.json" for item in items)]
    try:
        check_item_names(items)
    except ValueError as error:
        raise UsageError(str(error)) from None
    # the study's outputs must not replace the manifest or a file it names, nor find their
    # places taken
    read = {} if args.manifest is None else {Path(args.manifest): "the manifest"}
    for item in items:
        files = (item.image_path, item.handles_path, item.reference_path)
        for field, path in zip(("image", "handles", "reference"), files, strict=True):
            if path is not None:
                read.setdefault(path, f"the {field} file of item {item.name}")
    refuse_overwriting([out / name for name in written], read)
    configs = args.configs
    if configs:
        try:  # a bad spec is a usage error before any work
            parse_config_specs(configs, items[0].shape, command="study", quiet=args.quiet)
        except (TypeError, ValueError) as error:
            raise UsageError(str(error)) from None
    where = f", {jobs} jobs" if jobs > 1 and scheduler is None else ""
    where += f", Dask scheduler {scheduler}" if scheduler else ""
    say(args, f"study: {len(items)} images from {source}{where}")
    with Progress(len(items), "study", quiet=args.quiet) as bar:
        try:
            result = study(
                items,
                configs=configs,
                trials=args.trials,
                seed=args.seed,
                jobs=jobs,
                scheduler=scheduler,
                on_step=bar.advance,
            )
        except ValueError as error:
            raise UsageError(str(error)) from None
    summary = result.save(Path(args.out))
    width = max(len(name) for name in summary["images"])
    for name, winner in summary["winners"].items():
        tied = len(winner["tied_with"])
        note = f" (tied with {tied} other{'s' * (tied != 1)})" if tied else ""
        print(f"{name.ljust(width)}  {winner['label']}{note}")
    print(summary["answer"])
    seconds = summary["timings"]["total_s"]
    say(args, f"study: {seconds:.1f} s; wrote {args.out}")
    return 0
