"""``glmls augment``: random MLS deformations of images (:class:`glmls.augment.Augment`),
N per input, with their labels (keypoints, boxes) moved along.

Output: for input ``NAME.EXT`` and k = 0 .. N - 1, ``OUT/NAME_k.EXT`` (k zero-padded; EXT
``.png`` where glmls does not write EXT: a GIF), drawn
with sample index ``i * N + k`` for the i-th input (sorted by name), so that the same command
gives the same images whatever ``--jobs``; and ``OUT/labels.json``: per output image its moved
keypoints and boxes (where labels were given) with their validity, and its draw (``params``:
the handles and options that :meth:`glmls.augment.Augment.replay` takes). Everything is
written under temporary names and renamed at the end: a failed or stopped run leaves no
output (and removes the folders it made); Ctrl-C waits for the final renames. A run into a
folder that holds an earlier run's set replaces it: the images that the earlier
``labels.json`` names and this run does not write are removed once the new set is in place.

The labels file (``--labels``) is a JSON object keyed by input file name:
``{"photo.png": {"keypoints": [[x, y], ...], "boxes": [[x_min, y_min, x_max, y_max], ...]}}``
in pixels (x, y) = (column, row), pixel centres at integers; either key may be left out.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..analysis.jobs import check_jobs, check_scheduler, run_jobs
from ..augment import PRESETS, Augment
from ..core.handles import COORDINATE_LIMIT
from ..files.atomic import remove_leftovers
from ..files.images import WRITABLE, check_writable, image_bytes, shown_shape
from ..files.parsing import read_text
from ..imaging.source import BORDERS, INTERPOLATIONS, check_image
from .augment_outputs import former_outputs, remove_former, rename_all
from .inputs import image_inputs, kept_profile, read_image, say
from .options import (
    UsageError,
    add_jobs_options,
    add_max_pixels,
    below_a_file,
    positive_float,
    positive_int,
)

#: The most images one run writes (inputs times --n): each is named and checked for a
#: clash before any work, and listed in labels.json.
MAX_OUTPUTS = 1_000_000

HELP = "random MLS deformations of images, with their labels (data augmentation)"
EXAMPLES = """
examples:
  glmls augment photo.png out/ --n 10 --preset grid --seed 0
  glmls augment lines/ out/ --n 4 --preset text-distort --segments 6
  glmls augment faces/ out/ --n 5 --preset landmarks --labels landmarks.json --jobs 4
  glmls augment photo.png out/ --n 8 --preset grid --displacement 6 --units pixels
