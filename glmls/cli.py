"""The ``glmls`` command line: ``glmls warp``, ``glmls analyze``, ``glmls tune``.

Exit status: 0 on success, 2 for usage and input errors (bad options, malformed files), 1 for
failures while running (no OpenGL, an unreadable image...). Messages and progress go to
stderr, results to stdout or files; a user's mistake never prints a traceback.
"""

from __future__ import annotations

import argparse
import csv
import glob
import io
import json
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import __version__, bench, data
from .app import command as app_command
from .argtypes import positive_int
from .config import TRANSFORMS, WEIGHTS, MLSConfig
from .errors import GLUnavailableError
from .files import InputFileError, atomic_write, read_handles, read_points
from .io import imread, imwrite
from .mls import MLS
from .pipeline import INTERPOLATIONS, METHODS
from .progress import Progress
from .report import report
from .tune import MEASURES, label, parse_config, tune

EXIT_USAGE = 2
EXIT_FAILURE = 1
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")


class UsageError(Exception):
    """A mistake in the command line or its input files (exit status 2)."""


def _add_config_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("MLS configuration")
    group.add_argument("--transform", choices=TRANSFORMS, default="rigid")
    group.add_argument("--weight", choices=WEIGHTS, default="idw")
    group.add_argument("--alpha", type=float, default=1.0, help="idw power (default 1)")
    group.add_argument("--s", type=float, default=1e-8, help="idw adjusting term (default 1e-8)")
    group.add_argument(
        "--radius", type=float, default=None, help="influence radius in pixels (default: diagonal)"
    )
    group.add_argument(
        "--interpolating", action="store_true", help="make any weight interpolate the handles"
    )


def config_from_args(args: argparse.Namespace) -> MLSConfig:
    try:
        return MLSConfig(
            transform=args.transform,
            weight=args.weight,
            alpha=args.alpha,
            s=args.s,
            radius=args.radius,
            interpolating=args.interpolating,
        )
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None


def parse_background(text: str) -> float | tuple[float, ...]:
    """``0``, ``255``, ``0.5`` or a comma list per channel (``255,255,255`` or ``0,0,0,0``)."""
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number or comma-separated numbers per channel, got {text!r}"
        ) from None
    if not 1 <= len(values) <= 4:
        raise argparse.ArgumentTypeError(f"expected 1 to 4 values, got {len(values)}")
    return values[0] if len(values) == 1 else values


def _inputs(pattern: str) -> tuple[list[Path], bool]:
    """The images named by ``pattern`` (a file, a folder or a glob) and whether it is many."""
    path = Path(pattern)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        many = True
    elif path.is_file():
        return [path], False
    else:
        many = glob.has_magic(pattern)
        if not many:
            raise UsageError(f"{pattern}: no such file or folder")
        files = sorted(Path(p) for p in glob.glob(pattern) if Path(p).is_file())
    if not files:
        raise UsageError(f"{pattern}: no images found")
    return files, many


def _read_image(path: Path) -> np.ndarray:
    try:
        return imread(path)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such file") from None
    except (OSError, ValueError) as error:
        raise UsageError(f"{path}: cannot read the image: {error}") from None


def _write_image(path: Path, image: np.ndarray) -> None:
    with atomic_write(path) as tmp:
        imwrite(tmp, image)


def _make_mls(src, dst, config: MLSConfig, shape) -> MLS:
    try:
        return MLS.from_config(src, dst, config, shape=shape)
    except (TypeError, ValueError) as error:
        raise UsageError(f"handles: {error}") from None


def _say(args: argparse.Namespace, message: str) -> None:
    if not args.quiet:
        print(message, file=sys.stderr)


# -- glmls warp -------------------------------------------------------------------------------


def _warp_options(args: argparse.Namespace) -> dict:
    return {
        "method": args.method,
        "interpolation": args.interpolation,
        "grid": args.grid,
        "background": args.background,
    }


