"""What the ``glmls`` commands share: argparse value types, the MLS configuration options
(made from :class:`~glmls.MLSConfig`'s fields, so a new field is a new option everywhere), the
image-construction options, and the error that means "exit status 2"."""

from __future__ import annotations

import argparse
import dataclasses
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

import numpy as np

from ..analysis.tuning import parse_config
from ..core.config import TRANSFORMS, WEIGHTS, MLSConfig
from ..files.images import DEFAULT_MAX_PIXELS
from ..imaging.options import WarpOptions
from ..imaging.source import BORDERS, INTERPOLATIONS, METHODS

__all__ = [
    "ArgumentParser",
    "HelpFormatter",
    "UsageError",
    "add_config_options",
    "add_jobs_options",
    "add_max_pixels",
    "add_warp_options",
    "below_a_file",
    "config_from_args",
    "fit_background",
    "folder_path",
    "handle_warnings",
    "nonnegative_int",
    "parse_background",
    "positive_float",
    "positive_int",
    "text_table",
    "warp_options_from_args",
]

#: Fields of MLSConfig whose values are names.
_CHOICES = {"transform": TRANSFORMS, "weight": WEIGHTS}


#: The beginning of a word that is a value, not an option, although it begins with '-': a
#: number or numbers (``-1``, ``-.5``, ``-1e-3``, ``-1,1,1``, ``-inf``); glmls has no option
#: of one dash and a digit.
_NEGATIVE_VALUE = re.compile(r"-(?:\.?\d|inf|nan)", re.IGNORECASE)


class UsageError(ValueError):
    """A mistake in the command line or its input files (exit status 2)."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser with a mistake on one line, as glmls's other errors: the command,
    the fault and where the options are listed, not the whole usage first (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """argparse's, where an option that takes one value (named in full or by a prefix
        argparse takes for it) takes a next word that begins with '-' and a digit
        (``--spacing -1,1,1``, ``--alpha -1e-3``, ``--backg -1,0,0``) as ``--option=word``:
        argparse reads such a word as an option unless it is one plain negative number, and
        then says the option expects an argument, where the option's own check of the value
        has the clearer message. Words after ``--`` are left as they are; an option of no
        value or of several (``nargs``) is left to argparse."""
        words = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(self._negative_values(words), namespace)

    def _negative_values(self, words: list[str]) -> list[str]:
        joined: list[str] = []
        for i, word in enumerate(words):
            if word == "--":  # the rest are positional words, as they are
                return joined + words[i:]
            action = self._option_action(joined[-1]) if joined else None
            if action is not None and action.nargs is None and _NEGATIVE_VALUE.match(word):
                joined[-1] = f"{joined[-1]}={word}"
            else:
                joined.append(word)
        return joined

    def _option_action(self, word: str) -> argparse.Action | None:
        """The action of the option ``word`` names: its full name, or, as argparse allows, an
        unambiguous prefix of a long option's (an ambiguous one is left to argparse's
        error)."""
        action = self._option_string_actions.get(word)
        if action is not None or not (self.allow_abbrev and word.startswith("--")):
            return action
        actions = {
            id(found): found
            for name, found in self._option_string_actions.items()
            if name.startswith(word)
        }
        return next(iter(actions.values())) if len(actions) == 1 else None


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Examples kept as written, and every option's default after its help (where it has one:
    an option without a value of its own says what happens in its help)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if default is None or default is False or default == argparse.SUPPRESS:
            return text
        if "%(default)" in text:
            return text
        if not action.option_strings:
            return text
        if isinstance(default, (list, tuple)):  # as it is typed, not as a Python list
            return f"{text} (default: {' '.join(map(str, default))})"
        return f"{text} (default: %(default)s)"


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _int_at_least(text, 1)


def nonnegative_int(text: str) -> int:
    """An integer >= 0."""
    return _int_at_least(text, 0)


def _int_at_least(text: str, low: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"expected an integer >= {low}, got {value}")
    return value


def folder_path(text: str) -> Path:
    """An output folder: one that exists or can be made, not a file (nor below one), so that
    a run does not do all its work before it finds that it cannot write; nor empty, which
    ``Path`` would take for the working folder."""
    if not text.strip():
        raise argparse.ArgumentTypeError("empty: give the folder to write into (. for this one)")
    fault = below_a_file(Path(text), itself=True)
    if fault is not None:
        raise argparse.ArgumentTypeError(fault)
    return Path(text)


def below_a_file(path: Path, *, itself: bool) -> str | None:
    """Why ``path`` cannot be written for a file in its way: the first of the folders above
    it that exists is a file (or, with ``itself``, ``path`` is one, where it is to be a
    folder); None where nothing is in the way."""
    for place in (path, *path.parents) if itself else path.parents:
        if place.exists():
            if place.is_dir():
                return None
            what = "" if place == path else f" {place} is"
            return f"{path}:{what} a file, not a folder"
    return None


def refuse_overwriting(outputs: Sequence[Path], inputs: dict[Path, str]) -> None:
    """:class:`UsageError` for an output that is one of ``inputs`` (a path and what it is:
    "an input image", "the --handles file"), which writing it would destroy, checked by the
    file itself (a link or another spelling of its name is the same file); or that exists
    and is no file (a folder), which the output could not replace, or whose folder exists
    and is no folder (a file), in which it could not be made. Checked before any work,
    so that a run does not find it only when it writes; and for two outputs of one file
    (``demo --record x --screenshot x``), the second of which would replace the first."""
    named: dict[object, Path] = {}
    for output in outputs:
        first = named.setdefault(_file_identity(output) or output.resolve(), output)
        if first is not output:
            raise UsageError(
                f"{output}: two outputs of one file ({first} and {output}): the second would "
                "replace the first; give each its own name"
            )
    for output in outputs:
        if output.exists() and not output.is_file():
            raise UsageError(f"{output}: an output's name, but it exists and is not a file")
        for folder in output.parents:  # a file where a folder of the outputs goes
            if folder.exists():
                if not folder.is_dir():
                    raise UsageError(
                        f"{folder}: the folder of an output ({output.name}), but it exists "
                        "and is not a folder"
                    )
                break  # the folders above an existing one are folders
    read = {}
    for path, what in inputs.items():
        identity = _file_identity(path)
        if identity is not None:
            read.setdefault(identity, what)
    for output in outputs:
        what = read.get(_file_identity(output))
        if what is not None:
            raise UsageError(
                f"{output}: the output is {what}, which writing it would overwrite: write to "
                "another name or folder"
            )


def _file_identity(path: Path) -> tuple[int, int] | None:
    """The device and inode of the file at ``path``; None where there is none."""
    try:
        status = path.stat()
    except (OSError, ValueError):
        return None
    return (status.st_dev, status.st_ino)


def text_table(heads: Sequence[str], cells: Sequence[Sequence[str]]) -> str:
    """Columns of text, left-aligned, two spaces apart, without trailing blanks."""
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(heads)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(heads, widths, strict=True))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(line.rstrip() for line in lines)


def positive_float(text: str) -> float:
    """A finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text}")
    return value


