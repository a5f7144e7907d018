"""``glmls tune``: the paper's automatic choice of the configuration (section 6)."""

from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

from ..analysis.jobs import DistributedUnavailableError
from ..analysis.reporting import picture_names, report
from ..analysis.triangles import ANGLE_MEASURES
from ..analysis.tuning import MAX_TRIALS, MEASURES, label, search_space, tune
from ..analysis.tuning_trials import MAGNITUDES
from ..core.config import MLSConfig
from ..files.atomic import atomic_write
from ..files.json_out import write_json
from .inputs import (
    add_example_inputs,
    check_picture,
    check_reference,
    example_or_files,
    keep_inputs,
    make_mls,
    report_paths,
    say,
    warn_about_handles,
    warn_about_reference,
)
from .options import (
    UsageError,
    add_jobs_options,
    nonnegative_int,
    parse_config_specs,
    text_table,
)
from .progress import Progress
from .tune_construction import (
    OUTPUTS,
    check_construction_memory,
    check_construction_options,
    configure_construction,
    remove_former_construction,
    run_construction,
)

HELP = "choose the best configuration automatically"
EXAMPLES = """
examples:
  glmls tune --example --out out/tune --trials 3
  glmls tune photo.png --handles h.json --reference r.json --out tune/ \\
      --configs 'rigid:*' 'similarity:gaussian:radius=300' --rank-by angle
  glmls tune --example --out out/tune --jobs 2
  glmls tune --example --out out/tune --configs rigid:idw:alpha=1 --construction
"""


def _magnitudes(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"a fraction of the diagonal in [0, 1], got {text}")
    return value