def cmd_warp(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    src, dst = read_handles(args.handles)
    files, many = _inputs(args.input)
    out = Path(args.output)
    if many and out.exists() and not out.is_dir():
        raise UsageError(f"{out}: must be a folder when IN names several images")
    targets = [out / f.name for f in files] if many or out.is_dir() else [out]
    with Progress(len(files), "warp", quiet=args.quiet or not many) as bar:
        for source, target in zip(files, targets, strict=True):
            image = _read_image(source)
            with _make_mls(src, dst, config, image.shape) as m:
                try:
                    result = m.warp(image, **_warp_options(args))
                except (TypeError, ValueError) as error:
                    raise UsageError(f"{source}: {error}") from None
            _write_image(target, result)
            print(target)
            bar.advance()
    return 0


# -- glmls analyze ----------------------------------------------------------------------------


def _example_or_files(args: argparse.Namespace, *, need_reference: bool):
    """(image, src, dst, reference or None, name) from --example or the given files."""
    if args.example:
        return (
            data.astronaut(),
            *data.astronaut_handles(),
            data.astronaut_reference_points(),
            "astronaut (bundled example)",
        )
    missing = [o for o, v in (("IN", args.input), ("--handles", args.handles)) if v is None]
    if need_reference and args.reference is None:
        missing.append("--reference")
    if missing:
        raise UsageError(f"missing {', '.join(missing)} (or use --example)")
    image = _read_image(Path(args.input))
    src, dst = read_handles(args.handles)
    reference = read_points(args.reference) if args.reference else None
    return image, src, dst, reference, str(args.input)


def cmd_analyze(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    image, src, dst, reference, name = _example_or_files(args, need_reference=False)
    if reference is None:
        _say(args, "analyze: no --reference given: the source handles are the reference points")
        reference = src
    with _make_mls(src, dst, config, image.shape) as m:
        try:
            result = report(
                image,
                m,
                reference,
                grid=args.analysis_grid,
                method=args.method,
                interpolation=args.interpolation,
                warp_grid=args.grid,
                cmap=args.cmap,
            )
        except ValueError as error:
            raise UsageError(str(error)) from None
    result.summary["input"] = name
    paths = result.save(args.out)
    for path in paths:
        print(path)
    field, angle = result.summary["error_field"], result.summary["triangles"]["angle"]
    _say(
        args,
        f"analyze: E_MLS mean {field['mean']:.4g} px^2 (std {field['std']:.4g}); "
        f"angular error mean {angle['mean']:.4g}; "
        f"fold-overs {result.summary['foldovers']['cells']} cells",
    )
    return 0


# -- glmls tune -------------------------------------------------------------------------------

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


def cmd_tune(args: argparse.Namespace) -> int:
    image, src, dst, reference, name = _example_or_files(args, need_reference=True)
    shape = image.shape[:2]
    try:
        configs = (
            [c for spec in args.configs for c in parse_config(spec, shape)]
            if args.configs
            else None
        )
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    count = len(configs) if configs is not None else 42
    _say(args, f"tune: {name}, {count} configurations x {args.trials} random deformations")
    with Progress(count * args.trials, "tune", quiet=args.quiet) as bar:
        try:
            result = tune(
                shape,
                src,
                dst,
                reference,
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
        _say(args, f"tune: skipped {label(MLSConfig(**skip['config']))}: {skip['reason']}")
    with MLS.from_config(src, dst, result.best, shape=shape) as m:
        winner = report(image, m, reference, grid=args.analysis_grid, cmap=args.cmap)
    winner.summary["input"] = name
    winner.save(out / "winner")
    _say(args, f"tune: best by {result.rank_by}: {result.rows[0]['label']}; wrote {out}")
    return 0


# -- the parser -------------------------------------------------------------------------------

_EXAMPLES = {
    "warp": """
        examples:
          glmls warp photo.png out.png --handles handles.json --transform similarity
          glmls warp 'frames/*.png' warped/ --handles landmarks.csv --method backward
        """,
    "analyze": """
        examples:
          glmls analyze --example --out out/example
          glmls analyze photo.png --handles h.json --reference r.json --out report/
        """,
    "tune": """
        examples:
          glmls tune --example --out out/tune --trials 3
          glmls tune photo.png --handles h.json --reference r.json --out tune/ \\
              --configs 'rigid:*' 'similarity:gaussian:radius=300' --rank-by angle
        """,
    "bench": """
        examples:
          glmls bench --quick --out out/bench        # 1024^2, 64 handles, grid 1 and 4
          glmls bench --sizes 512,1024 --handles 16,64 --grids 1,4 --out out/bench
        """,
    "demo": """
        examples:
          glmls demo                                   # the bundled photograph
          glmls demo photo.png --handles h.json
          xvfb-run -a glmls demo --replay drag.json --frames 30 --screenshot shot.png
        """,
}


def _subparser(subparsers, name: str, help_text: str) -> argparse.ArgumentParser:
    return subparsers.add_parser(
        name,
        help=help_text,
        description=help_text,
        epilog=textwrap.dedent(_EXAMPLES[name]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def _add_warp_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("image construction")
    group.add_argument("--method", choices=METHODS, default="quads")
    group.add_argument("--interpolation", choices=INTERPOLATIONS, default="nearest")
    group.add_argument(
        "--grid", type=positive_int, default=1, help="mesh step in pixels (default 1)"
    )


def _add_example_inputs(parser: argparse.ArgumentParser, *, reference_required: bool) -> None:
    parser.add_argument("input", metavar="IN", nargs="?", help="the image")
    parser.add_argument("--handles", metavar="H", help="handles file (JSON, CSV or BigWarp)")
    parser.add_argument(
        "--reference",
        metavar="R",
        help="reference points file (JSON or CSV)"
        + ("" if reference_required else "; default: the source handles"),
    )
    parser.add_argument(
        "--example", action="store_true", help="use the bundled photograph, handles and points"
    )
    parser.add_argument("--out", metavar="DIR", required=True, help="output folder")
    parser.add_argument(
        "--analysis-grid",
        type=positive_int,
        default=1 if not reference_required else 4,
        help="mesh step of the error field in pixels",
    )
    parser.add_argument(
        "--cmap",
        choices=("viridis", "linear"),
        default="viridis",
        help="colour map: viridis, or the paper's two-colour linear map",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glmls",
        description="Image deformation by Moving Least Squares on the GPU, with error analysis.",
    )
    parser.add_argument("--version", action="version", version=f"glmls {__version__}")
    parser.add_argument("--quiet", action="store_true", help="no progress or messages")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    warp = _subparser(subparsers, "warp", "deform images by MLS")
    warp.add_argument("input", metavar="IN", help="an image, a folder or a glob")
    warp.add_argument("output", metavar="OUT", help="the output image (a folder for many)")
    warp.add_argument("--handles", metavar="H", required=True, help="handles file")
    warp.add_argument(
        "--background",
        type=parse_background,
        default=0.0,
        help="value of uncovered pixels: one number or one per channel (default 0)",
    )
    _add_config_options(warp)
    _add_warp_options(warp)
    warp.set_defaults(run=cmd_warp)

    analyze = _subparser(subparsers, "analyze", "error analysis of one deformation")
    _add_example_inputs(analyze, reference_required=False)
    _add_config_options(analyze)
    _add_warp_options(analyze)
    analyze.set_defaults(run=cmd_analyze)

    tune_parser = _subparser(subparsers, "tune", "choose the best configuration automatically")
    _add_example_inputs(tune_parser, reference_required=True)
    tune_parser.add_argument("--trials", type=positive_int, default=5)
    tune_parser.add_argument("--seed", type=int, default=0)
    tune_parser.add_argument(
        "--jitter",
        type=float,
        default=None,
        help="random target displacement (pixels, std per axis); default: a quarter of the "
        "median handle displacement, at least 1%% of the diagonal",
    )
    tune_parser.add_argument(
        "--configs",
        nargs="+",
        metavar="SPEC",
        help="transform:weight[:name=value,...], * for all (default: all 42)",
    )
    tune_parser.add_argument("--rank-by", choices=MEASURES, default="combined")
    tune_parser.set_defaults(run=cmd_tune)
    demo = _subparser(subparsers, "demo", "the real-time window")
    app_command.configure_parser(demo)
    demo.set_defaults(run=app_command.run)
    bench_parser = _subparser(subparsers, "bench", "benchmarks against peers, same inputs")
    bench.configure_parser(bench_parser)
    bench_parser.set_defaults(run=bench.run)
    for sub in (warp, analyze, tune_parser, demo, bench_parser):
        sub.add_argument(
            "--quiet",
            action="store_true",
            default=argparse.SUPPRESS,
            help="no progress or messages",
        )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (UsageError, InputFileError) as error:
        print(f"glmls {args.command}: {error}", file=sys.stderr)
        return EXIT_USAGE
    except GLUnavailableError as error:
        print(f"glmls {args.command}: {error}", file=sys.stderr)
        return EXIT_FAILURE
    except OSError as error:
        print(f"glmls {args.command}: {error}", file=sys.stderr)
        return EXIT_FAILURE
    except KeyboardInterrupt:
        print(f"glmls {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