def add_config_options(parser: argparse.ArgumentParser) -> None:
    """One option per field of :class:`MLSConfig` (``--transform``, ``--weight``,
    ``--alpha``, ``--s``, ``--radius``, ``--interpolating``), its help from the field's."""
    group = parser.add_argument_group("MLS configuration")
    for f in dataclasses.fields(MLSConfig):
        flag = "--" + f.name.replace("_", "-")
        text = f.metadata.get("help", "")
        if f.default is False:
            group.add_argument(flag, action="store_true", help=text)
        elif f.name in _CHOICES:
            group.add_argument(flag, choices=_CHOICES[f.name], default=f.default, help=text)
        else:
            group.add_argument(flag, type=float, default=f.default, help=text)


def config_from_args(args: argparse.Namespace) -> MLSConfig:
    """The :class:`MLSConfig` of parsed options; :class:`UsageError` if it is invalid. An
    option the weight does not use is said on stderr (unless ``--quiet``), not refused."""
    try:
        config = MLSConfig(**{f.name: getattr(args, f.name) for f in dataclasses.fields(MLSConfig)})
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None
    if not getattr(args, "quiet", False):
        for message in unused_config_options(config):
            print(f"glmls {args.command}: warning: {message}", file=sys.stderr)
    return config


def unused_config_options(config: MLSConfig, *, flags: bool = True) -> list[str]:
    """What of ``config``, set away from its default, the weight does not use: a radius with
    idw; alpha with a radius weight not made interpolating; s with a weight other than idw.
    ``flags``: the options named as command-line flags (``--radius 5``), else as a
    configuration's parameters (``radius=5``)."""

    def named(option: str, value: float) -> str:
        return f"--{option} {value:g}" if flags else f"{option}={value:g}"

    defaults = MLSConfig()
    messages = []
    if not config.uses_radius and config.radius is not None:
        radius_weights = ", ".join(w for w in WEIGHTS if MLSConfig(weight=w).uses_radius)
        messages.append(
            f"{named('radius', config.radius)} is not used by the {config.weight} weight (the "
            f"radius weights use it: {radius_weights})"
        )
    unused = []
    if config.uses_radius and not config.interpolating:
        whose = "idw's, and --interpolating's" if flags else "idw's, and interpolating's"
        unused.append(("alpha", config.alpha, defaults.alpha, whose))
    if not config.weight_entry.uses_s:
        unused.append(("s", config.s, defaults.s, "idw's"))
    for option, value, default, whose in unused:
        if value != default:
            messages.append(
                f"{named(option, value)} is not used by the {config.weight} weight ({whose})"
            )
    return messages


