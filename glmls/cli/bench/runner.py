"""``glmls bench``: glmls against the tools a user would pick instead, on the same inputs.

Each case (tool, mode, workload, image size, handle count, grid or adaptive tolerance,
transform; see :mod:`glmls.cli.bench.cases`) runs in a fresh Python process, so its peak memory
is its own (VmHWM: the whole process, interpreter and libraries included). The table gives the
median of the timed runs with their spread (min-max), the peak memory, each row's time as a
ratio to glmls end to end on the same workload, image, handles, grid (1 for the tools without
one and for the adaptive mesh) and transform, measured in the same run, and the error: the
share of output pixels that differ from the image of f's exact per-pixel inverse. Results
also go to ``bench.csv`` and ``bench.png`` in ``--out``.

``python -m glmls.cli.bench --quick`` is a CI-sized run (1024^2, 64 handles, both workloads,
grid 1 and 4, rigid; molesq affine); the full matrix is 512/1024/2048 x 16/64/256 handles x
grid 1/4/8 x every transform x both workloads. ``--tolerances 0.05,0.25`` adds glmls cases on
the adaptive mesh (where this glmls has one).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import math
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from ...core.config import TRANSFORMS
from ..options import folder_path, refuse_overwriting
from .cases import (
    GRIDLESS_TOOLS,
    MLS_TOOLS,
    MOLESQ_TRANSFORMS,
    TOOLS,
    WORKLOADS,
    Case,
    available,
    run_case,
)

HELP = "benchmarks against peers, same inputs"
#: The longest --timeout, seconds (a week): beyond it the wait's clock overflows.
MAX_TIMEOUT = 7 * 86400.0
EXAMPLES = """
examples:
  glmls bench --quick --out out/bench        # 1024^2, 64 handles, grid 1 and 4
  glmls bench --sizes 512,1024 --handles 16,64 --grids 1,4 --out out/bench
"""

QUICK = {
    "sizes": [1024],
    "handles": [64],
    "grids": [1, 4],
    "transforms": ["rigid"],
    "workloads": list(WORKLOADS),
    "tolerances": [],
    "repeat": 3,
}
FULL = {
    "sizes": [512, 1024, 2048],
    "handles": [16, 64, 256],
    "grids": [1, 4, 8],
    "transforms": list(TRANSFORMS),
    "workloads": list(WORKLOADS),
    "tolerances": [],
    "repeat": 5,
}
COLUMNS = (
    "tool",
    "mode",
    "workload",
    "size",
    "handles",
    "grid",
    "tolerance",
    "transform",
    "status",
    "median_s",
    "min_s",
    "max_s",
    "runs",
    "peak_mb",
    "ratio",
    "error_percent",
)


class UsageError(ValueError):
    """A bad command line (exit status 2)."""


def _items(text: str, what: str) -> list[str]:
    """The comma-separated items of ``text``; ``ArgumentTypeError`` for an empty one (``64,,
    64``, a trailing comma) or one given twice (its cases would run twice, and the table's
    ratios compare a case with its own second run)."""
    items = [v.strip() for v in text.split(",")]
    if not text.strip() or not all(items):
        raise argparse.ArgumentTypeError(f"expected {what} separated by commas, got {text!r}")
    twice = sorted({v for v in items if items.count(v) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"{', '.join(twice)} given twice in {text!r}")
    return items


def _int_list(text: str) -> list[int]:
    items = _items(text, "integers")
    try:
        values = [int(v) for v in items]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected integers separated by commas, got {text!r}"
        ) from None
    if min(values) < 1 or len(set(values)) < len(values):
        raise argparse.ArgumentTypeError(f"expected distinct positive integers, got {text!r}")
    return values


def _float_list(text: str) -> list[float]:
    items = _items(text, "numbers")
    try:
        values = [float(v) for v in items]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected numbers separated by commas, got {text!r}"
        ) from None
    if not all(math.isfinite(v) and v > 0 for v in values) or len(set(values)) < len(values):
        raise argparse.ArgumentTypeError(f"expected distinct positive numbers, got {text!r}")
    return values


def _name_list(choices: Sequence[str]):
    def parse(text: str) -> list[str]:
        values = _items(text, "names")
        bad = [v for v in values if v not in choices]
        if bad:
            raise argparse.ArgumentTypeError(
                f"unknown {', '.join(bad)}; choose from {', '.join(choices)}"
            )
        return values

    return parse


def _default(key: str) -> str:
    """The help's note of an option's default, in the full matrix and with --quick."""
    full, quick = FULL[key], QUICK[key]
    if isinstance(full, list):
        full, quick = ",".join(map(str, full)), ",".join(map(str, quick))
    return f"(default: {full}; --quick: {quick})"


def configure(parser: argparse.ArgumentParser) -> None:
    """Add ``glmls bench``'s options to ``parser``."""
    parser.description = "Time glmls against other image-warping tools on the same inputs."
    parser.add_argument(
        "--quick", action="store_true", help="a CI-sized subset (1024^2, 64 handles, grid 1, 4)"
    )
    parser.add_argument("--sizes", type=_int_list, help=f"image sides {_default('sizes')}")
    parser.add_argument("--handles", type=_int_list, help=f"handle counts {_default('handles')}")
    parser.add_argument("--grids", type=_int_list, help=f"mesh steps in pixels {_default('grids')}")
    parser.add_argument(
        "--transforms", type=_name_list(TRANSFORMS), help=f"transforms {_default('transforms')}"
    )
    parser.add_argument(
        "--workloads",
        type=_name_list(WORKLOADS),
        help="lattice (handles on a lattice, no folds) and/or random (random handles, folds) "
        f"{_default('workloads')}",
    )
    parser.add_argument(
        "--tolerances",
        type=_float_list,
        help="glmls on the adaptive mesh too, at these tolerances (px), e.g. 0.05,0.25",
    )
    parser.add_argument(
        "--tools",
        type=_name_list(TOOLS),
        help=f"which tools, of {','.join(TOOLS)} (default: every one installed)",
    )
    parser.add_argument("--repeat", type=int, help=f"timed runs per case {_default('repeat')}")
    parser.add_argument(
        "--timeout", type=float, default=600.0, help="seconds per case before it is abandoned"
    )
    parser.add_argument(
        "--out",
        type=folder_path,
        default=Path("bench-out"),
        help="folder for bench.csv and bench.png",
    )
    parser.add_argument("--worker", help=argparse.SUPPRESS)  # one case, in a child process


