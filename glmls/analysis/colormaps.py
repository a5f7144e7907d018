"""Colour maps for error pictures: the paper's two-colour linear map and viridis, colour
limits (with a robust percentile upper bound), NaN colouring and a colour bar with numbers.

A colour map is an (n, 3) uint8 table; a value x maps to entry round(t (n - 1)) with
t = clip((x - lo) / (hi - lo), 0, 1). The GPU renderer (:mod:`glmls.analysis.canvas`) uses
the same tables and rule; :func:`apply_colormap` is its CPU counterpart.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import MappingProxyType

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..core.config import check_integer, check_real
from ..errors import DtypeError

#: Colour of undefined (NaN) values: mid grey, absent from both default maps.
NAN_COLOR = (128, 128, 128)
#: The paper's default extremes: white for the minimum, red for the maximum (Fig. 6).
LOW_COLOR = (255, 255, 255)
HIGH_COLOR = (220, 0, 0)
#: The least span of the analysis pictures' colour scales, by quantity: below these, values
#: differ by float32's rounding of the GPU's f alone (a similarity's angle errors, exact in
#: mathematics, come out near 1e-6 degrees; a rotation's det J within 1e-6 of 1), and a scale
#: stretched over that noise would paint an exact deformation as if it had errors. E_MLS in
#: px^2 (voxel^2), the distance error in px, the angle errors (degrees or eq. 11's ratio),
#: the construction error (0-1) and det J.
LEAST_SPANS = MappingProxyType(
    {"E_MLS": 1e-6, "distance": 1e-3, "angle": 1e-3, "construction": 1e-3, "det_j": 1e-3}
)
#: E_MLS's scale spans at least this share of its largest value too: the GPU's float32
#: rounding of the field grows with it (a few 1e-7 of E where E is in the hundreds), and
#: takes one colour of 256 only where the scale is some 500 times wider.
LEAST_RELATIVE_SPAN = 1e-3

#: The longest side of a colour bar, pixels: that of the pictures glmls draws on the GPU on
#: most devices (``GL_MAX_TEXTURE_SIZE``), beside which a bar goes.
MAX_BAR_SIDE = 16384
#: The most colours of a table: 256 show every level of 8-bit colour; this is ample.
MAX_COLORS = 65536
#: The largest ``font_size`` of a colour bar's digits, pixels.
MAX_FONT_SIZE = 1024

# viridis by Stéfan van der Walt and Nathaniel J. Smith (CC0), 256 entries as 8-bit RGB,
# rounded from the float table of matplotlib's _cm_listed.py.
_VIRIDIS_HEX = (
    "440154 440256 450457 450559 46075a 46085c 460a5d 460b5e 470d60 470e61 471063 "
    "471164 471365 481467 481668 481769 48186a 481a6c 481b6d 481c6e 481d6f 481f70 "
    "482071 482173 482374 482475 482576 482677 482878 482979 472a7a 472c7a 472d7b "
    "472e7c 472f7d 46307e 46327e 46337f 463480 453581 453781 453882 443983 443a83 "
    "443b84 433d84 433e85 423f85 424086 424186 414287 414487 404588 404688 3f4788 "
    "3f4889 3e4989 3e4a89 3e4c8a 3d4d8a 3d4e8a 3c4f8a 3c508b 3b518b 3b528b 3a538b "
    "3a548c 39558c 39568c 38588c 38598c 375a8c 375b8d 365c8d 365d8d 355e8d 355f8d "
    "34608d 34618d 33628d 33638d 32648e 32658e 31668e 31678e 31688e 30698e 306a8e "
    "2f6b8e 2f6c8e 2e6d8e 2e6e8e 2e6f8e 2d708e 2d718e 2c718e 2c728e 2c738e 2b748e "
    "2b758e 2a768e 2a778e 2a788e 29798e 297a8e 297b8e 287c8e 287d8e 277e8e 277f8e "
    "27808e 26818e 26828e 26828e 25838e 25848e 25858e 24868e 24878e 23888e 23898e "
    "238a8d 228b8d 228c8d 228d8d 218e8d 218f8d 21908d 21918c 20928c 20928c 20938c "
    "1f948c 1f958b 1f968b 1f978b 1f988b 1f998a 1f9a8a 1e9b8a 1e9c89 1e9d89 1f9e89 "
    "1f9f88 1fa088 1fa188 1fa187 1fa287 20a386 20a486 21a585 21a685 22a785 22a884 "
    "23a983 24aa83 25ab82 25ac82 26ad81 27ad81 28ae80 29af7f 2ab07f 2cb17e 2db27d "
    "2eb37c 2fb47c 31b57b 32b67a 34b679 35b779 37b878 38b977 3aba76 3bbb75 3dbc74 "
    "3fbc73 40bd72 42be71 44bf70 46c06f 48c16e 4ac16d 4cc26c 4ec36b 50c46a 52c569 "
    "54c568 56c667 58c765 5ac864 5cc863 5ec962 60ca60 63cb5f 65cb5e 67cc5c 69cd5b "
    "6ccd5a 6ece58 70cf57 73d056 75d054 77d153 7ad151 7cd250 7fd34e 81d34d 84d44b "
    "86d549 89d548 8bd646 8ed645 90d743 93d741 95d840 98d83e 9bd93c 9dd93b a0da39 "
    "a2da37 a5db36 a8db34 aadc32 addc30 b0dd2f b2dd2d b5de2b b8de29 bade28 bddf26 "
    "c0df25 c2df23 c5e021 c8e020 cae11f cde11d d0e11c d2e21b d5e21a d8e219 dae319 "
    "dde318 dfe318 e2e418 e5e419 e7e419 eae51a ece51b efe51c f1e51d f4e61e f6e620 "
    "f8e621 fbe723 fde725"
)


def _table_from_hex(text: str) -> np.ndarray:
    table = np.array([[int(h[i : i + 2], 16) for i in (0, 2, 4)] for h in text.split()], np.uint8)
    table.flags.writeable = False
    return table


#: viridis, (256, 3) uint8, read-only: perceptually uniform, readable in grey and by most
#: colour-blind viewers.
VIRIDIS = _table_from_hex(_VIRIDIS_HEX)


def as_color(color: object, name: str = "color") -> tuple[int, int, int]:
    """An (r, g, b) colour of 0-255 integers; ``ValueError``/``TypeError`` otherwise."""
    try:
        values = tuple(color)  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(
            f"{name} must be an (r, g, b) sequence of 0-255 numbers, got {color!r}"
        ) from None
    if len(values) != 3 or not all(
        isinstance(c, (int, float, np.integer, np.floating)) and 0 <= c <= 255 for c in values
    ):
        raise ValueError(f"{name} must be (r, g, b) with each in 0-255, got {color!r}")
    return tuple(round(float(c)) for c in values)  # type: ignore[return-value]


def linear_colormap(
    low: Sequence[float] = LOW_COLOR, high: Sequence[float] = HIGH_COLOR, *, n: int = 256
) -> np.ndarray:
    """The paper's colour map: n colours linearly interpolated from ``low`` to ``high``.

    Its default runs from white (the minimum) to red (the maximum), as the paper's Fig. 6.

    Parameters
    ----------
    low, high : sequence of float, optional
        The (r, g, b) colours, 0-255, of the minimum and the maximum.
    n : int, optional
        The number of colours (2 to 65536).

    Returns
    -------
    numpy.ndarray
        The table, (n, 3) uint8.

    Raises
    ------
    ValueError
        For a colour out of 0-255 or not of 3 values, or n out of 2..65536.
    TypeError
        For a colour that is not a sequence, or an n that is not an integer (2.0 too).

    See Also
    --------
    apply_colormap : colours values with a table.

    Examples
    --------
    >>> glmls.analysis.linear_colormap(n=3).tolist()
    [[255, 255, 255], [238, 128, 128], [220, 0, 0]]
    >>> glmls.analysis.linear_colormap((0, 0, 0), (255, 255, 255), n=2).tolist()
    [[0, 0, 0], [255, 255, 255]]
    """
    lo, hi = np.array(as_color(low, "low"), float), np.array(as_color(high, "high"), float)
    n = check_integer("n", n, 2, MAX_COLORS)  # numpy's own errors beyond, or an endless table
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.round(lo + t * (hi - lo)).astype(np.uint8)


def colormap(cmap: object = "viridis") -> np.ndarray:
    """A colour table from ``"viridis"``, ``"linear"`` (white to red), a pair of colours
    ``(low, high)`` for the paper's linear map, or an (n, 3) table of 0-255 values."""
    if isinstance(cmap, str):
        if cmap == "viridis":
            return VIRIDIS
        if cmap == "linear":
            return linear_colormap()
        raise ValueError(f"unknown colour map {cmap!r}; use 'viridis', 'linear' or a table")
    table = np.asarray(cmap)
    if table.shape == (2, 3):
        return linear_colormap(table[0], table[1])
    if table.ndim != 2 or table.shape[1] != 3 or len(table) < 2:
        raise ValueError(
            f"cmap must be a name, a (low, high) colour pair or an (n, 3) table, got {cmap!r}"
        )
    if not np.issubdtype(table.dtype, np.number) or table.min() < 0 or table.max() > 255:
        raise ValueError("a colour table must hold numbers in 0-255")
    return np.round(table).astype(np.uint8)