def parse_config_specs(
    specs: Sequence[str], shape: Sequence[int], *, command: str, quiet: bool = False
) -> list[MLSConfig]:
    """The configurations of ``--configs`` entries (``transform:weight[:name=value,...]``) for
    an image of ``shape``; a ValueError names the bad entry. An entry that names its weight and
    sets a parameter the weight does not use (``rigid:idw:radius=5``) is said on stderr
    (unless ``quiet``), as the MLS options' own warnings are; an entry of every weight
    (``*``) sets its parameters for the weights that use them."""
    configs = []
    for spec in specs:
        parsed = parse_config(spec, shape)
        configs += parsed
        parts = spec.split(":")
        if quiet or len(parts) != 3 or parts[1] == "*":
            continue
        for config in parsed:
            for message in unused_config_options(config, flags=False):
                print(f"glmls {command}: warning: --configs {spec}: {message}", file=sys.stderr)
    return configs


def add_warp_options(
    parser: argparse.ArgumentParser, *, grid: int | None = None, windows: bool = False
) -> None:
    """--method, --interpolation, --grid (default ``grid``; None: the warp's own, 1 for an
    image, for a volume 1 or 2 by its method), --tolerance, --border and --fit.
    ``windows``: --interpolation and --border default to None, the default of the window
    that opens (an image's: nearest, constant; a volume's: linear, edge), so that a value
    given is told from one left out."""
    group = parser.add_argument_group("image construction")
    group.add_argument(
        "--method",
        choices=METHODS,
        default="quads",
        help="quads: forward with polygon interpolation (the mesh of pixel-square corners); "
        "splat: simple forward; backward: f's inverse; backward-swap: the swapped-handles "
        "shortcut, for comparison; paper-quads: the paper's pseudo-code exactly (squares of "
        "adjacent pixel centres, nearest vertex; --grid 1 only)",
    )
    group.add_argument(
        "--interpolation",
        choices=INTERPOLATIONS,
        default=None if windows else "nearest",
        help="nearest: one source pixel's value (no new colours); linear: bilinear"
        + (" (default: nearest for an image, linear for a volume)" if windows else ""),
    )
    group.add_argument(
        "--grid",
        type=positive_int,
        default=grid,
        help="mesh step in pixels (voxels)"
        + ("" if grid is not None else " (default: 1; a volume's backward method: 2)"),
    )
    group.add_argument(
        "--tolerance",
        type=positive_float,
        default=None,
        metavar="PX",
        help="quads on the error-bounded adaptive mesh instead of the --grid lattice: every "
        "pixel's source point within PX pixels of f's inverse (e.g. 0.05; docs/adaptive.md)",
    )
    group.add_argument(
        "--border",
        choices=BORDERS,
        default=None if windows else "constant",
        help="what lies beyond the image (numpy.pad's names): constant: the background; "
        "edge: the edge pixels repeated; symmetric: mirrored with them; reflect: mirrored "
        "about them; wrap: the image repeated"
        + (" (default: constant for an image, edge for a volume)" if windows else ""),
    )
    group.add_argument(
        "--fit",
        action="store_true",
        help="show the whole deformed image: the output canvas grows to its bounds, so "
        "nothing is cut off (default: the input's size and place)",
    )


def warp_options_from_args(args: argparse.Namespace) -> WarpOptions:
    """The :class:`~glmls.WarpOptions` of the options :func:`add_warp_options` added (and
    ``--background`` where the command has it); :class:`UsageError` if they do not go
    together (e.g. ``--tolerance`` with ``--grid 4``)."""
    values = {name: getattr(args, name) for name in WARP_ARGUMENTS}
    if values["grid"] is None:
        del values["grid"]  # WarpOptions' own
    if getattr(args, "background", None) is not None:
        values["background"] = args.background
    try:
        return WarpOptions(**values)
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None


#: The fields of :class:`~glmls.WarpOptions` that :func:`add_warp_options` gives options of.
WARP_ARGUMENTS = ("method", "interpolation", "grid", "tolerance", "border")


def add_max_pixels(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--max-pixels",
        type=positive_int,
        default=DEFAULT_MAX_PIXELS,
        metavar="N",
        help="refuse input images of more pixels (a guard against decompression bombs)",
    )


