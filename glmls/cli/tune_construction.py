"""``glmls tune --construction``: rank the ways of building the deformed image (quads nearest and
linear, splat, backward...) by the construction error at the reference points
(:doc:`/construction`), for one MLS configuration."""

from __future__ import annotations

import argparse
import csv
import dataclasses
import io
import json
from pathlib import Path

import numpy as np

from ..analysis.construction import DEFAULT_RADIUS, check_window_memory
from ..analysis.construction_ranking import (
    parse_construction,
    parse_constructions,
    rank_constructions,
)
from ..core.config import MLSConfig
from ..core.handleset import HandleSet
from ..files.atomic import atomic_write, same_file
from ..files.json_out import write_json
from .inputs import make_mls, reference_or_handles, say
from .options import UsageError, nonnegative_int, text_table

__all__ = [
    "OUTPUTS",
    "check_construction_memory",
    "check_construction_options",
    "configure_construction",
    "construction_table",
    "remove_former_construction",
    "run_construction",
]

UNITS = "RMS colour difference per reference point, intensity scaled to 0-1"
#: The files of the ranking, in ``--out``.
OUTPUTS = ("construction.json", "construction.csv")


def configure_construction(parser: argparse.ArgumentParser) -> None:
    """The options of the construction ranking (``--construction-radius``,
    ``--construction-methods``)."""
    parser.add_argument(
        "--construction-radius",
        type=nonnegative_int,
        default=DEFAULT_RADIUS,
        metavar="K",
        help="construction error window: (2K + 1)² output pixels around each f(r)",
    )
    parser.add_argument(
        "--construction-methods",
        nargs="+",
        metavar="METHOD[:INTERP]",
        help="constructions to rank, e.g. quads:linear splat backward:nearest "
        "(default: quads and backward nearest and linear, splat, paper-quads where offered)",
    )


def check_construction_options(args: argparse.Namespace) -> None:
    """:class:`UsageError`, before any work, for ``--construction-methods`` or
    ``--construction-radius`` without ``--construction`` (they would change nothing), or a
    construction that is not one or is named twice (the ranking would otherwise fail after
    the whole tune)."""
    given = [
        option
        for option, value in (
            ("--construction-methods", args.construction_methods is not None),
            ("--construction-radius", args.construction_radius != DEFAULT_RADIUS),
        )
        if value
    ]
    if given and not args.construction:
        raise UsageError(f"{', '.join(given)}: for --construction, which is not given")
    specs = args.construction_methods or ()
    for spec in specs:
        try:
            parse_construction(spec)
        except (TypeError, ValueError) as error:
            raise UsageError(f"--construction-methods {spec}: {error}") from None
    try:
        parse_constructions(specs)
    except ValueError as error:
        raise UsageError(f"--construction-methods: {error}") from None


def check_construction_memory(args: argparse.Namespace, image, reference, handles) -> None:
    """:class:`UsageError`, before the tune, for ``--construction`` windows of
    ``--construction-radius`` around the reference points (or the handles) that need more
    than this machine's memory: the ranking runs after the whole tune."""
    if not args.construction:
        return
    # the points reference_or_handles ranks at (without its word, said when it ranks)
    points = len(reference) if reference is not None else len(handles.source_points())
    channels = image.shape[2] if image.ndim == 3 else 1
    try:
        check_window_memory(args.construction_radius, points, channels)
    except ValueError as error:
        raise UsageError(f"--construction-radius {args.construction_radius}: {error}") from None


_TABLE_COLUMNS = (
    ("rank", "rank", "{:d}"),
    ("construction", "label", "{}"),
    ("mean", "mean", "{:.4g}"),
    ("median", "median", "{:.4g}"),
    ("std", "std", "{:.2g}"),
    ("max", "max", "{:.4g}"),
    ("points", "count", "{:d}"),
    ("time s", "time_s", "{:.3g}"),
)


def _cell(row: dict, key: str, fmt: str) -> str:
    value = row[key] if key in row else row["stats"].get(key)
    return "-" if value is None else fmt.format(value)