def check_percentile(name: str, value: object) -> float:
    """A percentile option as a float: a real number (``check_real``)
    in (0, 100]; ``TypeError`` naming ``name`` for another type, ``ValueError`` else."""
    return check_real(name, value, low=0, high=100, low_open=True)


def real_values(values: object, name: str = "values") -> np.ndarray:
    """``values`` as float64 (bools as 0 and 1); ``DtypeError`` naming ``name`` for values
    that are not real numbers, where a cast would drop an imaginary part, read None as NaN
    or fail on a string without naming the argument."""
    array = np.asarray(values)
    if array.dtype.kind not in "biuf":
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    return array.astype(np.float64, copy=False)


def color_limits(
    values: object,
    *,
    vmin: float | None = None,
    vmax: float | None = None,
    percentile: float | None = None,
    span: float = 0.0,
) -> tuple[float, float]:
    """The limits (lo, hi) of a colour scale for ``values``.

    Parameters
    ----------
    values : array_like
        The values; NaN and infinite ones are left out.
    vmin, vmax : float, optional
        The limits where given; else the minimum and the maximum of the values.
    percentile : float, optional
        In (0, 100]: that percentile of the values as a robust upper bound (a few huge
        values, e.g. near a handle, then do not wash out the rest).
    span : float, optional
        The least ``hi - lo`` (>= 0): limits from the values that lie closer are moved apart,
        the one given as ``vmin`` or ``vmax`` staying, else both about their middle, so that
        values equal but for rounding take one colour (:data:`LEAST_SPANS`).

    Returns
    -------
    lo, hi : float
        The limits (0 and 1 for no finite values).

    Raises
    ------
    ValueError
        For a percentile out of (0, 100], or limits that are not finite or with vmin > vmax.
    TypeError
        For a ``vmin``, ``vmax`` or ``percentile`` that is no real number
        (``glmls.core.config.check_real``: a bool, a string, a complex), named; for
        ``values`` that are not real numbers or bools (complex, strings, objects, None).

    Examples
    --------
    >>> values = [0.0, 1.0, 2.0, np.nan, 100.0]
    >>> glmls.analysis.color_limits(values)
    (0.0, 100.0)
    >>> glmls.analysis.color_limits(values, percentile=50)  # NaN left out
    (0.0, 1.5)
    >>> glmls.analysis.color_limits(values, vmin=1.0, vmax=2.0)
    (1.0, 2.0)
    >>> glmls.analysis.color_limits([2e-7, 3e-6], vmin=0.0, span=1e-3)  # rounding noise
    (0.0, 0.001)
    """
    array = real_values(values)
    finite = array[np.isfinite(array)]
    if percentile is not None:
        percentile = check_percentile("percentile", percentile)
    if vmin is not None:
        lo = check_real("vmin", vmin)
    else:
        lo = float(finite.min()) if finite.size else 0.0
    if vmax is not None:
        hi = check_real("vmax", vmax)
    elif not finite.size:
        hi = lo + 1.0
    elif percentile is not None:
        hi = float(np.percentile(finite, percentile))
    else:
        hi = float(finite.max())
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi < lo:
        raise ValueError(f"colour limits must be finite with vmin <= vmax, got ({lo}, {hi})")
    least = check_real("span", span, low=0)
    if hi - lo < least:
        if vmax is None and vmin is not None:
            hi = lo + least
        elif vmin is None and vmax is not None:
            lo = hi - least
        elif vmin is None:
            middle = 0.5 * (lo + hi)
            lo, hi = middle - 0.5 * least, middle + 0.5 * least
    return lo, hi