def _settings(args: argparse.Namespace) -> dict:
    base = QUICK if args.quick else FULL
    settings = {
        k: v if getattr(args, k, None) is None else getattr(args, k) for k, v in base.items()
    }
    if settings["repeat"] < 1:
        raise UsageError(f"--repeat must be >= 1, got {settings['repeat']}")
    if not 0 < args.timeout <= MAX_TIMEOUT:  # NaN and inf too: the wait takes whole seconds
        raise UsageError(f"--timeout must be > 0 and at most {MAX_TIMEOUT:g} s, got {args.timeout}")
    return settings


def plan(settings: dict, tools: Sequence[str]) -> list[Case]:
    """The cases to run: every glmls combination (end to end and per frame), and each peer
    where it applies (molesq: affine only; scikit-image and OpenCV: transform and grid do not
    apply, run once per size and handle count)."""
    cases = []
    for workload in settings.get("workloads", ["lattice"]):
        for size in settings["sizes"]:
            for handles in settings["handles"]:
                for tool in tools:
                    cases += _tool_cases(settings, tool, workload, size, handles)
    return cases


def _tool_cases(settings: dict, tool: str, workload: str, size: int, handles: int) -> list:
    transforms = settings["transforms"]
    if tool == "molesq":
        transforms = [t for t in transforms if t in MOLESQ_TRANSFORMS] or ["affine"]
    elif tool not in MLS_TOOLS:
        transforms = ["-"]
    grids = [0] if tool in GRIDLESS_TOOLS else settings["grids"]
    modes = ("e2e", "frame") if tool == "glmls" else ("e2e",)
    tolerances = settings.get("tolerances", []) if tool == "glmls" else []
    cases = []
    for transform in transforms:
        for mode in modes:
            for grid in grids:
                cases.append(Case(tool, mode, size, handles, grid, transform, workload))
            for tolerance in tolerances:
                cases.append(Case(tool, mode, size, handles, 0, transform, workload, tolerance))
    return cases


def _spawn(case: Case, repeat: int, timeout: float) -> dict:
    payload = json.dumps({"case": case.to_dict(), "repeat": repeat})
    command = [sys.executable, "-m", "glmls.cli.bench", "--worker", payload]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"status": f"timeout after {timeout:g} s"}
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"status": f"failed: {tail[:200]}"}
    return {"status": "ok"} | json.loads(lines[-1])


def _median(values: list[float]) -> float:
    ordered = sorted(values)
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else (ordered[mid - 1] + ordered[mid]) / 2


