"""The options of a volume warp as one value (:class:`VolumeOptions`), and how the
construction cuts a volume into slabs (:class:`SlabOptions`)."""

from __future__ import annotations

import dataclasses
import operator
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..core.config import check_choice, check_integer, is_integer
from ..core.handles import COORDINATE_LIMIT
from ..core.handles3 import as_volume_spacing
from ..core.mesh import check_grid
from ..imaging.frame import real_values
from ..imaging.options import Default
from ..imaging.source import BORDERS, INTERPOLATIONS, check_background

__all__ = ["VOLUME_METHODS", "VOLUME_WARP_KEYWORDS", "SlabOptions", "VolumeOptions"]

#: How a deformed volume is built: ``quads`` (the default, named as the 2D default): the cells
#: method, the deformed cells of the voxel-corner lattice, each split into 6 tetrahedra,
#: filled; ``backward``: each output voxel samples the source at its preimage under f.
VOLUME_METHODS = ("quads", "backward")


def _shown(value: object) -> str:
    """``value`` for a message: an array by its shape (a volume passed as a shape would
    print every voxel)."""
    if isinstance(value, np.ndarray) and value.size > 8:
        return f"an array of shape {value.shape}"
    return repr(value)


def _triple(value: object, name: str, what: str) -> tuple:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError(f"{name} must be {what}, got {_shown(value)}")
    items = list(value)  # type: ignore[call-overload]
    if len(items) != 3:
        raise ValueError(f"{name} must be {what}, got {_shown(value)}")
    return tuple(items)


def volume_shape(shape: object) -> tuple[int, int, int]:
    """The (D, H, W) of ``shape``: (D, H, W), or a volume's (D, H, W, C) with 1 to 4
    channels, as ``volume.shape`` gives it (:func:`check_volume_shape`'s errors; None, which
    a volume's shape never is, a ``TypeError`` too)."""
    if shape is None:
        raise TypeError("shape must be (D, H, W) integers, got None")
    if isinstance(shape, (tuple, list)) and len(shape) == 4 and shape[3] in (1, 2, 3, 4):
        shape = shape[:3]
    return check_volume_shape(shape, "shape")  # type: ignore[return-value]


def check_volume_shape(shape: object, name: str = "output_shape") -> tuple[int, int, int] | None:
    """``shape`` as (D, H, W) ints >= 1 (None stays None): ``TypeError`` for another type
    or sides that are not integers (:func:`~glmls.core.config.is_integer`: 5.0 and True are
    not), ``ValueError`` for another length or a side below 1 or beyond the coordinate
    range (1e6 voxels)."""
    if shape is None:
        return None
    dims = _triple(shape, name, "(D, H, W) integers")
    if not all(is_integer(n) for n in dims):
        raise TypeError(f"{name} must be (D, H, W) integers, got {_shown(shape)}")
    out = (operator.index(dims[0]), operator.index(dims[1]), operator.index(dims[2]))
    if min(out) < 1:
        raise ValueError(f"{name} must have D, H, W >= 1, got {_shown(shape)}")
    if max(out) > COORDINATE_LIMIT:
        raise ValueError(
            f"{name} must have D, H, W <= {COORDINATE_LIMIT:.0e} (glmls's coordinate range, "
            f"voxels), got {_shown(shape)}"
        )
    return out


def check_volume_origin(origin: object) -> tuple[float, float, float] | None:
    """``origin`` as (x0, y0, z0) finite floats (None stays None): ``TypeError`` for values
    that are not real numbers, ``ValueError`` for another length or a value that is not
    finite or beyond the coordinate limit."""
    if origin is None:
        return None
    values = _triple(origin, "origin", "(x0, y0, z0) real numbers")
    within = f"finite and within ±{COORDINATE_LIMIT:.0e}"
    return real_values("origin", values, repr(origin), "(x0, y0, z0) real numbers", within)  # type: ignore[return-value]