def construction_table(rows: list[dict]) -> str:
    """The ranking as a plain-text table, one line per construction."""
    cells = [[_cell(row, key, fmt) for _, key, fmt in _TABLE_COLUMNS] for row in rows]
    return text_table([head for head, _, _ in _TABLE_COLUMNS], cells)


_CSV_KEYS = ("rank", "method", "interpolation", "label", "mean", "median")
_CSV_STATS = ("std", "min", "max", "count", "nan_count")
_CSV_COLUMNS = (*_CSV_KEYS, *_CSV_STATS, "time_s")
_CSV_HEAD = ",".join(_CSV_COLUMNS)
#: Larger than any ranking this command writes: a file that size is someone else's.
_MOST_BYTES = 1 << 20


def _csv_text(rows: list[dict]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(_CSV_COLUMNS)
    for row in rows:
        stats = [row["stats"].get(k) for k in _CSV_STATS]
        writer.writerow([row[k] for k in _CSV_KEYS] + stats + [row["time_s"]])
    return buffer.getvalue()


def _written_here(path: Path) -> bool:
    """Whether ``path`` is a file of the construction ranking as :func:`run_construction`
    writes it (its keys and units, or its CSV header): only those are removed."""
    try:
        if not path.is_file() or path.stat().st_size > _MOST_BYTES:
            return False
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    if path.suffix == ".csv":
        return text.partition("\n")[0] == _CSV_HEAD
    try:
        document = json.loads(text)
    except (ValueError, RecursionError):
        return False
    keys = {"input", "config", "settings", "units", "ranking"}
    return isinstance(document, dict) and keys <= document.keys() and document["units"] == UNITS


def remove_former_construction(args: argparse.Namespace, inputs: list[Path]) -> list[Path]:
    """Remove from ``args.out`` the construction ranking of an earlier run (:data:`OUTPUTS`,
    recognised by their content; never one of ``inputs``): beside this run's ranking it
    would pass for this run's. A ranking this run writes takes their place later. Returns
    the files removed; one that cannot be removed is an ``OSError``."""
    removed = []
    for name in OUTPUTS:
        path = Path(args.out) / name
        if not _written_here(path) or any(same_file(path, other) for other in inputs):
            continue
        try:
            path.unlink()
        except FileNotFoundError:
            continue
        except OSError as error:
            raise OSError(
                f"{path}: an earlier run's, which would pass for this run's, cannot be "
                f"removed: {error.strerror or error}"
            ) from None
        removed.append(path)
    return removed


def run_construction(
    args: argparse.Namespace,
    image: np.ndarray,
    handles: HandleSet,
    reference: np.ndarray | None,
    name: str,
    config: MLSConfig,
) -> int:
    """Rank the constructions of ``image`` deformed by the MLS of ``handles`` with ``config``
    at the ``reference`` points (None: the source handles), print the table and write
    ``construction.json`` (``input``, ``config``, ``settings``, ``ranking``) and
    ``construction.csv`` into ``args.out``. Reads ``args.out``, ``args.quiet`` and, where
    :func:`configure_construction` added them, ``args.construction_radius`` and
    ``args.construction_methods``. Returns the exit status (0)."""
    shape = image.shape[:2]
    radius = getattr(args, "construction_radius", DEFAULT_RADIUS)
    methods = getattr(args, "construction_methods", None)
    points = reference_or_handles(args, reference, handles)
    say(args, f"tune --construction: {name}, ranking the constructions at {len(points)} points")
    with make_mls(handles, config, shape) as m:
        try:
            rows = rank_constructions(image, m, points, methods=methods, radius=radius)
        except ValueError as error:
            raise UsageError(str(error)) from None
    out = Path(args.out)
    document = {
        "input": name,
        "config": dataclasses.asdict(config),
        "settings": {"radius": radius, "window": 2 * radius + 1, "points": len(points)},
        "units": UNITS,
        "ranking": rows,
    }
    write_json(out / OUTPUTS[0], document)
    with atomic_write(out / OUTPUTS[1]) as tmp:
        tmp.write_text(_csv_text(rows), encoding="utf-8")
    print(construction_table(rows))
    if rows:
        say(args, f"tune --construction: best: {rows[0]['label']}; wrote {out}")
    return 0