def summarise(case: Case, result: dict) -> dict:
    row = case.to_dict() | {"status": result["status"]}
    times = result.get("times")
    if times:
        row |= {
            "median_s": _median(times),
            "min_s": min(times),
            "max_s": max(times),
            "runs": len(times),
            "peak_mb": result["peak_mb"],
        }
        if result.get("error_percent") is not None:
            row["error_percent"] = result["error_percent"]
    return row


def add_ratios(rows: list[dict]) -> None:
    """ratio = a row's median / glmls end to end's on the same workload, size, handles and
    transform (grid: the same, or 1 for the tools without one and the adaptive mesh; peers:
    glmls rigid where they have no transform)."""
    base = {
        (r.get("workload", "lattice"), r["size"], r["handles"], r["grid"], r["transform"]): r[
            "median_s"
        ]
        for r in rows
        if r["tool"] == "glmls" and r["mode"] == "e2e" and "median_s" in r and r["grid"]
    }
    for row in rows:
        if "median_s" not in row:
            continue
        grid = row["grid"] or 1
        transform = row["transform"] if row["transform"] != "-" else "rigid"
        same = (row.get("workload", "lattice"), row["size"], row["handles"], grid)
        ref = base.get((*same, transform))
        if ref is None:  # e.g. molesq (affine) when glmls ran rigid only
            ref = next((v for k, v in base.items() if k[:4] == same), None)
        if ref:
            row["ratio"] = row["median_s"] / ref


def _mesh(row: dict) -> str:
    """The mesh of a row: its grid, the adaptive tolerance (``t0.05``) or ``-``."""
    if row.get("tolerance"):
        return f"t{row['tolerance']:g}"
    return str(row["grid"]) if row["grid"] else "-"


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.1f}" if seconds < 10 else f"{seconds * 1e3:.0f}"


def format_table(rows: list[dict]) -> str:
    """The rows as text; ``error %``: pixels that differ from per-pixel f's image."""
    header = (
        f"{'tool':<12} {'mode':<5} {'workload':<8} {'size':>5} {'hdl':>4} {'mesh':>5} "
        f"{'transform':<10} {'median ms':>10} {'(min-max)':>17} {'peak MB':>8} "
        f"{'x glmls':>8} {'error %':>8}"
    )
    lines = [header, "-" * len(header)]
    for r in rows:
        prefix = (
            f"{r['tool']:<12} {r['mode']:<5} {r.get('workload', 'lattice'):<8} {r['size']:>5} "
            f"{r['handles']:>4} {_mesh(r):>5} {r['transform']:<10} "
        )
        if "median_s" not in r:
            lines.append(prefix + r["status"])
            continue
        spread = f"({_ms(r['min_s'])}-{_ms(r['max_s'])})"
        ratio = f"{r['ratio']:.2f}" if "ratio" in r else ""
        error = f"{r['error_percent']:.3g}" if r.get("error_percent") is not None else ""
        lines.append(
            prefix
            + f"{_ms(r['median_s']):>10} {spread:>17} {r['peak_mb']:>8.0f} {ratio:>8} "
            + f"{error:>8}"
        )
    return "\n".join(line.rstrip() for line in lines)


def write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row.get(k, "") for k in COLUMNS})


