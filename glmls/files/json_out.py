"""JSON outputs as the standard has them: a float that is not finite (an undefined or an
infinitely bad measure: NaN, ``inf``) is written as ``null``, where Python's ``json`` would
write ``NaN`` or ``Infinity``, which JSON does not define and other readers refuse."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping

from .atomic import atomic_write

__all__ = ["strict_json", "write_json"]


def strict_json(value: object) -> object:
    """``value`` (dicts, lists, tuples, numbers, strings, None) with every float that is not
    finite replaced by None.

    Examples
    --------
    >>> from glmls.files.json_out import strict_json
    >>> strict_json({"mean": float("nan"), "spread": [1.5, float("inf")]})
    {'mean': None, 'spread': [1.5, None]}
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {key: strict_json(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(item) for item in value]
    return value


def write_json(path: str | os.PathLike, document: object) -> None:
    """``document`` as indented, standard JSON (:func:`strict_json`) in ``path``, whole or not
    at all (:func:`~glmls.files.atomic.atomic_write`)."""
    text = json.dumps(strict_json(document), indent=2, allow_nan=False) + "\n"
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