def picture_limits(
    quantity: str, values: object, *, percentile: float | None = None, unit: float = 1.0
) -> tuple[float, float]:
    """The colour limits of an analysis picture of ``quantity`` (a key of :data:`LEAST_SPANS`).

    The scale runs from the smallest value (white at the minimum, as the paper's figures
    colour their error fields) to the largest (or ``percentile``), and spans at least the
    quantity's least span: above the smallest value for the errors, about the middle for det
    J. The construction errors start at 0, a perfect construction (a scale from the best
    point would flatter them all).

    Parameters
    ----------
    quantity : str
        ``"E_MLS"``, ``"distance"``, ``"angle"``, ``"construction"`` or ``"det_j"``.
    values : array_like
        The picture's values; NaN and infinite ones are left out.
    percentile : float, optional
        A robust upper bound, as :func:`color_limits` takes it.
    unit : float, optional
        The length of a pixel (voxel) in the values' units: E_MLS's least span is taken in
        square units of it (the distance error is relative, the angles in degrees).

    Returns
    -------
    lo, hi : float
        The limits.

    Raises
    ------
    ValueError
        For an unknown ``quantity``, a bad ``percentile`` or ``unit``.
    TypeError
        For a ``percentile`` or ``unit`` that is no real number, named.

    Examples
    --------
    >>> glmls.analysis.picture_limits("angle", [2e-6, 3e-6, 0.0])  # rounding: one colour
    (0.0, 0.001)
    >>> glmls.analysis.picture_limits("angle", [0.5, 2.0, 40.0], percentile=50)
    (0.5, 2.0)
    >>> glmls.analysis.picture_limits("construction", [0.2, 0.4])
    (0.0, 0.4)
    >>> glmls.analysis.picture_limits("det_j", [0.9999999, 1.0000001])
    (0.9995, 1.0005)
    """
    if quantity not in LEAST_SPANS:
        raise ValueError(f"quantity must be one of {sorted(LEAST_SPANS)}, got {quantity!r}")
    length = check_real("unit", unit, low=0, low_open=True)
    span = LEAST_SPANS[quantity] * (length**2 if quantity == "E_MLS" else 1.0)
    if quantity == "E_MLS":
        array = real_values(values)
        finite = np.abs(array[np.isfinite(array)])
        if finite.size:
            span = max(span, LEAST_RELATIVE_SPAN * float(finite.max()))
    if quantity == "construction":
        lo: float | None = 0.0
    elif quantity == "det_j":
        lo = None
    else:  # the least error, where the span starts
        array = real_values(values)  # a complex array's imaginary part is not dropped
        finite = array[np.isfinite(array)]
        lo = float(finite.min()) if finite.size else 0.0
    return color_limits(values, vmin=lo, percentile=percentile, span=span)