def trial_count(text: str) -> int:
    """``--trials``: an integer from 1 to :data:`MAX_TRIALS` (a count beyond it would run for
    hours, a typing slip rather than a wish)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 1 <= value <= MAX_TRIALS:
        raise argparse.ArgumentTypeError(f"expected an integer from 1 to {MAX_TRIALS}, got {value}")
    return value


def configure(parser: argparse.ArgumentParser) -> None:
    add_example_inputs(parser, reference_required=True)
    parser.add_argument(
        "--trials",
        type=trial_count,
        default=6,
        help=f"trials per configuration: the user's edit, then edits of it (1 to {MAX_TRIALS})",
    )
    parser.add_argument(
        "--seed", type=nonnegative_int, default=0, help="seed of the random edits (>= 0)"
    )
    parser.add_argument(
        "--magnitudes",
        type=_magnitudes,
        nargs="+",
        default=list(MAGNITUDES),
        metavar="F",
        help="drags of the random edits, as fractions of the image diagonal (taken in turn)",
    )
    parser.add_argument(
        "--configs",
        nargs="+",
        metavar="SPEC",
        help="transform:weight[:name=value,...], * for all (default: all 42)",
    )
    parser.add_argument(
        "--rank-by",
        choices=MEASURES,
        default="rank",
        help="rank: the weighted rank over the criteria (angle first); or one criterion",
    )
    parser.add_argument(
        "--angle",
        choices=ANGLE_MEASURES,
        default="degrees",
        help="angular error: degrees (mean change of the corner angles) or paper (eq. 11)",
    )
    parser.add_argument(
        "--construction",
        action="store_true",
        help="also rank the constructions (quads, splat, backward...) of the winner by the "
        "construction error at the reference points (construction.json/csv)",
    )
    configure_construction(parser)
    add_jobs_options(parser)


_TABLE_COLUMNS = (
    ("rank", "rank", "{:d}"),
    ("configuration", "label", "{}"),
    ("score", "score", "{:.2f}"),
    ("angle", "angle_mean", "{:.3g}"),
    ("smooth", "smoothness_mean", "{:.3g}"),
    ("predict px", "predictive_mean", "{:.3g}"),
    ("E_MLS px^2", "mls_mean", "{:.4g}"),
    ("dist err", "distance_mean", "{:.3g}"),
    ("miss px", "handle_miss_max", "{:.2g}"),
    ("pareto", "pareto", "{}"),
    ("set apart because", "set_apart", "{}"),
)


def _cell(row: dict, key: str, fmt: str) -> str:
    value = row[key]
    if key == "set_apart":
        return "; ".join(value) if value else "-"
    if key == "pareto":
        return "*" if value else ""
    return fmt.format(value)


def ranking_table(rows: list[dict]) -> str:
    """The ranking as text: best first, the criteria's means, and why a configuration was
    set apart."""
    cells = [[_cell(row, key, fmt) for _, key, fmt in _TABLE_COLUMNS] for row in rows]
    return text_table([head for head, _, _ in _TABLE_COLUMNS], cells)


def _csv_text(rows: list[dict]) -> str:
    keys = sorted({k for row in rows for k in row} - {"config"}, key=list(rows[0]).index)
    config_keys = list(rows[0]["config"])
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(config_keys + keys)
    for row in rows:
        cells = [row[k] for k in keys]
        cells = ["; ".join(c) if isinstance(c, list) else c for c in cells]
        writer.writerow([row["config"][k] for k in config_keys] + cells)
    return buffer.getvalue()


def run(args: argparse.Namespace) -> int:
    check_construction_options(args)
    image, handles, reference, name = example_or_files(args, need_reference=True)
    warn_about_handles(args, handles, image.shape)
    warn_about_reference(args, reference, image.shape)
    check_reference(args, reference, "the example's reference points")
    check_picture(image, name)  # the winner's report pictures it, after the tuning
    check_construction_memory(args, image, reference, handles)  # ranked after the tuning
    written = ["ranking.json", "ranking.csv"]
    written += list(OUTPUTS) if args.construction else []
    outputs = [Path(args.out) / name for name in written]
    keep_inputs(args, outputs + report_paths(Path(args.out) / "winner", picture_names()))
    shape = image.shape[:2]
    try:
        configs = (  # None: the default search space
            parse_config_specs(args.configs, shape, command="tune", quiet=args.quiet)
            if args.configs
            else None
        )
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    if configs is not None:  # the tune ranks a repeat once: the progress bar counts it once
        configs = list(dict.fromkeys(configs))
    count = len(configs) if configs is not None else len(search_space(shape))
    say(args, f"tune: {name}, {count} configurations x {args.trials} random deformations")
    with Progress(count * args.trials, "tune", quiet=args.quiet) as bar:
        try:
            result = tune(
                shape,
                handles.src,
                handles.dst,
                reference,
                src_segments=handles.src_segments,
                dst_segments=handles.dst_segments,
                trials=args.trials,
                seed=args.seed,
                configs=configs,
                grid=args.analysis_grid,
                magnitudes=args.magnitudes,
                angle=args.angle,
                rank_by=args.rank_by,
                jobs=args.jobs,
                scheduler=args.scheduler,
                on_step=bar.advance,
            )
        except (ValueError, DistributedUnavailableError) as error:
            raise UsageError(str(error)) from None
    out = Path(args.out)
    document = {
        "input": name,
        "rank_by": result.rank_by,
        "settings": result.settings,
        "ranking": result.rows,
        "skipped": result.skipped,
    }
    write_json(out / "ranking.json", document)
    with atomic_write(out / "ranking.csv") as tmp:
        tmp.write_text(_csv_text(result.rows), encoding="utf-8")
    inputs = [Path(v) for v in (args.input, args.handles, args.reference) if v is not None]
    removed = remove_former_construction(args, inputs)
    if removed and not args.construction:
        names = " and ".join(path.name for path in removed)
        say(args, f"tune: removed {names} of an earlier run (no --construction this time)")
    print(ranking_table(result.rows))
    for skip in result.skipped:
        say(args, f"tune: skipped {label(MLSConfig(**skip['config']))}: {skip['reason']}")
    best = result.rows[0]
    if not best["admissible"]:
        say(args, "tune: no configuration meets every property; the best is set apart: "
            + "; ".join(best["set_apart"]))  # fmt: skip
    with make_mls(handles, result.best, shape) as m:
        winner = report(
            image, m, reference, grid=args.analysis_grid, angle=args.angle, cmap=args.cmap
        )
    winner.summary["input"] = name
    winner.save(out / "winner")
    tied = result.tied_with_best
    note = f" (tied with {', '.join(tied)}: first by name)" if tied else ""
    say(args, f"tune: best by {result.rank_by}: {best['label']}{note}; wrote {out}")
    if args.construction:
        return run_construction(args, image, handles, reference, name, result.best)
    return 0
