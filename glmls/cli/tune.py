"""``glmls tune``: the paper's automatic choice of the configuration (section 6)."""

from __future__ import annotations

import argparse
import csv
import io
import json
from pathlib import Path

from ..analysis.report import report
from ..analysis.tune import MEASURES, label, parse_config, search_space, tune
from ..core.config import MLSConfig
from ..files.atomic import atomic_write
from .inputs import add_example_inputs, example_or_files, make_mls, say, warn_about_handles
from .options import UsageError, positive_int
from .progress import Progress

HELP = "choose the best configuration automatically"
EXAMPLES = """
examples:
  glmls tune --example --out out/tune --trials 3
  glmls tune photo.png --handles h.json --reference r.json --out tune/ \\
      --configs 'rigid:*' 'similarity:gaussian:radius=300' --rank-by angle
"""


def configure(parser: argparse.ArgumentParser) -> None:
    add_example_inputs(parser, reference_required=True)
    parser.add_argument(
        "--trials", type=positive_int, default=5, help="random deformations per configuration"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the random deformations")
    parser.add_argument(
        "--jitter",
        type=float,
        default=None,
        help="random target displacement (pixels, std per axis); default: a quarter of the "
        "median handle displacement, at least 1%% of the diagonal",
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
        default="combined",
        help="combined: mls and angle, each relative to the best; or one measure alone",
    )


_TABLE_COLUMNS = (
    ("rank", "rank", "{:d}"),
    ("configuration", "label", "{}"),
    ("score", "combined", "{:.3f}"),
    ("E_MLS px^2", "mls_mean", "{:.4g}"),
    ("+-", "mls_spread", "{:.2g}"),
    ("angle err", "angle_mean", "{:.4g}"),
    ("+-", "angle_spread", "{:.2g}"),
    ("dist err", "distance_mean", "{:.4g}"),
    ("miss px", "handle_miss_mean", "{:.3g}"),
)


def ranking_table(rows: list[dict]) -> str:
    cells = [[fmt.format(row[key]) for _, key, fmt in _TABLE_COLUMNS] for row in rows]
    heads = [head for head, _, _ in _TABLE_COLUMNS]
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(heads)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(heads, widths, strict=True))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(lines)


def _csv_text(rows: list[dict]) -> str:
    keys = [k for k in rows[0] if k != "config"]
    config_keys = list(rows[0]["config"])
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(config_keys + keys)
    for row in rows:
        writer.writerow([row["config"][k] for k in config_keys] + [row[k] for k in keys])
    return buffer.getvalue()


def run(args: argparse.Namespace) -> int:
    image, handles, reference, name = example_or_files(args, need_reference=True)
    warn_about_handles(args, handles, image.shape)
    shape = image.shape[:2]
    try:
        configs = (
            [c for spec in args.configs for c in parse_config(spec, shape)]
            if args.configs
            else None
        )
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
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
                jitter=args.jitter,
                rank_by=args.rank_by,
                on_step=bar.advance,
            )
        except ValueError as error:
            raise UsageError(str(error)) from None
    out = Path(args.out)
    document = {
        "input": name,
        "rank_by": result.rank_by,
        "settings": result.settings,
        "ranking": result.rows,
        "skipped": result.skipped,
    }
    with atomic_write(out / "ranking.json") as tmp:
        tmp.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    with atomic_write(out / "ranking.csv") as tmp:
        tmp.write_text(_csv_text(result.rows), encoding="utf-8")
    print(ranking_table(result.rows))
    for skip in result.skipped:
        say(args, f"tune: skipped {label(MLSConfig(**skip['config']))}: {skip['reason']}")
    with make_mls(handles, result.best, shape) as m:
        winner = report(image, m, reference, grid=args.analysis_grid, cmap=args.cmap)
    winner.summary["input"] = name
    winner.save(out / "winner")
    say(args, f"tune: best by {result.rank_by}: {result.rows[0]['label']}; wrote {out}")
    return 0