def unit_fractions(values: object, lo: float, hi: float) -> np.ndarray:
    """(values - lo) / (hi - lo) in float64 (0 where hi == lo), of halves where the span
    overflows (limits of either sign near float64's largest): not inf / inf."""
    array = np.asarray(values, dtype=np.float64)
    if not hi > lo:
        return np.zeros_like(array)
    with np.errstate(over="ignore", invalid="ignore"):
        if np.isfinite(hi - lo):
            return (array - lo) / (hi - lo)
        return (array / 2 - lo / 2) / (hi / 2 - lo / 2)


def color_indices(values: object, lo: float, hi: float, n: int) -> np.ndarray:
    """Table index of every value (-1 for NaN): round(t (n - 1)), t clipped to [0, 1]."""
    array = np.asarray(values, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        t = np.clip(unit_fractions(array, lo, hi), 0.0, 1.0)
    index = np.floor(t * (n - 1) + 0.5)
    return np.where(np.isnan(array), -1, index).astype(np.int64)


def apply_colormap(
    values: object,
    *,
    cmap: object = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
    percentile: float | None = None,
    nan_color: Sequence[float] = NAN_COLOR,
) -> np.ndarray:
    """Colour an array of values on the CPU (the GPU renderer's reference).

    A value x maps to entry round(t (n - 1)) of an n-colour table, with
    t = clip((x - lo) / (hi - lo), 0, 1) and (lo, hi) from :func:`color_limits`.

    Parameters
    ----------
    values : array_like
        The values, of any shape.
    cmap : str or array_like, optional
        ``"viridis"``, ``"linear"`` (the paper's white to red), a pair of colours
        ``(low, high)`` for a linear map, or an (n, 3) table of 0-255 values.
    vmin, vmax, percentile : float, optional
        The colour limits, as :func:`color_limits` takes them.
    nan_color : sequence of float, optional
        The (r, g, b) colour of NaN values (mid grey by default).

    Returns
    -------
    numpy.ndarray
        ``values.shape + (3,)`` uint8.

    Raises
    ------
    ValueError
        For an unknown colour map, a bad table or colour, or bad limits.
    TypeError
        For a ``nan_color`` that is not a sequence, or ``values`` that are not real numbers
        or bools (complex, strings, objects, None).

    See Also
    --------
    colorbar : the scale's picture.

    Examples
    --------
    >>> glmls.analysis.apply_colormap([0.0, 0.5, 1.0, np.nan], cmap="linear").tolist()
    [[255, 255, 255], [237, 127, 127], [220, 0, 0], [128, 128, 128]]
    >>> glmls.analysis.apply_colormap(np.array([[0.0, 1.0]])).tolist()  # viridis
    [[[68, 1, 84], [253, 231, 37]]]
    """
    table = colormap(cmap)
    lo, hi = color_limits(values, vmin=vmin, vmax=vmax, percentile=percentile)
    index = color_indices(values, lo, hi, len(table))
    out = table[np.maximum(index, 0)]
    out[index < 0] = as_color(nan_color, "nan_color")
    return out


def format_number(value: float, digits: int = 3) -> str:
    """Short tick label: ``digits`` significant digits (whole numbers from 100 on at 3),
    scientific outside [0.01, 10000)."""
    size = abs(value)
    if 100 <= size < 1e4:
        whole = len(str(int(size)))  # digits before the point
        return f"{value:.{max(digits - whole, 0)}f}"
    if value == 0 or 0.01 <= size < 100:
        return f"{value:.{digits}g}"
    text = f"{value:.{digits - 1}e}"
    return text.replace("e+0", "e").replace("e-0", "e-").replace("e+", "e")


#: The most significant digits :func:`tick_labels` gives a label.
MAX_TICK_DIGITS = 12


def tick_labels(values: Sequence[float]) -> list[str]:
    """The labels of ticks at ``values`` (increasing): :func:`format_number`'s, with as many
    more digits (up to :data:`MAX_TICK_DIGITS`) as neighbouring ticks need to read apart
    (0.333 to 0.334 in five ticks: 0.3330, 0.3333, ...)."""
    numbers = [float(v) for v in values]
    distinct = [k for k in range(1, len(numbers)) if numbers[k] != numbers[k - 1]]
    for digits in range(3, MAX_TICK_DIGITS + 1):
        labels = [format_number(v, digits) for v in numbers]
        if all(labels[k] != labels[k - 1] for k in distinct):
            break
    return labels


def colorbar(
    cmap: object,
    lo: float,
    hi: float,
    *,
    length: int = 256,
    thickness: int = 20,
    ticks: int = 5,
    label: str | None = None,
    background: Sequence[float] = (255, 255, 255),
    text_color: Sequence[float] = (0, 0, 0),
    font_size: int = 12,
) -> np.ndarray:
    """A vertical colour bar (maximum at the top) with numbered ticks, as an image.

    Digits are drawn with Pillow's default font.

    Parameters
    ----------
    cmap : str or array_like
        A colour map, as :func:`apply_colormap` takes it.
    lo, hi : float
        The values at the bottom and the top.
    length : int, optional
        The bar's height in pixels (16 to 16384).
    thickness : int, optional
        The bar's width in pixels (2 to 16384).
    ticks : int, optional
        Numbered ticks from ``lo`` to ``hi`` (2 to ``length``).
    label : str, optional
        A title above the bar.
    background, text_color : sequence of float, optional
        (r, g, b) colours, 0-255.
    font_size : int, optional
        The digits' size in pixels (1 to 1024).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) uint8; H is ``length`` plus margins of ``font_size`` above and below (and
        the label's line).

    Raises
    ------
    ValueError
        For limits that are not finite or with lo > hi, ``ticks``, ``length``,
        ``thickness`` or ``font_size`` out of its range (named), a ``label`` or
        ``thickness`` that makes the picture wider than 16384 pixels (named), or a bad
        colour map or colour.
    TypeError
        For limits that are no real numbers, or a ``length``, ``thickness``, ``ticks`` or
        ``font_size`` that is not an integer.

    Examples
    --------
    >>> bar = glmls.analysis.colorbar("viridis", 0.0, 2.0, length=64)
    >>> bar.shape[0], bar.shape[2], bar.dtype.name  # 12 pixels above and below the bar
    (88, 3, 'uint8')
    >>> bar[12, 0].tolist(), bar[12 + 63, 0].tolist()  # the top is the maximum's colour
    ([253, 231, 37], [68, 1, 84])
    """
    table = colormap(cmap)
    lo = check_real("lo", lo, finite=False)
    hi = check_real("hi", hi, finite=False)
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi < lo:
        raise ValueError(f"colour bar limits must be finite with lo <= hi, got ({lo}, {hi})")
    length = check_integer("length", length, 16, MAX_BAR_SIDE)
    thickness = check_integer("thickness", thickness, 2, MAX_BAR_SIDE)
    # a tick a row at most: more would overlap, and draw for as long as there are
    ticks = check_integer("ticks", ticks, 2, length, what=f"an integer from 2 to length ({length})")
    # Pillow refuses 0 and sizes beyond 65535 unnamed, and draws large ones for seconds
    font_size = check_integer("font_size", font_size, 1, MAX_FONT_SIZE)
    font = ImageFont.load_default(size=font_size)
    if np.isfinite(hi - lo):
        values = np.linspace(lo, hi, ticks)
    else:  # lo + (hi - lo) t overflows
        shares = np.linspace(0.0, 1.0, ticks)
        values = lo * (1.0 - shares) + hi * shares
    labels = tick_labels(values)
    text_width = max(int(font.getlength(text)) for text in labels)
    # a tick's mark, then a gap as wide as half a digit's height: the mark right before the
    # digits read as a minus sign
    mark, gap = 5, max(3, font_size // 2)
    margin = font_size  # room for half a label above the top tick and below the bottom one
    top = margin + (font_size + 4 if label else 0)
    labelled = thickness + mark + gap + text_width + 4
    width = max(labelled, int(font.getlength(label)) + 4 if label else 0)
    height = top + length + margin
    if width > MAX_BAR_SIDE:
        cause = "label" if width > labelled else f"thickness {thickness}"
        raise ValueError(
            f"{cause} makes the colour bar {width} pixels wide at font_size {font_size}, "
            f"more than {MAX_BAR_SIDE}; shorten it, or make the font smaller"
        )
    image = Image.new("RGB", (width, height), as_color(background, "background"))
    # bar: row 0 of the bar is the maximum
    t = np.linspace(1.0, 0.0, length)
    rows = table[np.floor(t * (len(table) - 1) + 0.5).astype(int)]
    bar = np.repeat(rows[:, None, :], thickness, axis=1)
    image.paste(Image.fromarray(np.ascontiguousarray(bar)), (0, top))
    draw = ImageDraw.Draw(image)
    ink = as_color(text_color, "text_color")
    for value, text in zip(values, labels, strict=True):
        frac = float(unit_fractions(value, lo, hi))
        y = top + round((1.0 - frac) * (length - 1))
        draw.line([(thickness, y), (thickness + mark - 1, y)], fill=ink)
        draw.text((thickness + mark + gap, y), text, fill=ink, font=font, anchor="lm")
    if label:
        draw.text((0, 2), label, fill=ink, font=font, anchor="la")
    return np.asarray(image)