@dataclass(frozen=True, kw_only=True)
class VolumeOptions:
    """What volume a 3D warp builds: the keywords of :func:`glmls.volume.warp_volume`.

    Validated when made; frozen, so one value can be changed with
    ``dataclasses.replace``.

    Parameters
    ----------
    method : {"quads", "backward"}, default "quads"
        ``"quads"``, the cells method: the lattice of voxel corners (step ``grid``) is
        deformed by f, each deformed cell split into 6 tetrahedra and filled (the paper's
        construction in 3D; where cells fold, the first cell in scan order of the source,
        smallest (z, y, x), shows). ``"backward"``: each output voxel samples the source at
        its preimage under f, found by Newton's method from the cells' piecewise linear
        inverse (``grid`` is that first guess's lattice step; from grid 2 it is corrected to
        second order by f's inverse Jacobians at the lattice points).
    interpolation : {"nearest", "linear"}, default "nearest"
        One source voxel's value, or trilinear interpolation (float32).
    grid : int or None, default None
        The lattice step in voxels; None: 1 for ``"quads"``, 2 for ``"backward"``
        (:attr:`lattice_step`). For ``"backward"`` it is only the first guess's, which moves
        the result within Newton's tolerance alone (but where f folds, the guess decides
        which of a voxel's preimages Newton finds); 2 costs fewer evaluations of f than 1 (a
        third of its time for a 256^3 volume on a CPU renderer: :doc:`/volumes`, Speed).
    border : {"constant", "edge", "symmetric", "reflect", "wrap"}, default "constant"
        What lies beyond the source volume (:data:`glmls.BORDERS`, numpy.pad's meanings).
    background : float or tuple of float, default 0.0
        What uncovered voxels hold: a scalar, or one value per channel.
    output_shape : (int, int, int) or None, default None
        (D, H, W) of the output; None: the input's.
    origin : (float, float, float) or None, default None
        (x0, y0, z0): output voxel (k, j, i) shows the deformed space's point
        ``origin + (i dx, j dy, k dz)`` (handle units); None: (0, 0, 0).
    spacing : (float, float, float) or None, default None
        (dz, dy, dx): voxel (k, j, i) of the source sits at (i dx, j dy, k dz) in the
        handles' units, and so does output voxel (k, j, i), shifted by ``origin``. A radius
        weight given no radius takes the volume's diagonal in those units, that of
        (D dz, H dy, W dx). None: the MLS's ``spacing``, else (1, 1, 1); one that differs
        from the MLS's is a ValueError.

    Raises
    ------
    ValueError, TypeError
        For a bad value, named.

    Examples
    --------
    >>> from glmls.volume import VolumeOptions
    >>> VolumeOptions(method="backward", output_shape=[4, 5, 6]).output_shape
    (4, 5, 6)
    >>> VolumeOptions(method="backward").lattice_step
    2
    >>> VolumeOptions(method="splat")
    Traceback (most recent call last):
    ...
    ValueError: unknown method 'splat' for a volume; choose one of quads, backward
    """

    method: str = "quads"
    interpolation: str = "nearest"
    grid: int | None = None
    border: str = "constant"
    background: float | tuple[float, ...] = 0.0
    output_shape: tuple[int, int, int] | None = None
    origin: tuple[float, float, float] | None = None
    spacing: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        for name, value, choices in (
            ("method", self.method, VOLUME_METHODS),
            ("interpolation", self.interpolation, INTERPOLATIONS),
            ("border", self.border, BORDERS),
        ):
            check_choice(name, value, choices, " for a volume" if name == "method" else "")
        checked = {
            "grid": None if self.grid is None else check_grid(self.grid, "voxels"),
            "background": check_background(self.background),
            "output_shape": check_volume_shape(self.output_shape),
            "origin": check_volume_origin(self.origin),
            "spacing": None if self.spacing is None else as_volume_spacing(self.spacing),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @property
    def lattice_step(self) -> int:
        """The lattice step the method takes, voxels: ``grid``, or 1 or 2 by the method.

        Where ``grid`` is None: 1 for ``"quads"`` (the construction's own lattice) and 2 for
        ``"backward"`` (only the first guess's: from 2 it is corrected to second order, and
        its lattice costs an eighth of 1's evaluations of f).

        Examples
        --------
        >>> from glmls.volume import VolumeOptions
        >>> VolumeOptions().lattice_step, VolumeOptions(method="backward").lattice_step
        (1, 2)
        >>> VolumeOptions(method="backward", grid=1).lattice_step
        1
        """
        if self.grid is not None:
            return self.grid
        return 2 if self.method == "backward" else 1

    @classmethod
    def of(cls, options: VolumeOptions | None = None, **keywords: object) -> VolumeOptions:
        """``options`` (None: the defaults) with ``keywords`` replacing its fields.

        Parameters
        ----------
        options : VolumeOptions or None
            The starting value.
        **keywords
            Fields of :class:`VolumeOptions`.

        Returns
        -------
        VolumeOptions
            A validated value.

        Raises
        ------
        TypeError
            For a keyword that is no field (named), or ``options`` of another type.

        Examples
        --------
        >>> from glmls.volume import VolumeOptions
        >>> VolumeOptions.of(VolumeOptions(grid=2), method="backward").grid
        2
        """
        if options is not None and not isinstance(options, VolumeOptions):
            raise TypeError(f"options must be a VolumeOptions, got {type(options).__name__}")
        fields = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(keywords) - fields)
        if unknown:
            raise TypeError(
                f"unknown volume warp option{'s' if len(unknown) > 1 else ''} "
                f"{', '.join(unknown)}; the options are {', '.join(sorted(fields))}"
            )
        given = {k: v for k, v in keywords.items() if not isinstance(v, Default)}
        if options is None:
            return cls(**given)  # type: ignore[arg-type]
        return dataclasses.replace(options, **given) if given else options  # type: ignore[arg-type]


