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
    ``None``, scalars and short values as they are."""
    if value is None:
        return "None"
    if isinstance(value, np.generic):
        return repr(value.item())
    if _is_array(value):
        kind = "array" if isinstance(value, np.ndarray) else type(value).__name__
        if len(value.shape) == 0:  # type: ignore[attr-defined]
            return f"{kind}({value.item()!r}, {value.dtype})"  # type: ignore[attr-defined]
        return f"{kind}({tuple(value.shape)}, {value.dtype})"  # type: ignore[attr-defined]
    if isinstance(value, (list, tuple)):
        return _describe_sequence(value)
    text = repr(value)
    return text if len(text) <= 60 else f"<{type(value).__name__}>"


def _is_array(value: object) -> bool:
    """A numpy array or an array of another library (a torch tensor): shape and dtype."""
    return hasattr(value, "shape") and hasattr(value, "dtype")


def _describe_sequence(value: list | tuple) -> str:
    if not value:
        return "[]"
    numbers = (int, float, np.generic)
    # The length is checked first: the repr of a long list is never made.
    if len(value) <= 12 and all(isinstance(item, numbers) for item in value):
        items = [item.item() if isinstance(item, np.generic) else item for item in value]
        text = repr(items if isinstance(value, list) else tuple(items))
        if len(text) <= 60:
            return text  # a spacing, a shape: short numbers, shown as they are
    present = [item for item in value if item is not None]
    if all(_is_array(item) for item in present):  # per-image arrays, None where none
        if not present:
            return repr([None] * len(value)) if len(value) <= SHOWN else f"[{len(value)} Nones]"
        kinds = {
            "array" if isinstance(item, np.ndarray) else type(item).__name__ for item in present
        }
        shown = [
            "None" if item is None else f"{tuple(item.shape)} {item.dtype}"
            for item in value[:SHOWN]
        ]
        more = ", ..." if len(value) > SHOWN else ""
        return f"[{len(value)} {'/'.join(sorted(kinds))}s: {', '.join(shown)}{more}]"
    kinds = sorted({type(item).__name__ for item in value})
    return f"[{len(value)} {'/'.join(kinds)}s]"


def fields_repr(obj: object) -> str:
    """``Name(field=..., ...)`` of a dataclass instance, each field by :func:`describe`."""
    parts = [f"{f.name}={describe(getattr(obj, f.name))}" for f in fields(obj)]  # type: ignore[arg-type]
    return f"{type(obj).__name__}({', '.join(parts)})"
