"""MLS settings: the transform, the distance weight (``glmls.core.weights``) and its parameters."""

from __future__ import annotations

import math
import numbers
import operator
import os
from dataclasses import dataclass, field

import numpy as np

from .weights import RADIUS_WEIGHTS, REGISTRY, WEIGHTS, Weight

__all__ = [
    "RADIUS_WEIGHTS",
    "TRANSFORMS",
    "WEIGHTS",
    "MLSConfig",
    "check_choice",
    "check_flag",
    "check_integer",
    "check_real",
    "check_result_bytes",
    "check_seed",
    "check_sequence",
    "config_or_options",
    "counted",
    "image_diagonal",
    "is_integer",
    "physical_memory",
    "transform_code",
]

#: The transforms of Schaefer et al. (2006); a transform's index is its code in the shaders
#: (``MLS_TRANSFORM`` in ``glmls/shaders/mls/core.glsl``).
TRANSFORMS = ("affine", "similarity", "rigid")

#: The largest idw power: d^(4 alpha) (``interpolating``) of any distance within the
#: coordinate range (±1e6 px, distances up to 2.9e6 px) stays within float64 (the
#: reference's weights), and alpha within float32 (the shaders'). The paper's typical values
#: are 1 and 2.
MAX_ALPHA = 10.0


def transform_code(name: str) -> int:
    """``MLS_TRANSFORM`` of a transform name."""
    return TRANSFORMS.index(name)