def plot(rows: list[dict], path: Path) -> None:
    """Horizontal bars of the median time per case on a log scale (Pillow only)."""
    from PIL import Image, ImageDraw

    done = [r for r in rows if "median_s" in r]
    if not done:
        return
    colours = {
        "glmls": (31, 119, 180),
        "reference": (127, 127, 127),
        "molesq": (255, 127, 14),
        "skimage-pwa": (44, 160, 44),
        "skimage-tps": (148, 103, 189),
        "opencv-tps": (214, 39, 40),
    }
    font = _font(14)
    # one line of text per bar, with room between lines (the labels ran together at 16 px)
    bar = max(24, _text_height(font) + 10)
    labels = [_label(r) for r in done]
    label_w = 20 + max(int(font.getlength(text)) for text in labels)
    plot_w, top = 560, 50
    height = top + bar * len(done) + 60
    image = Image.new("RGB", (label_w + plot_w + 100, height), "white")
    draw = ImageDraw.Draw(image)
    lo = math.floor(math.log10(min(r["median_s"] for r in done)))
    hi = math.ceil(math.log10(max(r["median_s"] for r in done)))
    hi = max(hi, lo + 1)

    def x_of(seconds: float) -> float:
        return label_w + plot_w * (math.log10(seconds) - lo) / (hi - lo)

    draw.text((10, 12), "median time per case (log scale); lines: min-max", fill="black", font=font)
    for decade in range(lo, hi + 1):
        x = x_of(10.0**decade)
        draw.line([(x, top - 5), (x, height - 45)], fill=(220, 220, 220))
        draw.text((x - 20, height - 38), _ms(10.0**decade) + " ms", fill="black", font=font)
    for i, (r, label) in enumerate(zip(done, labels, strict=True)):
        y = top + i * bar
        if i % 2:
            draw.rectangle([0, y, image.width, y + bar - 1], fill=(245, 245, 245))
        draw.text((10, y + (bar - _text_height(font)) // 2), label, fill="black", font=font)
        colour = colours.get(r["tool"], (0, 0, 0))
        if r["tool"] == "glmls" and r["mode"] == "frame":
            colour = (120, 180, 230)
        draw.rectangle([label_w, y + 5, x_of(r["median_s"]), y + bar - 5], fill=colour)
        draw.line(
            [(x_of(r["min_s"]), y + bar // 2), (x_of(r["max_s"]), y + bar // 2)], fill="black"
        )
    image.save(path)


def _label(row: dict) -> str:
    mesh = _mesh(row)
    mesh = "" if mesh == "-" else (mesh if mesh.startswith("t") else f"g{mesh}")
    transform = "" if row["transform"] == "-" else row["transform"]
    parts = [row["tool"], row["mode"], row.get("workload", "lattice")]
    parts += [f"{row['size']}^2", f"{row['handles']}h", mesh, transform]
    return " ".join(p for p in parts if p)


def _font(size: int):
    """Pillow's scalable default font (Pillow >= 10.1), else its small bitmap font."""
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # an older Pillow without sizes
        return ImageFont.load_default()


def _text_height(font) -> int:
    box = font.getbbox("Hg^2")  # (left, top, right, bottom)
    return int(box[3] - box[1])


def run(args: argparse.Namespace) -> int:
    """Run the benchmark for parsed ``args``: 0 when every case ran, 1 when some failed,
    2 for a bad command line. Messages are one line on stderr."""
    try:
        if args.worker is not None:
            return _worker(args.worker)
        settings = _settings(args)
        tools = []
        for tool in args.tools or TOOLS:
            why = available(tool)
            if why is None:
                tools.append(tool)
            else:
                print(f"glmls bench: skipping {tool}: {why}", file=sys.stderr)
        if "glmls" not in tools:
            raise UsageError("glmls must be among --tools: ratios are against it")
        cases = plan(settings, tools)
        try:  # a folder in the place of an output: found before the runs, not after
            refuse_overwriting([args.out / "bench.csv", args.out / "bench.png"], {})
        except ValueError as error:
            raise UsageError(str(error)) from None
        made = [f for f in (args.out, *args.out.parents) if not f.exists()]
        args.out.mkdir(parents=True, exist_ok=True)  # an unwritable --out fails before the runs
        try:
            rows = [_timed(case, n, cases, settings, args) for n, case in enumerate(cases, 1)]
        except BaseException:  # Ctrl-C, or a failure: no empty folders of --out left behind
            with contextlib.suppress(OSError):
                for folder in made:  # the innermost first; rmdir stops at a non-empty one
                    folder.rmdir()
            raise
        add_ratios(rows)
        print(format_table(rows))
        write_csv(rows, args.out / "bench.csv")
        plot(rows, args.out / "bench.png")
        print(f"wrote {args.out / 'bench.csv'} and {args.out / 'bench.png'}", file=sys.stderr)
        failed = [r for r in rows if r["status"] != "ok"]
        return 1 if failed else 0
    except UsageError as error:
        print(f"glmls bench: {error}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError, ValueError) as error:
        print(f"glmls bench: {error}", file=sys.stderr)
        return 1


def _timed(case: Case, number: int, cases: list[Case], settings: dict, args) -> dict:
    """The summary row of ``case``, the ``number``-th of ``cases``, its line on stderr."""
    mesh = f"tolerance {case.tolerance:g}" if case.tolerance else f"grid {case.grid or '-'}"
    print(
        f"[{number}/{len(cases)}] {case.tool} {case.mode} {case.workload} {case.size}^2 "
        f"{case.handles} handles {mesh} {case.transform}",
        file=sys.stderr,
        flush=True,
    )
    return summarise(case, _spawn(case, settings["repeat"], args.timeout))


def _worker(payload: str) -> int:
    request = json.loads(payload)
    result = run_case(Case(**request["case"]), int(request["repeat"]))
    print(json.dumps(result), flush=True)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="glmls bench")
    configure(parser)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse has printed its one-line usage error
        return int(exit_.code or 0)
    return run(args)
