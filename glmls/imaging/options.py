"""Options as values: :class:`WarpOptions`, what image a warp builds (the keywords of
:meth:`glmls.MLS.warp`, carried as one value through :func:`glmls.warp`, the
:class:`~glmls.gl.WarpPipeline`, the report and the command line), and
:class:`PipelineOptions`, how a :class:`~glmls.gl.WarpPipeline` builds it (the choices between
equivalent internal paths: the defaults are the fastest; tests and benchmarks take the other
paths by passing other options, never by changing module state)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TypeVar, cast

from ..core.config import check_flag, check_integer
from ..core.mesh import check_grid
from .adaptive import check_adaptive
from .frame import check_origin, check_output_shape
from .source import check_background, check_options

__all__ = ["FIELDS", "Default", "PipelineOptions", "WarpOptions", "default"]

_T = TypeVar("_T")


class Default:
    """A keyword's default value, marked as not given by the caller: it reads as the value
    itself (``repr``), so that signatures show ``method='quads'``, while
    :meth:`WarpOptions.of` can tell it from a value the caller gave explicitly."""

    __slots__ = ("wrapped",)

    def __init__(self, value: object) -> None:
        self.wrapped = value

    def __repr__(self) -> str:
        return repr(self.wrapped)


def default(value: _T) -> _T:
    """``value`` as a keyword's ``Default`` (typed as the value, for annotations)."""
    return cast(_T, Default(value))