def check_choice(name: str, value: object, choices: tuple[str, ...], where: str = "") -> str:
    """``value`` if it is one of the strings ``choices``: ``TypeError`` naming ``name`` for
    a value that is no string (None, a number), ``ValueError`` for another string (``where``,
    e.g. " for a volume", said after the value)."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, one of {', '.join(choices)}; got {value!r}")
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}{where}; choose one of {', '.join(choices)}")
    return str(value)


def check_flag(name: str, value: object) -> bool:
    """``value`` as a bool if it is one (numpy's too); ``TypeError`` naming ``name`` else
    (1, "yes" and None are not flags)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def is_integer(value: object) -> bool:
    """Whether ``value`` is an integer as every integer option of glmls takes one: a Python
    or numpy integer, or a 0-d integer array (what :func:`operator.index` accepts, as numpy's
    own sizes do), but not a bool, and not a float even where it is whole (``2.0``)."""
    if isinstance(value, (bool, np.bool_)):
        return False
    try:
        operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        return False
    return True


def check_integer(
    name: str, value: object, low: int, high: int | None = None, *, what: str | None = None
) -> int:
    """``value`` as an int from ``low`` to ``high`` (None: no upper bound).

    The one rule of glmls's integer options (:func:`is_integer`): a value of another type
    (a float such as ``2.0``, a bool, a string, None) is a ``TypeError``, an integer out of
    range a ``ValueError``; both name ``name`` and the value, in the same words (``what``:
    what the option must be; by default "an integer >= low" or "an integer from low to
    high")."""
    if what is None:
        what = f"an integer >= {low}" if high is None else f"an integer from {low} to {high}"
    message = f"{name} must be {what}, got {value!r}"
    if not is_integer(value):
        raise TypeError(message)
    number = operator.index(value)  # type: ignore[arg-type]
    if number < low or (high is not None and number > high):
        raise ValueError(message)
    return number


def check_real(
    name: str,
    value: object,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    finite: bool = True,
    what: str | None = None,
) -> float:
    """``value`` as a float: the one rule of glmls's real-valued options.

    A real number is a Python ``int`` or ``float``, a numpy integer or floating scalar, or a
    0-d array (or tensor) of one, taken as its number. A bool (numpy's too), a string, None,
    a complex, and an array of another shape (``np.array([0.5])``) are a ``TypeError`` naming
    ``name``, the value and its type. A value that is not finite (NaN, ±inf; allowed where
    ``finite`` is False, as for a fill value) or out of range is a ``ValueError`` naming
    ``name`` and the value. The range runs from ``low`` to ``high`` (None: unbounded), a bound
    excluded where ``low_open`` or ``high_open`` is set. ``what`` is what the messages say the
    option must be (by default "a finite number" and the range). -0.0 is returned as 0.0.
    """
    if what is None:
        what = _real_what(low, high, low_open, high_open, finite)
    number = value
    if getattr(number, "ndim", None) == 0 and hasattr(number, "item"):
        number = number.item()  # type: ignore[union-attr]  # a numpy scalar or 0-d array
    if isinstance(number, (bool, np.bool_)) or not isinstance(number, numbers.Real):
        raise TypeError(f"{name} must be {what}, got {value!r} ({type(value).__name__})")
    try:
        result = float(number) + 0.0  # type: ignore[arg-type]
    except OverflowError:  # an int beyond float64
        raise ValueError(f"{name} must be {what}, got {value!r}") from None
    if finite and not math.isfinite(result):
        raise ValueError(f"{name} must be {what}, got {value!r}")
    below = low is not None and (result <= low if low_open else result < low)
    above = high is not None and (result >= high if high_open else result > high)
    if below or above:
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return result


def _real_what(
    low: float | None, high: float | None, low_open: bool, high_open: bool, finite: bool
) -> str:
    """What :func:`check_real`'s messages say a value must be, by default."""
    noun = "a finite number" if finite else "a number"
    if low is not None and high is not None:
        if not (low_open or high_open):
            return f"{noun} from {low:g} to {high:g}"
        return f"{noun} in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    if low is not None:
        return f"{noun} {'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f"{noun} {'<' if high_open else '<='} {high:g}"
    return noun


def physical_memory() -> int | None:
    """This machine's physical memory in bytes, or None where the system does not say."""
    try:
        pages, page_size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # no sysconf, or no such name (Windows)
        return None
    return pages * page_size if pages > 0 and page_size > 0 else None


def check_result_bytes(what: str, nbytes: int) -> None:
    """``ValueError`` where the arrays of a result (``what``: the call and its shape, for the
    message) need more than this machine's physical memory, ``nbytes`` in all.

    Checked before anything is allocated or evaluated, so that a huge shape fails at once
    with the sizes to compare, rather than as numpy's ``MemoryError``, a GL error, or the
    swapping (or the kernel's out-of-memory kill) of an allocation that the system
    overcommits. A result that fits may still fail where other processes hold the memory;
    where the system does not say its memory (:func:`physical_memory` None), nothing is
    checked."""
    memory = physical_memory()
    if memory is not None and nbytes > memory:
        raise ValueError(
            f"{what} needs {nbytes:,} bytes ({nbytes / 2**30:,.1f} GiB), more than this "
            f"machine's memory of {memory:,} bytes ({memory / 2**30:,.1f} GiB)"
        )


def counted(count: int, noun: str, plural: str | None = None) -> str:
    """``count`` and ``noun`` for a message, the noun plural unless the count is 1:
    ``counted(1, "pixel")`` is "1 pixel", ``counted(3, "pixel")`` "3 pixels"."""
    return f"{count} {noun if count == 1 else (plural or noun + 's')}"


def check_seed(seed: object) -> int:
    """``seed`` if it is an integer >= 0 (a random draw's seed): ``TypeError`` naming it for
    another type (True is no seed), ``ValueError`` for a negative one."""
    return check_integer("seed", seed, 0)


def check_sequence(name: str, value: object, what: str) -> list:
    """``value``'s items as a list: ``TypeError`` naming ``name`` for a string or bytes (which
    would be read one character at a time) or a value that is no sequence (None, a number,
    one item alone); ``what`` says what the items are."""
    message = f"{name} must be a sequence of {what}, got {value!r}"
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{message}; for one, write [{value!r}]")
    try:
        return list(value)  # type: ignore[call-overload]
    except TypeError:
        raise TypeError(message) from None


def config_or_options(config: MLSConfig | None, options: dict[str, object]) -> MLSConfig:
    """``config``, or an :class:`MLSConfig` of the keyword ``options`` where it is None.

    Both at once is a ``TypeError`` naming the options: one of them would go unused, and f
    would silently be another weight's or transform's than the one asked for; so is a
    ``config`` that is no :class:`MLSConfig`.
    """
    if config is None:
        return MLSConfig(**options)  # type: ignore[arg-type]
    if not isinstance(config, MLSConfig):  # (a name such as "rigid" is a keyword's value)
        raise TypeError(f"config must be an MLSConfig, got {type(config).__name__}")
    if options:
        names = ", ".join(sorted(options))
        raise TypeError(
            f"give a config or its keyword options ({names}), not both: "
            f"dataclasses.replace(config, {names.split(', ')[0]}=...) changes a field"
        )
    return config


@dataclass(frozen=True, kw_only=True)
class MLSConfig:
    """How f is built from the handles: the transform and the distance weight (Table 1).

    A frozen dataclass of keyword-only fields; each field's ``metadata["help"]`` is its
    one-line description (the command line's help). d below is the distance from the
    evaluated point to a source handle, R the ``radius``.

    Parameters
    ----------
    transform : {"rigid", "similarity", "affine"}
        The MLS transform of Schaefer et al. (2006): affine (eq. 5), similarity (eq. 6) or
        rigid (the similarity's rotation, normalised).
    weight : {"idw", "cressman", "shepard", "gaussian", "linear"}
        A name of ``glmls.core.weights.REGISTRY``: ``idw`` 1 / (s + d^(2 alpha));
        ``cressman`` max(0, (R² - d²) / (R² + d²)); ``shepard`` max(0, (R - d) / (R d));
        ``gaussian`` exp(-d² / R²); ``linear`` max(0, R - d).
    alpha : float
        The idw power (> 0 and <= ``MAX_ALPHA``, 10), also used by ``interpolating``.
    s : float
        idw's adjusting term (>= 0), in pixel units (squared when alpha = 1).
    radius : float or None
        R in pixels (> 0); None means the image diagonal where an image size is known (the
        paper's best choice); the radius weights need one or the other.
    interpolating : bool
        Multiply the weight by 1 / d^(2 alpha), so that f(p_i) = q_i for every weight.
        Cressman, Gaussian and linear weights are finite at d = 0, so without this f(p_i) can
        miss q_i (by tens of pixels when R is wide).

    Raises
    ------
    ValueError
        For an unknown transform or weight, alpha <= 0 or > 10, s < 0, radius <= 0, or a value that
        is not finite.
    TypeError
        For a value of the wrong type (a transform that is not a string, a number that is not
        real, ``interpolating`` that is not a bool).

    See Also
    --------
    glmls.MLS : takes these fields as keywords, or a ``config=``.

    Examples
    --------
    >>> config = glmls.MLSConfig(transform="similarity", weight="gaussian", radius=50)
    >>> config.radius, config.uses_radius
    (50.0, True)
    >>> glmls.MLSConfig(weight="cressman").resolve_radius((3, 4))  # the image diagonal
    5.0
    >>> glmls.MLSConfig(transform="projective")
    Traceback (most recent call last):
        ...
    ValueError: unknown transform 'projective'; choose one of affine, similarity, rigid
    """

    transform: str = field(default="rigid", metadata={"help": "MLS transform"})
    weight: str = field(default="idw", metadata={"help": "distance weight (paper's Table 1)"})
    alpha: float = field(default=1.0, metadata={"help": "idw power (and interpolating's)"})
    s: float = field(
        default=1e-8,
        metadata={"help": "idw adjusting term, in the handles' units to the power 2 alpha (px^2)"},
    )
    radius: float | None = field(
        default=None,
        metadata={
            "help": "influence radius in the handles' units, pixels for an image (default: the "
            "image's diagonal, a volume's in its handles' units; a mesh needs one)"
        },
    )
    interpolating: bool = field(
        default=False, metadata={"help": "make any weight interpolate the handles"}
    )

    def __post_init__(self) -> None:
        # numpy's str_ and bool_ are stored as str and bool (equal, hashed alike, printed plainly)
        object.__setattr__(self, "transform", check_choice("transform", self.transform, TRANSFORMS))
        object.__setattr__(self, "weight", check_choice("weight", self.weight, tuple(REGISTRY)))
        alpha = check_real("alpha", self.alpha, low=0, low_open=True)
        if alpha > MAX_ALPHA:
            raise ValueError(
                f"alpha must be <= {MAX_ALPHA:g} (beyond, d^(2 alpha) of distances within the "
                f"coordinate range leaves float64; typical values are 1 and 2), got {alpha}"
            )
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "s", check_real("s", self.s, low=0))
        if self.radius is not None:
            radius = check_real("radius", self.radius, low=0, low_open=True)
            object.__setattr__(self, "radius", radius)
        object.__setattr__(self, "interpolating", check_flag("interpolating", self.interpolating))

    @property
    def weight_entry(self) -> Weight:
        """The weight's entry in ``glmls.core.weights.REGISTRY``.

        Examples
        --------
        >>> entry = glmls.MLSConfig(weight="idw").weight_entry
        >>> entry.name, entry.formula, entry.needs_radius
        ('idw', '1 / (s + d^(2 alpha))', False)
        """
        return REGISTRY[self.weight]

    @property
    def uses_radius(self) -> bool:
        """Whether the weight needs an influence radius (all but ``idw``).

        Examples
        --------
        >>> glmls.MLSConfig(weight="idw").uses_radius
        False
        >>> glmls.MLSConfig(weight="gaussian").uses_radius
        True
        """
        return self.weight_entry.needs_radius

    @property
    def infinite_at_zero(self) -> bool:
        """Whether w(0) is infinite, so that MLS interpolates the handles exactly.

        Examples
        --------
        >>> glmls.MLSConfig().infinite_at_zero  # idw's s > 0 keeps w(0) finite
        False
        >>> glmls.MLSConfig(interpolating=True).infinite_at_zero
        True
        """
        return self.interpolating or self.weight_entry.infinite_at_zero(self)

    @property
    def pole(self) -> float:
        """The power p of the weight's pole at d = 0, w ~ 1 / d^p (0 where w(0) is finite).

        The registry's ``pole``, times 1 / d^(2 alpha) more where interpolating.

        Examples
        --------
        >>> glmls.MLSConfig(s=0.0).pole, glmls.MLSConfig(interpolating=True).pole
        (2.0, 2.0)
        """
        return self.weight_entry.pole(self) + (2.0 * self.alpha if self.interpolating else 0.0)

    def resolve_radius(self, shape: tuple[int, int] | None) -> float | None:
        """R in pixels: the given radius, else the diagonal of an image of ``shape``.

        Parameters
        ----------
        shape : tuple of int or None
            (H, W) of the image, if known.

        Returns
        -------
        float or None
            The radius; None for a weight that needs none and was given none.

        Raises
        ------
        ValueError
            When a radius weight has neither a radius nor a shape.

        Examples
        --------
        >>> glmls.MLSConfig(weight="gaussian").resolve_radius((30, 40))  # the diagonal
        50.0
        >>> glmls.MLSConfig(weight="gaussian", radius=12.0).resolve_radius((30, 40))
        12.0
        >>> print(glmls.MLSConfig(weight="idw").resolve_radius((30, 40)))
        None
        """
        if not self.uses_radius:
            return self.radius
        if self.radius is not None:
            return self.radius
        if shape is None:
            raise ValueError(
                f"weight {self.weight!r} needs an influence radius: pass radius=R (pixels), "
                "or shape=(H, W) to use the image diagonal"
            )
        return image_diagonal(shape)


def image_diagonal(shape: tuple[int, int]) -> float:
    """Length of the diagonal of an H x W image, in pixels."""
    return math.hypot(shape[0], shape[1])