"""

#: The preset options with a command-line flag, and their types.
PRESET_FLAGS = {
    "rows": positive_int,
    "cols": positive_int,
    "displacement": float,
    "units": str,
    "segments": positive_int,
    "radius": float,
}
LABELS_NAME = "labels.json"
#: The most bytes of copies of one input that one call of :class:`Augment` deforms.
CHUNK_BYTES = 64 << 20


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="IN", help="an image, a folder or a glob")
    parser.add_argument("output", metavar="OUT", help="the output folder (made if needed)")
    parser.add_argument("--n", type=positive_int, default=10, help="deformed images per input")
    parser.add_argument("--preset", choices=tuple(PRESETS), default="grid", help="the deformation")
    parser.add_argument("--seed", type=int, default=0, help="the random seed (>= 0)")
    parser.add_argument(
        "--labels",
        metavar="JSON",
        help='keypoints and boxes per input file name: {"photo.png": {"keypoints": [[x, y], '
        '...], "boxes": [[x_min, y_min, x_max, y_max], ...]}}, in pixels',
    )
    group = parser.add_argument_group("preset options (those of the chosen preset)")
    group.add_argument("--rows", type=positive_int, help="grid: rows of handles (default: 4)")
    group.add_argument("--cols", type=positive_int, help="grid: columns of handles (default: 4)")
    group.add_argument(
        "--displacement",
        type=float,
        help="grid, landmarks: the largest offset per axis (default: 0.03)",
    )
    group.add_argument(
        "--units",
        choices=("fraction", "pixels"),
        help="of --displacement: a fraction of the image's width and height, or pixels "
        "(default: fraction)",
    )
    group.add_argument(
        "--segments", type=positive_int, help="text-*: patches along the width (default: 4)"
    )
    group.add_argument(
        "--radius",
        type=float,
        help="text-*: the radius R in pixels (default: text-distort W / segments / 3, "
        "text-stretch 4 W / 5 / segments, text-perspective H / 2)",
    )
    warp = parser.add_argument_group("warp")
    warp.add_argument(
        "--transform",
        choices=("affine", "similarity", "rigid"),
        default=None,
        help="the MLS transform (default: the preset's, affine for text-perspective, "
        "else similarity)",
    )
    warp.add_argument(
        "--interpolation",
        choices=INTERPOLATIONS,
        default="linear",
        help="nearest: one source pixel's value; linear: bilinear",
    )
    warp.add_argument(
        "--border",
        choices=BORDERS,
        default="edge",
        help="what lies beyond the image, numpy.pad's names",
    )
    parser.add_argument(
        "--box-step",
        type=positive_float,
        default=2.0,
        help="pixels between points of a box's outline",
    )
    add_max_pixels(parser)
    add_jobs_options(parser)


@dataclasses.dataclass(frozen=True)
class AugmentTask:
    """One input image of ``glmls augment``, as sent to a worker process (picklable)."""

    source: Path
    folder: Path
    first_index: int
    count: int
    preset: str
    preset_options: dict
    seed: int
    warp_options: dict
    box_step: float
    labels: dict | None
    max_pixels: int


@dataclasses.dataclass(frozen=True)
class AugmentOutcome:
    """The temporary files written (temporary, final) and the labels entries, or an error
    and whether it is a failure to write (exit status 1) rather than a mistake (2)."""

    written: tuple[tuple[str, str], ...] = ()
    labels: dict = dataclasses.field(default_factory=dict)
    error: str | None = None
    unwritten: bool = False


def _unnumbered(error: Exception) -> str:
    """``error``'s message without the ``images[k]: `` that names a copy of one input in a
    batch of its copies (the input's name stands before it)."""
    return re.sub(r"^images\[\d+\]: ", "", str(error))


def _check_draw(augment: Augment, source: Path, first: int, landmarks: object) -> None:
    """``UsageError`` naming ``source`` where ``augment`` cannot draw for an image of its
    size (the size read from the file's header: a text preset's ``--segments`` finer than
    its pixels, say), so that no image is deformed before a later input is refused;
    ``landmarks``: the labels' keypoints, the ``landmarks`` preset's handles. A file whose
    header does not say is left to its reading, which names what is wrong."""
    shape = shown_shape(source)
    if shape is None:
        return
    given = None if landmarks is None else [np.asarray(landmarks, np.float64)]
    try:
        augment.draw([shape], indices=[first], landmarks=given)
    except (TypeError, ValueError) as error:
        raise UsageError(f"{source}: {_unnumbered(error)}") from None


def _names(task: AugmentTask) -> list[Path]:
    return _output_names(task.folder, task.source, task.count)


def _output_names(folder: Path, source: Path, count: int) -> list[Path]:
    """``folder/NAME_k.EXT`` for input ``NAME.EXT``, k = 0 .. count - 1 zero-padded (EXT
    ``.png`` where glmls does not write EXT: a GIF)."""
    width = max(3, len(str(count - 1)))
    suffix = _output_suffix(source)
    return [folder / f"{source.stem}_{k:0{width}d}{suffix}" for k in range(count)]


def _output_suffix(source: Path) -> str:
    return source.suffix if source.suffix.lower() in WRITABLE else ".png"


def augment_file(task: AugmentTask) -> AugmentOutcome:
    """Read one image, deform it ``count`` times, write the results under temporary names
    beside their final ones; a mistake in the input is an outcome with ``error``. The
    copies are deformed :data:`CHUNK_BYTES` of them at a time (the same images: each draw
    is numbered by its index alone), so that ``--n 1000`` of a large image does not hold a
    thousand copies at once."""
    written: list[tuple[str, str]] = []
    try:
        image = read_image(task.source, task.max_pixels, prefix="glmls augment")
        targets = _names(task)
        channels = 1 if image.ndim == 2 else image.shape[2]
        labels = task.labels or {}
        keypoints = labels.get("keypoints")
        boxes = labels.get("boxes")
        try:
            check_image(image, str(task.source))  # before the outputs: no suffix takes int16
        except (TypeError, ValueError) as error:
            raise UsageError(str(error)) from None
        try:
            for target in targets:
                check_writable(target, image.dtype, channels)
            aug = Augment(
                task.preset,
                seed=task.seed,
                warp_options=task.warp_options,
                box_step=task.box_step,
                **task.preset_options,
            )
        except (TypeError, ValueError) as error:
            raise UsageError(f"{task.source}: {error}") from None
        profile = kept_profile(task.source, targets[0], channels, "glmls augment")
        entries = {}
        step = max(1, CHUNK_BYTES // max(1, image.nbytes))
        for start in range(0, task.count, step):
            count = min(step, task.count - start)
            first = task.first_index + start
            try:
                result = aug(
                    np.stack([image] * count),
                    keypoints=None if keypoints is None else [keypoints] * count,
                    boxes=None if boxes is None else [boxes] * count,
                    indices=range(first, first + count),
                )
            except (TypeError, ValueError) as error:
                raise UsageError(f"{task.source}: {_unnumbered(error)}") from None
            for k, target in enumerate(targets[start : start + count]):
                fd, name = tempfile.mkstemp(
                    prefix=f".{target.name}.", suffix=target.suffix, dir=task.folder
                )
                os.close(fd)
                written.append((name, str(target)))
                data = image_bytes(target, result.images[k], icc_profile=profile)
                try:  # a checked write: a short one (a full disk) raises
                    Path(name).write_bytes(data)
                except OSError as error:
                    raise OSError(f"{target}: cannot write: {error.strerror or error}") from None
                entry: dict = {"source": task.source.name, "params": result.params[k]}
                if keypoints is not None:
                    entry["keypoints"] = np.asarray(result.keypoints[k]).tolist()
                    entry["keypoints_valid"] = np.asarray(result.keypoints_valid[k]).tolist()
                if boxes is not None:
                    entry["boxes"] = np.asarray(result.boxes[k]).tolist()
                    entry["boxes_valid"] = np.asarray(result.boxes_valid[k]).tolist()
                entries[target.name] = entry
    except BaseException as error:  # whatever stops it, it leaves no temporary file
        for name, _ in written:
            Path(name).unlink(missing_ok=True)
        if isinstance(error, (UsageError, OSError)):
            return AugmentOutcome(error=str(error), unwritten=isinstance(error, OSError))
        raise
    return AugmentOutcome(tuple(written), entries)


def read_labels(path: str, files: list[Path]) -> dict[str, dict]:
    """The labels file: per input file name, its ``keypoints`` and ``boxes`` as lists;
    :class:`UsageError` naming what is wrong (:class:`InputFileError` where the file cannot
    be read)."""
    text = read_text(Path(path))  # a byte order mark read as the handle files read it
    try:
        data = json.loads(text, object_pairs_hook=_unique_keys)
    except UsageError as error:
        raise UsageError(f"{path}: {error}") from None
    except ValueError as error:  # JSON's faults, and an integer of more than 4300 digits
        raise UsageError(f"{path}: not a JSON labels file: {error}") from None
    except RecursionError:
        raise UsageError(f"{path}: not a JSON labels file: nested too deeply") from None
    if not isinstance(data, dict):
        raise UsageError(f"{path}: expected an object keyed by image file name")
    known = {f.name for f in files}
    for name, entry in data.items():
        if name not in known:
            raise UsageError(f"{path}: {name!r} names no input image")
        if not isinstance(entry, dict) or set(entry) - {"keypoints", "boxes"}:
            raise UsageError(f"{path}: {name!r} must hold 'keypoints' and/or 'boxes' only")
        for key, columns in (("keypoints", 2), ("boxes", 4)):
            if key not in entry:
                continue
            try:  # JSON's true and false are no coordinates, though numpy takes them as 1, 0
                array = np.asarray(entry[key], dtype=np.float64) if _numbers(entry[key]) else None
            except (TypeError, ValueError):
                array = None
            if array is not None and array.size == 0:
                array = array.reshape(0, columns)
            if array is None or array.ndim != 2 or array.shape[1] != columns:
                raise UsageError(
                    f"{path}: {name!r} {key} must be a list of [{columns} numbers], got "
                    f"{json.dumps(entry[key])[:60]}"
                )
            if not np.isfinite(array).all():
                raise UsageError(f"{path}: {name!r} {key} holds values that are not finite")
            _check_label_rows(array, f"{path}: {name!r} {key}", boxes=key == "boxes")
            entry[key] = array.tolist()
    return data


def _check_label_rows(array: np.ndarray, name: str, *, boxes: bool) -> None:
    """:class:`UsageError` naming the first row of a labels entry that lies beyond the
    coordinate range, or a box whose maximum lies below its minimum: checked as the file is
    read, in its own terms (:class:`Augment` would name the row by its place in a batch of
    copies, after the work on the inputs before it)."""
    reach = np.abs(array).max(axis=1, initial=0.0)
    if len(array) and reach.max() > COORDINATE_LIMIT:
        row = int(np.argmax(reach))
        raise UsageError(
            f"{name}[{row}] {array[row].tolist()} lies beyond ±{COORDINATE_LIMIT:g} px of "
            "the origin"
        )
    if boxes:
        wrong = np.flatnonzero((array[:, 2] < array[:, 0]) | (array[:, 3] < array[:, 1]))
        if len(wrong):
            row = int(wrong[0])
            raise UsageError(
                f"{name}[{row}] {array[row].tolist()} has x_max < x_min or y_max < y_min "
                "(boxes are [x_min, y_min, x_max, y_max])"
            )


def _unique_keys(pairs: list[tuple[str, object]]) -> dict:
    """A JSON object whose keys differ: of a key given twice, which entry was meant is not
    known (``json`` would keep the last without a word)."""
    data = dict(pairs)
    if len(data) != len(pairs):
        seen: set[str] = set()
        twice = next(key for key, _ in pairs if key in seen or seen.add(key))
        raise UsageError(f"the key {json.dumps(twice)} twice in one object")
    return data


def _numbers(value: object) -> bool:
    """Whether a JSON value is a number or (nested) lists of numbers, not booleans."""
    if isinstance(value, list):
        return all(_numbers(item) for item in value)
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _remove_temporaries(tasks: list[AugmentTask], folder: Path) -> None:
    """Remove the temporary files of every output of ``tasks`` (:func:`augment_file`'s
    ``.NAME.*`` beside each output) and of ``folder``'s labels file, whoever wrote them:
    with ``--jobs``, the workers still running when another input failed finish and write
    theirs, unreported."""
    remove_leftovers([folder / LABELS_NAME, *(t for task in tasks for t in _names(task))])


def _preset_options(args: argparse.Namespace) -> dict:
    """The preset options given as flags; :class:`UsageError` naming the flags that
    ``--preset`` does not take and those it does."""
    given = {name: getattr(args, name) for name in PRESET_FLAGS if getattr(args, name) is not None}
    preset = PRESETS.get(args.preset)
    if preset is None:  # argparse's choices said so already
        return given
    known = {field.name for field in dataclasses.fields(preset)}
    unknown = [f"--{name}" for name in given if name not in known]
    if unknown:
        takes = [f"--{name}" for name in PRESET_FLAGS if name in known]
        raise UsageError(
            f"{', '.join(unknown)}: not an option of --preset {args.preset}; it takes "
            f"{', '.join(takes) or 'none'}"
        )
    return given


def _check_replaceable(folder: Path, files: list[Path], count: int, labels: str | None) -> None:
    """:class:`UsageError` naming an output (an image or the labels file) that exists and
    is no file, a folder say, which the final renames could not replace, or that is one of
    the inputs or the ``--labels`` file, which it would overwrite (OUT the input folder):
    checked before any work, so that the run does not stop with part of its outputs renamed
    into place, nor destroy what it read."""
    targets = [folder / LABELS_NAME]
    for source in files:
        targets += _output_names(folder, source, count)
    read = {path.resolve(): "an input image" for path in files}
    if labels is not None:
        read[Path(labels).resolve()] = "the --labels file"
    for target in targets:
        if target.exists() and not target.is_file():
            raise UsageError(f"{target}: an output's name, but it exists and is not a file")
        what = read.get(target.resolve()) if target.exists() else None
        if what is not None:
            raise UsageError(
                f"{target}: an output's name, but it is {what}, which the outputs would "
                f"overwrite: write to another folder"
            )


def run(args: argparse.Namespace) -> int:
    try:
        jobs, scheduler = check_jobs(args.jobs), check_scheduler(args.scheduler)
    except (ImportError, TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    warp_options = {"interpolation": args.interpolation, "border": args.border}
    if args.transform is not None:  # else the preset's own
        warp_options["transform"] = args.transform
    try:  # the configuration, checked before any work
        configured = Augment(
            args.preset,
            seed=args.seed,
            warp_options=warp_options,
            box_step=args.box_step,
            **_preset_options(args),
        )
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    files, _ = image_inputs(args.input)
    seen: dict[str, Path] = {}
    for source in files:  # the outputs and the labels are named by the input's name
        named = source.stem + _output_suffix(source)  # a.gif's copies are a_k.png, as a.png's
        if named in seen:
            raise UsageError(
                f"{seen[named]} and {source} have one name: their outputs "
                f"({source.stem}_000{_output_suffix(source)} ...) would overwrite each other"
            )
        seen[named] = source
    labels = read_labels(args.labels, files) if args.labels else {}
    if args.preset == "landmarks":  # its handles are the labels' keypoints: every input's
        bare = [f.name for f in files if not labels.get(f.name, {}).get("keypoints")]
        if bare:
            raise UsageError(
                f"the landmarks preset moves each image's keypoints; --labels gives none for "
                f"{', '.join(bare[:3])}{' ...' if len(bare) > 3 else ''}"
            )
    for i, source in enumerate(files):  # what each image's size refuses, before any work
        marks = labels.get(source.name, {}).get("keypoints")
        _check_draw(configured, source, i * args.n, marks if args.preset == "landmarks" else None)
    if not args.output.strip():  # Path("") is the working folder: not what "" says
        raise UsageError("OUT is empty: give the folder to write into (. for this one)")
    folder = Path(args.output)
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{folder}: must be a folder")
    fault = below_a_file(folder, itself=False)
    if fault is not None:
        raise UsageError(fault)
    if len(files) * args.n > MAX_OUTPUTS:  # every name is listed and checked before work
        raise UsageError(
            f"--n {args.n} on {len(files)} input(s) would write {len(files) * args.n:,} "
            f"images; at most {MAX_OUTPUTS:,} a run: split the inputs or --n"
        )
    _check_replaceable(folder, files, args.n, args.labels)
    made = [p for p in (folder, *folder.parents) if not p.exists()]  # the deepest first
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OSError(f"{folder}: cannot make the folder: {error.strerror or error}") from None
    tasks = [
        AugmentTask(
            source,
            folder,
            i * args.n,
            args.n,
            args.preset,
            _preset_options(args),
            args.seed,
            warp_options,
            args.box_step,
            labels.get(source.name),
            args.max_pixels,
        )
        for i, source in enumerate(files)
    ]
    written: list[tuple[str, str]] = []
    entries: dict = {}

    def finished(index: int, outcome: AugmentOutcome) -> None:
        written.extend(outcome.written)
        if outcome.error is not None:
            raise (OSError if outcome.unwritten else UsageError)(outcome.error)

    try:
        outcomes = run_jobs(augment_file, tasks, jobs=jobs, scheduler=scheduler, on_result=finished)
        for outcome in outcomes:  # in the order of the inputs, however the work was shared
            entries.update(outcome.labels)
        fd, name = tempfile.mkstemp(prefix=f".{LABELS_NAME}.", suffix=".json", dir=folder)
        written.append((name, str(folder / LABELS_NAME)))
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as stream:
                json.dump(entries, stream, indent=1)
        except OSError as error:  # a full disk
            raise OSError(
                f"{folder / LABELS_NAME}: cannot write: {error.strerror or error}"
            ) from None
    except BaseException:
        for temporary, _ in written:
            Path(temporary).unlink(missing_ok=True)
        _remove_temporaries(tasks, folder)  # of workers that finished after the failure
        for made_folder in made:  # the folders this run made, were they left empty
            try:
                made_folder.rmdir()
            except OSError:
                break
        raise
    read = files + ([Path(args.labels)] if args.labels else [])
    stale = former_outputs(folder, LABELS_NAME, {Path(f).name for _, f in written}, read)
    rename_all(written)
    remove_former(args, stale, LABELS_NAME, [Path(f) for _, f in written] + read)
    for outcome in outcomes:  # the images, in the order of the inputs
        for _, final in outcome.written:
            print(final, flush=True)
    for source in files:
        if _output_suffix(source) != source.suffix:
            say(
                args,
                f"glmls augment: {source}: glmls writes no {source.suffix}; its copies are .png",
            )
    count = len(written) - 1
    say(args, f"glmls augment: {count} image{'s' * (count != 1)} and {folder / LABELS_NAME}")
    sys.stdout.flush()
    return 0
