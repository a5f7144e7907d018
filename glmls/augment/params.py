"""The records of :class:`glmls.augment.Augment`'s draws: the warp options they carry,
checked as :func:`glmls.warp_batch` will take them, made JSON-able when drawn and checked
again when replayed (a record read back from a file, or edited, is refused naming the bad
entry: ``params[2]['dst']``), before any GPU work."""

from __future__ import annotations

import json
import operator
from collections.abc import Mapping, Sequence

import numpy as np

from ..batch.inputs import check_counts, check_point_sets, item_array
from ..batch.run import check_flags
from ..core.config import MLSConfig, check_flag, counted, is_integer
from ..core.handles import COORDINATE_LIMIT
from ..engine.kernel import check_bins
from ..engine.storage import check_storage
from ..errors import DtypeError
from ..gl.context import check_ctx
from ..imaging.options import FIELDS, WarpOptions
from ..mls import MLS_KEYWORDS
from .labels import check_positive

__all__ = [
    "LABEL_OPTIONS",
    "as_lists",
    "check_label_options",
    "check_one_options",
    "check_params",
    "check_reach",
    "check_warp_options",
    "differing_options",
    "fresh",
    "jsonable",
    "label_options_of",
    "param_handles",
    "param_points",
]

#: The options of :class:`glmls.augment.Augment` that shape the labels, each draw's record of
#: them (``label_options``): the step of a box's outline, the polygons' densifying step, and
#: whether the moved polygons are clipped to the canvas.
LABEL_OPTIONS = ("box_step", "densify", "clip_polygons")


#: The keywords of :func:`glmls.warp_batch` that ``warp_options`` cannot hold, each with the
#: reason its error gives: the labels are each call's own, and segment handles would go
#: with handles that the preset draws per image.
_NOT_OPTIONS = {
    "keypoints": "give them to the call",
    "masks": "give them to the call",
    "src_segments": "the preset draws each image's handles",
    "dst_segments": "the preset draws each image's handles",
}
_WARP_KEYWORDS = (FIELDS | {"options", "return_maps", "max_batch_bytes"} | MLS_KEYWORDS) - set(
    _NOT_OPTIONS
)
#: The fields of :class:`MLSConfig` that ``warp_options`` may set.
_CONFIG_FIELDS = ("transform", "weight", "alpha", "s", "radius", "interpolating")


def check_warp_options(options: Mapping[str, object], what: str = "warp_options") -> None:
    """``warp_options`` (or a draw's recorded options, called ``what``) as
    :func:`glmls.warp_batch` will take them, checked now: a keyword it does not take, or the
    labels that are the call's own, is a ``TypeError``, a bad value a ``ValueError`` naming
    it."""
    for name in options:
        if name in _NOT_OPTIONS:
            raise TypeError(f"{what} cannot hold {name}: {_NOT_OPTIONS[name]}")
        if name not in _WARP_KEYWORDS:
            raise TypeError(f"{what} has no keyword {name}")
    fields = {k: v for k, v in options.items() if k in FIELDS or k == "options"}
    try:
        WarpOptions.of(fields.pop("options", None), **fields)
        config = MLSConfig(**{k: v for k, v in options.items() if k in _CONFIG_FIELDS})
        # and what warp_batch would refuse only at the first batch (in a data-loader worker)
        check_flags(options.get("return_maps", False), options.get("max_batch_bytes"))
        if "storage" in options:
            check_storage(options["storage"])
        check_bins(options.get("bins"), config)
        check_ctx(options.get("ctx"))
    except (TypeError, ValueError) as error:
        raise type(error)(f"{what}: {error}") from None


