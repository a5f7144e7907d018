"""What the window shows, as one value: the MLS configuration, the image construction, the
border and whether the view fits the whole deformed image; and the steps its keys take."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from ..core.config import MLSConfig, image_diagonal
from ..imaging.adaptive import check_tolerance
from ..imaging.options import WarpOptions
from ..imaging.source import check_options

__all__ = [
    "ALPHA_RANGE",
    "ALPHA_STEP",
    "CONSTRUCTIONS",
    "GRIDS",
    "RADIUS_FACTOR",
    "TOLERANCES",
    "TRANSFORM_ORDER",
    "Settings",
    "bounded_step",
    "cycle",
]

#: The image constructions the window cycles through: (method, interpolation).
CONSTRUCTIONS = (
    ("quads", "nearest"),
    ("quads", "linear"),
    ("splat", "nearest"),
    ("backward", "linear"),
)
GRIDS = (1, 2, 4, 8, 16, 32)
#: The adaptive mesh's tolerances (px) the window cycles through; None: the regular grid.
TOLERANCES = (None, 0.25, 0.05)
#: The transforms in the order ``t`` cycles them (from the most rigid).
TRANSFORM_ORDER = ("rigid", "similarity", "affine")
#: Smallest and largest idw alpha, and the step of + / -.
ALPHA_RANGE = (0.25, 4.0)
ALPHA_STEP = 0.25
#: + / - multiply or divide the radius by this.
RADIUS_FACTOR = 1.25


def bounded_step(value: float, new: float, low: float, high: float) -> float:
    """``new``, one step from ``value``, kept within [low, high]; a ``value`` already
    beyond them (given on the command line) is never stepped the wrong way: up stays up,
    down stays down (or it stays where it is)."""
    if new >= value:
        return min(new, max(high, value))
    return max(new, min(low, value))


def cycle(values: Sequence, value: object, step: int = 1):
    """The value ``step`` places after ``value`` in ``values``, wrapping around."""
    return values[(list(values).index(value) + step) % len(values)]


@dataclass(frozen=True, kw_only=True)
class Settings:
    """What the image window shows: the MLS configuration and the image construction.

    A frozen value: the window's keys replace it with a changed copy (:meth:`stepped`,
    :meth:`next_construction`, :meth:`next_grid`, ...), as ``dataclasses.replace`` does.

    Parameters
    ----------
    config : glmls.MLSConfig, optional
        The transform, the weight and its parameter; ``MLSConfig()`` by default.
    method : str, default "quads"
        The image construction, one of :data:`glmls.METHODS` (as :func:`glmls.warp`'s);
        ``c`` cycles quads (nearest, linear), splat and backward.
    interpolation : {"nearest", "linear"}, default "nearest"
        How the input is sampled.
    grid : int, default 4
        The mesh step in pixels (quads, splat's triangles and the overlays).
    border : str, default "constant"
        What lies beyond the image (:data:`glmls.BORDERS`).
    fit : bool, default False
        Whether the view fits the whole deformed image (``o``) or shows the input's frame.
    tolerance : float, optional
        Pixels: quads (and the mesh and error overlays) on the adaptive mesh of this
        tolerance instead of the regular one at ``grid``; the other constructions ignore it.

    Raises
    ------
    ValueError
        For an unknown method, interpolation or border, a grid below 1, a tolerance that is
        not a positive number, or a construction that refuses the combination.
    TypeError
        For a ``config`` that is not an :class:`~glmls.MLSConfig`, or a ``fit`` that is not
        True or False.

    Examples
    --------
    >>> from glmls.app import Settings
    >>> s = Settings(config=glmls.MLSConfig(weight="gaussian", radius=200.0), grid=8)
    >>> s.parameter((512, 512)), s.stepped((512, 512), up=True).parameter((512, 512))
    ('R 200 px', 'R 250 px')
    >>> s.next_construction().method, s.next_grid(-1).grid, s.warp_options().grid
    ('quads', 4, 8)
    >>> Settings(grid=0)
    Traceback (most recent call last):
    ...
    ValueError: grid must be ...
    """

    config: MLSConfig = field(default_factory=MLSConfig)
    method: str = "quads"
    interpolation: str = "nearest"
    grid: int = 4
    border: str = "constant"
    fit: bool = False
    tolerance: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.config, MLSConfig):
            raise TypeError(f"config must be an MLSConfig, got {type(self.config).__name__}")
        check_options(self.method, self.interpolation, self.grid, self.border)
        if not isinstance(self.fit, bool):
            raise TypeError(f"fit must be True or False, got {self.fit!r}")
        if self.tolerance is not None:
            check_tolerance(self.tolerance)

    @property
    def adaptive(self) -> float | None:
        """The tolerance the image is drawn with: ``tolerance`` for quads, else None.

        Examples
        --------
        >>> from glmls.app import Settings
        >>> Settings(tolerance=0.25).adaptive
        0.25
        >>> print(Settings(method="splat", tolerance=0.25).adaptive)  # splat ignores it
        None
        """
        return self.tolerance if self.method == "quads" else None

    @property
    def mesh_options(self) -> dict[str, object]:
        """The mesh that the construction and the mesh and error overlays use.

        ``{"grid": grid}``, or ``{"tolerance": t}`` on the adaptive mesh (quads).

        Examples
        --------
        >>> from glmls.app import Settings
        >>> Settings(grid=8).mesh_options
        {'grid': 8}
        >>> Settings(grid=8).next_tolerance().mesh_options  # the adaptive mesh
        {'tolerance': 0.25}
        """
        tolerance = self.adaptive
        return {"grid": self.grid} if tolerance is None else {"tolerance": tolerance}

    def warp_options(self, **changes: object) -> WarpOptions:
        """The image construction as the pipeline takes it, a :class:`~glmls.WarpOptions`.

        Its method, interpolation, border and :attr:`mesh_options` are the settings', with
        ``changes`` on top.

        Parameters
        ----------
        **changes : object
            Other fields of :class:`~glmls.WarpOptions`, e.g. the canvas (``output_shape``,
            ``origin``).

        Returns
        -------
        glmls.WarpOptions
            The options for :func:`glmls.warp` and the other image functions.

        Examples
        --------
        >>> from glmls.app import Settings
        >>> options = Settings(method="splat", grid=8).warp_options(output_shape=(40, 60))
        >>> options.method, options.grid, options.output_shape
        ('splat', 8, (40, 60))
        """
        values = {"method": self.method, "interpolation": self.interpolation}
        values |= {"border": self.border, **self.mesh_options, **changes}
        return WarpOptions(**values)  # type: ignore[arg-type]

    def parameter(self, shape: tuple[int, int]) -> str:
        """The weight's parameter as text, e.g. ``alpha 1.25`` or ``R 362 px``.

        Parameters
        ----------
        shape : tuple of int
            (H, W) of the image (a default radius is the image's diagonal).

        Returns
        -------
        str
            What the readout shows.

        Examples
        --------
        >>> from glmls.app import Settings
        >>> Settings().parameter((300, 400))  # idw by default
        'alpha 1'
        >>> gaussian = Settings(config=glmls.MLSConfig(weight="gaussian"))
        >>> gaussian.parameter((300, 400))  # the default radius: the image's diagonal
        'R 500 px'
        """
        config = self.config
        if config.uses_radius:
            return f"R {config.resolve_radius(shape):.0f} px"
        return f"alpha {config.alpha:g}"

    def stepped(self, shape: tuple[int, int], up: bool) -> Settings:
        """The weight's parameter one step up or down (``+`` and ``-``).

        idw's alpha steps by ``ALPHA_STEP`` within ``ALPHA_RANGE``, another weight's
        radius is multiplied or divided by ``RADIUS_FACTOR`` (1 px to 100 image
        diagonals); a value given beyond those bounds is never stepped the wrong way.

        Parameters
        ----------
        shape : tuple of int
            (H, W) of the image (a default radius is the image's diagonal).
        up : bool
            Up (``+``) or down (``-``).

        Returns
        -------
        Settings
            The changed copy.

        Examples
        --------
        >>> from glmls.app import Settings
        >>> s = Settings()  # idw, alpha 1
        >>> s.stepped((300, 400), up=True).config.alpha
        1.25
        >>> gaussian = Settings(config=glmls.MLSConfig(weight="gaussian", radius=100.0))
        >>> gaussian.stepped((300, 400), up=False).config.radius
        80.0
        """
        config = self.config
        if config.uses_radius:
            radius = float(config.resolve_radius(shape))  # type: ignore[arg-type]
            new = radius * RADIUS_FACTOR if up else radius / RADIUS_FACTOR
            radius = bounded_step(radius, new, 1.0, 100 * image_diagonal(shape))
            return replace(self, config=replace(config, radius=radius))
        new = config.alpha + (ALPHA_STEP if up else -ALPHA_STEP)
        alpha = bounded_step(config.alpha, new, *ALPHA_RANGE)
        return replace(self, config=replace(config, alpha=alpha))

    def next_construction(self) -> Settings:
        """The next of ``CONSTRUCTIONS`` (the first if the current one is none of them).

        Returns
        -------
        Settings
            The changed copy (``c``).

        Examples
        --------
        >>> from glmls.app import Settings
        >>> s = Settings()
        >>> for _ in range(4):
        ...     s = s.next_construction()
        ...     print(s.method, s.interpolation)
        quads linear
        splat nearest
        backward linear
        quads nearest
        """
        pair = (self.method, self.interpolation)
        index = CONSTRUCTIONS.index(pair) if pair in CONSTRUCTIONS else -1
        method, interpolation = CONSTRUCTIONS[(index + 1) % len(CONSTRUCTIONS)]
        return replace(self, method=method, interpolation=interpolation)

    def next_tolerance(self) -> Settings:
        """The next of ``TOLERANCES`` (the first if the current one is none of them).

        Returns
        -------
        Settings
            The changed copy (``T``).

        Examples
        --------
        >>> from glmls.app import Settings
        >>> s = Settings()
        >>> print(s.tolerance)  # the regular grid
        None
        >>> s.next_tolerance().tolerance, s.next_tolerance().next_tolerance().tolerance
        (0.25, 0.05)
        >>> print(Settings(tolerance=0.05).next_tolerance().tolerance)  # back to the grid
        None
        """
        index = TOLERANCES.index(self.tolerance) if self.tolerance in TOLERANCES else -1
        return replace(self, tolerance=TOLERANCES[(index + 1) % len(TOLERANCES)])

    def next_grid(self, step: int) -> Settings:
        """The grid ``step`` places along ``GRIDS`` (``g`` and ``G``).

        It stops at the ends; from a grid between them (``--grid 3``) the first step is to
        the next one that way, and past the coarsest (``--grid 64``) ``G`` keeps it.

        Parameters
        ----------
        step : int
            Places to move: negative for finer, positive for coarser.

        Returns
        -------
        Settings
            The changed copy.

        Examples
        --------
        >>> from glmls.app import Settings
        >>> Settings(grid=4).next_grid(-1).grid, Settings(grid=4).next_grid(+2).grid
        (2, 16)
        >>> Settings(grid=1).next_grid(-1).grid  # the finest already
        1
        >>> Settings(grid=3).next_grid(-1).grid, Settings(grid=3).next_grid(+1).grid
        (2, 4)
        """
        if self.grid in GRIDS:
            index = GRIDS.index(self.grid) + step
        elif step < 0:
            index = sum(g < self.grid for g in GRIDS) + step
        else:
            index = sum(g < self.grid for g in GRIDS) + step - 1
            if index >= len(GRIDS):
                return self
        return replace(self, grid=GRIDS[min(max(index, 0), len(GRIDS) - 1)])
