"""A result's repr as its fields' shapes and dtypes: ``print(result)`` of a batch, a deformed
mesh or a volume's result is one line, not every value of every array."""

from __future__ import annotations

from dataclasses import fields

import numpy as np

__all__ = ["describe", "fields_repr"]

#: The items of a list that :func:`describe` names one by one.
SHOWN = 3


def describe(value: object) -> str:
    """A value in a few words: an array's shape and dtype, a list's length and kinds,
    ``None`` and short values as they are."""
    if value is None:
        return "None"
    if hasattr(value, "shape") and hasattr(value, "dtype"):
        kind = "array" if isinstance(value, np.ndarray) else type(value).__name__
        return f"{kind}({tuple(value.shape)}, {value.dtype})"
    if isinstance(value, (list, tuple)):
        if not value:
            return "[]"
        if all(isinstance(item, (int, float)) for item in value) and len(repr(value)) <= 60:
            return repr(value)  # a spacing, a shape: short numbers, shown as they are
        if all(hasattr(item, "shape") and hasattr(item, "dtype") for item in value):
            shown = [f"{tuple(item.shape)} {item.dtype}" for item in value[:SHOWN]]
            more = ", ..." if len(value) > SHOWN else ""
            return f"[{len(value)} arrays: {', '.join(shown)}{more}]"
        kinds = sorted({type(item).__name__ for item in value})
        return f"[{len(value)} {'/'.join(kinds)}s]"
    text = repr(value)
    return text if len(text) <= 60 else f"<{type(value).__name__}>"


def fields_repr(obj: object) -> str:
    """``Name(field=..., ...)`` of a dataclass instance, each field by :func:`describe`."""
    parts = [f"{f.name}={describe(getattr(obj, f.name))}" for f in fields(obj)]  # type: ignore[arg-type]
    return f"{type(obj).__name__}({', '.join(parts)})"