def jsonable(value: object) -> object:
    """``value`` with numpy scalars and arrays, tuples and mappings made the lists, numbers
    and dicts that JSON writes (and reads back equal); a 0-d array (an option such as
    ``rows=np.array(3)``) is its number."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return value.item()
    if isinstance(value, np.ndarray) and value.dtype.kind in "biuf":
        return value.tolist()  # the same nested lists of Python numbers, in one call
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def fresh(value: object) -> object:
    """A copy of ``value``, made by :func:`jsonable`, whose dicts and lists are new (a
    sample's record its own) and whose numbers and strings are shared."""
    if type(value) is dict:
        return {k: fresh(v) for k, v in value.items()}
    if type(value) is list:
        return [fresh(v) for v in value]
    return value


def check_label_options(options: Mapping[str, object]) -> dict[str, object]:
    """``options``' entries of :data:`LABEL_OPTIONS` checked, as floats and a bool:
    ``box_step`` a finite number > 0, ``densify`` one or None, ``clip_polygons`` True or
    False; a ``TypeError`` (a value of another type) or ``ValueError`` naming the entry."""
    checked: dict[str, object] = {}
    if "box_step" in options:
        checked["box_step"] = check_positive("box_step", options["box_step"])
    if "densify" in options:
        densify = options["densify"]
        checked["densify"] = None if densify is None else check_positive("densify", densify)
    if "clip_polygons" in options:
        checked["clip_polygons"] = check_flag("clip_polygons", options["clip_polygons"])
    return checked


def label_options_of(draw: Mapping, defaults: Mapping[str, object]) -> dict[str, object]:
    """The label options a draw was made with: its ``label_options``, checked (by
    :func:`check_params`), over ``defaults`` (the replaying Augment's) for an entry it lacks
    (a record made without them)."""
    recorded = draw.get("label_options")
    return {**defaults, **check_label_options(recorded if isinstance(recorded, Mapping) else {})}


def _check_recorded_labels(entry: object, name: str) -> None:
    if not isinstance(entry, Mapping):
        raise TypeError(f"{name} must be a dict, got {entry!r}")
    for key in entry:
        if key not in LABEL_OPTIONS:
            raise TypeError(f"{name} has no keyword {key}; it holds {', '.join(LABEL_OPTIONS)}")
    try:
        check_label_options(entry)
    except (TypeError, ValueError) as error:
        raise type(error)(f"{name}: {error}") from None


#: What each draw of ``params`` holds for :meth:`Augment.replay` (``label_options`` too,
#: where it was recorded).
_PARAM_KEYS = ("shape", "src", "dst", "options")


def check_params(params: object, count: int) -> list[Mapping]:
    """``params`` as a list of ``count`` draws, each a mapping with :data:`_PARAM_KEYS`;
    ``TypeError``/``ValueError`` naming the draw otherwise."""
    if isinstance(params, (str, bytes, Mapping)) or not isinstance(params, Sequence):
        raise TypeError(f"params must be a sequence of draws (dicts), got {type(params).__name__}")
    if len(params) != count:
        raise ValueError(
            f"params holds {counted(len(params), 'draw')} for {counted(count, 'image')}"
        )
    checked: set[str] = set()  # the options already checked, as JSON
    for i, draw in enumerate(params):
        if not isinstance(draw, Mapping):
            raise TypeError(f"params[{i}] must be a dict, got {type(draw).__name__}")
        missing = [key for key in _PARAM_KEYS if key not in draw]
        if missing:
            raise ValueError(f"params[{i}] has no {', '.join(map(repr, missing))}")
        _check_shape(draw["shape"], f"params[{i}]['shape']")
        options = draw["options"]
        if not isinstance(options, Mapping):
            raise TypeError(f"params[{i}]['options'] must be a dict, got {options!r}")
        # one Augment's draws share their options (as JSON): each such set is checked once
        seen = _json_key(options)
        if seen is None or seen not in checked:
            check_warp_options(options, f"params[{i}]['options']")
            if seen is not None:
                checked.add(seen)
        if "label_options" in draw:
            _check_recorded_labels(draw["label_options"], f"params[{i}]['label_options']")
    return list(params)


def _same_value(a: object, b: object) -> bool:
    """Whether two recorded option values are equal: arrays and lists element by element,
    NaN equal to NaN."""
    if isinstance(a, (np.ndarray, list, tuple)) and isinstance(b, (np.ndarray, list, tuple)):
        try:
            x, y = np.asarray(a), np.asarray(b)
        except ValueError:  # ragged: as Python compares them
            return a == b
        try:
            return bool(np.array_equal(x, y, equal_nan=True))
        except TypeError:  # not numbers: NaN cannot occur
            return bool(np.array_equal(x, y))
    try:
        return bool(a == b) or (a != a and b != b)  # NaN
    except (TypeError, ValueError):  # values whose == is no truth value
        return a is b


def differing_options(options: Mapping, other: Mapping) -> list[str]:
    """The names of the options whose values differ between two draws' records, sorted
    (arrays and lists compared element by element, NaN equal to NaN)."""
    missing = object()
    keys = {*options, *other}
    return sorted(
        (str(k) for k in keys if not _same_value(options.get(k, missing), other.get(k, missing))),
    )


def check_one_options(params: list) -> None:
    """``ValueError`` where the draws' records ``params`` hold different warp options (one
    replay is one warp): naming the record apart from the others, ``params[0]`` where
    ``params[1]`` and ``params[2]`` agree against it."""
    options = dict(params[0]["options"])
    for i, p in enumerate(params):
        names = differing_options(options, dict(p["options"]))
        if names:
            odd, other = i, 0
            if i == 1 and len(params) > 2:  # params[1] as params[2]: params[0] is odd
                if not differing_options(dict(p["options"]), dict(params[2]["options"])):
                    odd, other = 0, 1
            raise ValueError(
                f"params[{odd}]['options'] differ from params[{other}]'s in "
                f"{', '.join(names)}: replay draws of different warp options in separate calls"
            )


def _json_key(options: Mapping) -> str | None:
    """``options`` as JSON text with the types it keeps (a tuple and a list apart), or None
    where they hold anything else (an array, an object, whose text may not tell two apart)."""

    def plain(value: object) -> object:
        if value is None or type(value) in (bool, int, float, str):
            return [type(value).__name__, value]
        if type(value) in (list, tuple):
            return [type(value).__name__, [plain(v) for v in value]]  # type: ignore[attr-defined]
        raise TypeError(type(value).__name__)

    try:
        items = sorted((str(k), type(k).__name__, plain(v)) for k, v in options.items())
        return json.dumps(items, allow_nan=True)
    except TypeError:
        return None


def _check_shape(shape: object, name: str) -> None:
    """A draw's ``shape``, [H, W] integers >= 1 (glmls's integer rule: 16.0 is none): a
    ``TypeError`` for a value of another type (a string, entries that are no integers), a
    ``ValueError`` for another length or a side below 1."""
    message = f"{name} must be [H, W], integers >= 1, got {shape!r}"
    if isinstance(shape, (str, bytes)) or not isinstance(shape, (Sequence, np.ndarray)):
        raise TypeError(message)
    if len(shape) != 2:
        raise ValueError(message)
    if not all(is_integer(n) for n in shape):
        raise TypeError(message)
    if min(operator.index(n) for n in shape) < 1:
        raise ValueError(message)


def param_handles(params: Sequence[Mapping]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each draw's source and target points (:func:`param_points`), ``ValueError`` naming
    the draw whose counts differ."""
    src, dst = param_points(params, "src"), param_points(params, "dst")
    check_counts(src, dst, lambda i, key: f"params[{i}][{key!r}]")
    return src, dst


def param_points(params: Sequence[Mapping], key: str) -> list[np.ndarray]:
    """Each draw's ``key`` ("src" or "dst") as (K, 2) float64 points, checked as
    :func:`glmls.warp_batch` checks handles, the error naming ``params[i]['src']``."""
    for i, draw in enumerate(params):
        _refuse_bools(draw[key], f"params[{i}][{key!r}]")
    items = [item_array(draw[key], f"params[{i}][{key!r}]") for i, draw in enumerate(params)]
    return check_point_sets(items, lambda i: f"params[{i}][{key!r}]", rows="K")


def _refuse_bools(points: object, name: str) -> None:
    """``DtypeError`` naming ``name`` and the row where a recorded point set, as lists, holds
    a bool (JSON's ``true``): numpy makes a list of bools and floats float, 1.0 where a
    coordinate was meant, as the handle files' reader refuses it."""
    if not isinstance(points, (list, tuple)):
        return  # an array: its dtype says bool, and check_point_sets refuses it
    for row, values in enumerate(points):
        if isinstance(values, (bool, np.bool_)) or (
            isinstance(values, (list, tuple))
            and any(isinstance(v, (bool, np.bool_)) for v in values)
        ):
            raise DtypeError(f"{name} row {row} holds a bool, {values!r}; expected real numbers")


def as_lists(drawn: list[tuple[np.ndarray, np.ndarray]]) -> list[tuple[list, list]]:
    """Each sample's (src, dst) as lists (``tolist``): where every sample drew as many
    handles, of all at once."""
    if len({(p.shape, q.shape) for p, q in drawn}) != 1:
        return [(p.tolist(), q.tolist()) for p, q in drawn]
    sources = np.stack([p for p, _ in drawn]).tolist()
    targets = np.stack([q for _, q in drawn]).tolist()
    return list(zip(sources, targets, strict=True))


def check_reach(preset: object, reach: float, index: int) -> None:
    """A preset whose draws can take handles out of the coordinate range (the GPU's float32
    keeps ~1e-7 of it) names the magnitude that would send them there. ``reach`` is the
    preset's bound for the image, not one draw's extent: whether an image is refused does
    not hang on its random numbers (a run over a data set does not stop at one unlucky
    sample)."""
    if reach <= COORDINATE_LIMIT:
        return
    names = [f for f in ("displacement", "radius", "units") if hasattr(preset, f)]
    given = ", ".join(f"{f}={getattr(preset, f)!r}" for f in names)
    raise ValueError(
        f"images[{index}]: the {preset.name} preset's {given} can move handles to "  # type: ignore[attr-defined]
        f"{reach:g} px, beyond ±{COORDINATE_LIMIT:g} px: use a smaller magnitude"
    )