@dataclass(frozen=True, kw_only=True)
class WarpOptions:
    """What image a warp builds: the keywords of :meth:`glmls.MLS.warp` as one value.

    Validated when made; frozen (hashable, picklable), so one value can travel through a
    program and be changed with ``dataclasses.replace``.

    Parameters
    ----------
    method : {"quads", "splat", "backward", "backward-swap", "paper-quads"}, default "quads"
        How the deformed image is built (:data:`glmls.METHODS`; see :meth:`glmls.MLS.warp`).
    interpolation : {"nearest", "linear"}, default "nearest"
        One source pixel's value, or bilinear interpolation.
    grid : int, default 1
        The mesh step in pixels (``paper-quads``: 1 only).
    tolerance : float or None, default None
        Pixels: ``quads`` on the error-bounded adaptive mesh (``grid`` must stay 1); None:
        the regular mesh at ``grid``.
    border : {"constant", "edge", "symmetric", "reflect", "wrap"}, default "constant"
        What lies beyond the source image (:data:`glmls.BORDERS`).
    background : float or tuple of float, default 0.0
        What uncovered pixels hold: a scalar, or one value per channel (1 to 4 values; the
        image decides which counts fit). Stored as a float or a tuple of floats.
    output_shape : (int, int) or None, default None
        (H, W) of the output canvas; None: the input's. Stored as a tuple of ints.
    origin : (float, float) or None, default None
        (x0, y0): output pixel (column i, row j) shows the deformed plane's point
        ``origin + (i, j)``; None: (0, 0). Stored as a tuple of floats.

    Raises
    ------
    ValueError
        For an unknown ``method``, ``interpolation`` or ``border``, a ``grid`` outside 1 ..
        2**20 (or not 1 with ``paper-quads`` or with a ``tolerance``), a ``tolerance`` below
        0.001 px or with another method than ``quads``, a ``background`` of more than 4
        values, an ``output_shape`` that is not two values or has a side below 1, or an
        ``origin`` that is not two values or not finite; the message names the value.
    TypeError
        For a value of the wrong type: a ``grid`` or ``output_shape`` side that is not an
        integer (integer options take Python and numpy integers; a float such as ``2.0``
        or a bool is refused, as numpy refuses them for sizes), a ``tolerance``,
        ``background`` or ``origin`` value that is not a real number (a string, a bool, a
        complex); the message names the value.

    Examples
    --------
    >>> import dataclasses
    >>> import glmls
    >>> options = glmls.WarpOptions(method="backward", interpolation="linear")
    >>> options.method, options.grid, options.background
    ('backward', 1, 0.0)
    >>> dataclasses.replace(options, output_shape=[4, 6]).output_shape
    (4, 6)
    >>> glmls.WarpOptions(method="swirl")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: unknown method 'swirl'; choose one of quads, splat, backward, ...
    """

    method: str = "quads"
    interpolation: str = "nearest"
    grid: int = 1
    tolerance: float | None = None
    border: str = "constant"
    background: float | tuple[float, ...] = 0.0
    output_shape: tuple[int, int] | None = None
    origin: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        check_options(self.method, self.interpolation, self.grid, self.border)
        checked = {
            "grid": check_grid(self.grid),
            "tolerance": check_adaptive(self.method, self.grid, self.tolerance),
            "background": check_background(self.background),
            "output_shape": check_output_shape(self.output_shape),
            "origin": check_origin(self.origin),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @classmethod
    def of(cls, options: WarpOptions | None = None, **keywords: object) -> WarpOptions:
        """``options`` (None: the defaults) with the caller's ``keywords`` replacing fields.

        A keyword left at its ``Default`` keeps the field.

        Parameters
        ----------
        options : WarpOptions or None
            The starting value.
        **keywords
            Fields of :class:`WarpOptions`, each a value or a ``Default``.

        Returns
        -------
        WarpOptions
            ``options`` itself where no keyword was given, else a new, validated value.

        Raises
        ------
        TypeError
            If ``options`` is not a WarpOptions, or for a keyword that is no field (named).
        ValueError
            For a bad value (see :class:`WarpOptions`).

        Examples
        --------
        >>> from glmls.imaging.options import WarpOptions, default
        >>> base = WarpOptions(method="backward", grid=4)
        >>> WarpOptions.of(base, grid=2, method=default("quads")).grid
        2
        >>> WarpOptions.of(base, grid=2, method=default("quads")).method
        'backward'
        """
        if options is not None and not isinstance(options, WarpOptions):
            raise TypeError(f"options must be a glmls.WarpOptions, got {type(options).__name__}")
        unknown = sorted(set(keywords) - FIELDS)
        if unknown:
            raise TypeError(
                f"unknown warp option{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}; "
                f"the options are {', '.join(f.name for f in dataclasses.fields(cls))}"
            )
        given = {k: v for k, v in keywords.items() if not isinstance(v, Default)}
        if options is None:
            return cls(**given)  # type: ignore[arg-type]
        return dataclasses.replace(options, **given) if given else options  # type: ignore[arg-type]


#: The names of :class:`WarpOptions`' fields.
FIELDS = frozenset(f.name for f in dataclasses.fields(WarpOptions))


@dataclass(frozen=True, kw_only=True)
class PipelineOptions:
    """How a :class:`~glmls.gl.WarpPipeline` builds images, between equivalent paths.

    The choices between internal paths that give the same images; the defaults are the
    fastest.

    Parameters
    ----------
    compute_quads : bool, default True
        Scan-convert the quads in a compute shader (False: the GL rasterizer draws two
        triangles per cell, as it does for other viewports).
    fast_embedded : bool, default True
        Nearest quads of 8-bit images first take the pass without keys, redone with keys
        only where the mesh is not shown to be an embedding.
    band_bytes : int, default 2**26
        The largest mesh buffer of one band; bigger meshes are evaluated band by band (and
        the GL rasterizer's index buffer stays within it too).
    fixup_min, fixup_fraction : int, default 4096 and 8
        Capacity of the fused quads' fix-up list (pixels where triangles overlap): one pixel
        in ``fixup_fraction``, at least ``fixup_min``; beyond it (heavy fold-overs) every
        pixel is redone instead: slower, same result.

    Raises
    ------
    ValueError
        If ``band_bytes``, ``fixup_min`` or ``fixup_fraction`` is an integer below 1 (named).
    TypeError
        If one of them is not an integer (a float such as 4096.0, a bool), or
        ``compute_quads`` or ``fast_embedded`` is not a bool (named).

    Examples
    --------
    >>> import glmls
    >>> options = glmls.gl.PipelineOptions(band_bytes=4096)
    >>> options.fixup_capacity(100_000)
    12500
    >>> glmls.gl.PipelineOptions(fixup_min=0)
    Traceback (most recent call last):
    ...
    ValueError: fixup_min must be an integer >= 1, got 0
    """

    compute_quads: bool = True
    fast_embedded: bool = True
    band_bytes: int = 1 << 26
    fixup_min: int = 4096
    fixup_fraction: int = 8

    def __post_init__(self) -> None:
        for name in ("band_bytes", "fixup_min", "fixup_fraction"):
            object.__setattr__(self, name, check_integer(name, getattr(self, name), 1))
        for name in ("compute_quads", "fast_embedded"):
            object.__setattr__(self, name, check_flag(name, getattr(self, name)))

    def fixup_capacity(self, pixels: int) -> int:
        """The fix-up list's capacity for a target of ``pixels`` pixels.

        Parameters
        ----------
        pixels : int
            The target's pixels.

        Returns
        -------
        int
            ``max(fixup_min, pixels // fixup_fraction)``.
        """
        return max(self.fixup_min, pixels // self.fixup_fraction)
