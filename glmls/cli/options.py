"""What the ``glmls`` commands share: argparse value types, the MLS configuration options
(made from :class:`~glmls.MLSConfig`'s fields, so a new field is a new option everywhere), the
image-construction options, and the error that means "exit status 2"."""

from __future__ import annotations

import argparse
import dataclasses
import math

from ..core.config import TRANSFORMS, WEIGHTS, MLSConfig
from ..imaging.source import INTERPOLATIONS, METHODS

__all__ = [
    "UsageError",
    "add_config_options",
    "add_warp_options",
    "config_from_args",
    "parse_background",
    "positive_float",
    "positive_int",
]

#: Fields of MLSConfig whose values are names.
_CHOICES = {"transform": TRANSFORMS, "weight": WEIGHTS}


class UsageError(ValueError):
    """A mistake in the command line or its input files (exit status 2)."""


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {value}")
    return value


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
            default = f" (default {f.default:g})" if isinstance(f.default, float) else ""
            group.add_argument(flag, type=float, default=f.default, help=text + default)


def config_from_args(args: argparse.Namespace) -> MLSConfig:
    """The :class:`MLSConfig` of parsed options; :class:`UsageError` if it is invalid."""
    try:
        return MLSConfig(**{f.name: getattr(args, f.name) for f in dataclasses.fields(MLSConfig)})
    except (TypeError, ValueError) as error:
        raise UsageError(str(error)) from None


def add_warp_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("image construction")
    group.add_argument("--method", choices=METHODS, default="quads")
    group.add_argument("--interpolation", choices=INTERPOLATIONS, default="nearest")
    group.add_argument(
        "--grid", type=positive_int, default=1, help="mesh step in pixels (default 1)"
    )


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