#: The keywords of a volume warp (:func:`glmls.volume.warp_volume`): the fields of
#: :class:`VolumeOptions`, ``options`` and ``slabs``.
VOLUME_WARP_KEYWORDS = frozenset(
    {f.name for f in dataclasses.fields(VolumeOptions)} | {"options", "slabs"}
)


@dataclass(frozen=True, kw_only=True)
class SlabOptions:
    """How the volume construction cuts its work into slabs and bands.

    The most bytes of one output slab's buffers (keys or coordinates, and the slab texture)
    and of one band of the deformed lattice, and the source's texture's bytes and side.
    Smaller values give more slabs, bands and pieces of the source, the same result.

    Parameters
    ----------
    slab_bytes : int, default 2**26
        The output slab's largest buffer (4 bytes a voxel for the keys; the backward
        method's largest is its slopes, 48 bytes a voxel, beside 16 for its source points
        and 16 for the list of the voxels its Newton's second pass finishes, over the slab
        and the voxels within 2 of it whose points its fold pass reads: 2 slices more for a
        slab of whole slices, 2 voxels more on every side of a box of columns and rows).
    band_bytes : int, default 2**28
        The deformed lattice's buffer (12 bytes a lattice point; the backward method at grid
        2 and above adds f's inverse Jacobians, 48 bytes a point, and holds at least four
        layers of points), in buffers of at most the GL limit of a storage buffer (128 MiB
        on llvmpipe): as many bands as it holds are kept at once, each evaluated once for
        a slab's passes. The default holds the whole lattice of a 256^3 volume at grid 1
        (204 MB; two buffers on llvmpipe).
    texture_bytes : int, default 2**30
        The source volume's texture: a larger volume is held a few slices at a time (at
        least 4, and ``grid`` + 2 for ``"quads"``), those that each piece of a band of the
        lattice, or each sampling pass over a slab, reads.
    texture_side : int, default 2**20
        The most voxels along each side of the source's texture and of an output slab's
        texture, taken with the GL limit (``GL_MAX_3D_TEXTURE_SIZE``, 2048 on llvmpipe and at
        least 2048 by GL 4.3): the smaller holds. Slices wider or taller than it are held and
        built in boxes of at most that many columns and rows (at least 4, and ``grid`` + 2
        for ``"quads"``). The default leaves the GL limit alone; a small value cuts small
        volumes as the GL limit cuts large ones.

    Examples
    --------
    >>> from glmls.volume import SlabOptions
    >>> SlabOptions(slab_bytes=4096).slab_bytes
    4096
    """

    slab_bytes: int = 1 << 26
    band_bytes: int = 1 << 28
    texture_bytes: int = 1 << 30
    texture_side: int = 1 << 20

    def __post_init__(self) -> None:
        for name in ("slab_bytes", "band_bytes", "texture_bytes"):
            object.__setattr__(self, name, check_integer(name, getattr(self, name), 64))
        object.__setattr__(
            self, "texture_side", check_integer("texture_side", self.texture_side, 4)
        )