def fit_background(background: float | tuple[float, ...], channels: int):
    """``background`` for an image of ``channels`` channels in a batch of mixed images: a grey
    image (C = 1, or 2 with alpha) takes a colour's first value (and its alpha, if given and
    the image has one), an RGB image an RGBA background's colour."""
    if not isinstance(background, tuple):
        return background
    has_alpha = channels in (2, 4)
    colour = channels - has_alpha
    if len(background) in (channels, colour):
        return background
    if colour == 1 and len(background) >= 3:
        values = (background[0], *((background[3],) if has_alpha and len(background) == 4 else ()))
        return values[0] if len(values) == 1 else values
    if colour == 3 and len(background) == 4:
        return background[:3]
    return background


def handle_warnings(
    src: np.ndarray,
    shape: tuple[int, int],
    *,
    segment_ends: bool = False,
    reference: bool = False,
) -> list[str]:
    """Warnings for handles that look like another convention than pixels (x, y) = (column,
    row) on an image of ``shape``: all within [0, 1] x [0, 1] (normalised coordinates), or
    mostly outside the image (perhaps (row, column)). ``src``: the source points, with the
    ends of the source segments where ``segment_ends``; the reference points where
    ``reference``."""
    height, width = shape
    if len(src) == 0:
        return []
    noun = "handle points and segment ends" if segment_ends else "handles"
    every = "every handle point and segment end" if segment_ends else "every handle"
    if reference:
        noun, every = "reference points", "every reference point"
    x, y = src[:, 0], src[:, 1]
    if max(height, width) > 4 and (src >= 0).all() and (src <= 1).all():
        return [
            f"{every} lies within [0, 1] x [0, 1] of a {width} x {height} image: "
            "normalised coordinates? glmls takes pixels, (x, y) = (column, row)"
        ]
    inside = (x >= -0.5) & (x <= width - 0.5) & (y >= -0.5) & (y <= height - 0.5)
    if inside.mean() >= 0.5:
        return []
    swapped = (y >= -0.5) & (y <= width - 0.5) & (x >= -0.5) & (x <= height - 0.5)
    hint = (
        "; (row, column) order? glmls takes (x, y) = (column, row)" if swapped.mean() > 0.5 else ""
    )
    outside = int((~inside).sum())
    return [f"{outside} of {len(src)} {noun} lie outside the {width} x {height} image{hint}"]


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
    for part, value in zip(text.split(","), values, strict=True):
        mantissa = part.strip().lower().split("e")[0]
        spelled = any(digit in mantissa for digit in "123456789")  # a number, not 0
        if (math.isinf(value) and spelled) or (value == 0.0 and spelled):
            raise argparse.ArgumentTypeError(
                f"{part.strip()} is outside float64's range (it would be {value:g}); write "
                "inf or -inf for an infinite background"
            )
        try:
            exact = int(part)
        except ValueError:
            continue  # not an integer: 0.5, 1e3, nan
        if exact != value:  # an integer beyond 2**53: float64 rounds it
            raise argparse.ArgumentTypeError(
                f"{part.strip()} is not exact as a number (it would be {value:.0f}); a "
                "background is exact within +-2**53"
            )
    return values[0] if len(values) == 1 else values


def scheduler_address(text: str) -> str:
    """``local`` or a Dask scheduler's address (``tcp://host:8786``), checked by Dask where
    it is installed (without it, :func:`glmls.analysis.jobs.check_scheduler` says how to
    install it)."""
    address = text.strip()
    if address == "local":
        return address
    try:
        from distributed.comm.addressing import get_address_host_port
    except ImportError:
        return text
    try:
        get_address_host_port(address)
    except ValueError as error:
        raise argparse.ArgumentTypeError(
            f"expected 'local' or a Dask scheduler's address (tcp://host:8786), got {text!r}: "
            f"{error}"
        ) from None
    return address


def add_jobs_options(parser: argparse.ArgumentParser) -> None:
    """--jobs and --scheduler (:func:`glmls.analysis.jobs.run_jobs`)."""
    group = parser.add_argument_group("parallel work")
    group.add_argument(
        "--jobs",
        type=positive_int,
        default=1,
        metavar="N",
        help="worker processes, each with its own GL context; with --scheduler local, the "
        "local Dask cluster's workers",
    )
    group.add_argument(
        "--scheduler",
        type=scheduler_address,
        metavar="ADDRESS",
        help="a Dask cluster: 'local' (one made on this machine with --jobs workers) or an "
        "existing scheduler's address (tcp://host:8786); needs pip install "
        "'glmls[distributed]' (default: no Dask)",
    )
