"""Reading and writing volumes: NIfTI (``.nii``, ``.nii.gz``, through nibabel), TIFF stacks
(``.tif``, ``.tiff``, through tifffile) and NumPy arrays (``.npy``).

glmls volumes are (D, H, W) = (z, y, x) arrays, or (D, H, W, C) with C channels, and their
points are (x, y, z) = (column, row, slice) with voxel centres at integer coordinates, as
images are (H, W) arrays with points (x, y). A NIfTI data array is indexed (i, j, k) =
(x, y, z), so reading transposes it to (z, y, x) and writing back again: the voxel at NIfTI
index (i, j, k) is ``volume.data[k, j, i]``, glmls's point (i, j, k). The NIfTI affine maps
voxel indices (i, j, k, 1) to world coordinates, so it maps glmls's points (x, y, z, 1) to
the world as they are: it is kept as read, unchanged. Channels are NIfTI's vector
dimension, the 5th ((i, j, k, 1, C), intent ``vector``, as ITK writes vector images; the 4th
is time): written so, and read from it or from RGB records. A time series (i, j, k, T) is
read as T channels, one a time point, and written back as it was read: 4D, with its time
step (:class:`NiftiHeader`). A volume read from a NIfTI file keeps the header fields that
say what its numbers mean and stay true of it warped in space (:class:`NiftiHeader`: the
sform and qform codes, the units, the description, the intent, ``cal_min``/``cal_max``,
``aux_file``, ``toffset``), and :func:`write_volume` writes them back; the intents of
components in the space's frame (vectors, displacements, matrices), which a warp does not
turn, ``dim_info`` and the slice timing (the warp moves the slices) are not carried, and are
written as nibabel's defaults.

:class:`Volume` holds the data, the voxel spacing (dz, dy, dx) (in the order of the array's
axes, as :meth:`glmls.MLS.warp` takes it) and the affine, where the file says them:

- NIfTI: the affine; the spacing is the length of its columns (k, j, i); the header fields
  :class:`~glmls.files.NiftiHeader` holds;
- TIFF: the spacing of a calibrated ImageJ stack (its ``spacing``, 1 where ImageJ leaves
  it out, and X/Y resolutions, which :func:`write_volume` writes), of an OME-TIFF (its
  ``PhysicalSizeZ``, ``Y``, ``X``, in micrometres where their units differ), or the
  ``"spacing": [dz, dy, dx]`` of the JSON description of the first page (which
  :func:`write_volume` writes for the dtypes ImageJ does not hold), else none; no affine;
- ``.npy``: the array only.

A TIFF is a volume when it holds more than one page (a stack; a stack written one slice a
write too, whose pages tifffile makes series of their own); one page is an image
(:func:`glmls.imread`). The pages are slices where the file's axes (ImageJ's or OME's
metadata, as tifffile reads them) have a Z axis, or where no metadata names them; channels
are an axis C or S beside it (``ZCYX``, ``CZYX``, ``ZYXS``), or, for a stack of one channel
(D, H, W, 1) as :func:`write_volume` writes it, ``channel_axis=true`` in its ImageJ
description or the JSON description of its first page, or the shape (D, H, W, 1) of
tifffile's JSON description (``tifffile.imwrite`` of such an array, ``photometric=
"minisblack"``); a stack without either reads as (D, H, W). A stack of the channels or time
points of one 2D image (axes ``CYX``, ``TYX``, ``TCYX``) is refused, not read as slices, and
so is a time series of volumes (``TZYX``, ``TZCYX``), a file without axes metadata whose
pages are not all of one shape, dtype and kind (a reduced-resolution page, a thumbnail,
aside), and a stack of YCbCr (other than JPEG's, which reads as RGB), CMYK or CIE Lab
colours. The numbers are read as stored: a palette stack's indices, a min-is-white stack's
values (not inverted, as :func:`glmls.imread` shows an image). The pages' orientation (TIFF
tag 274) is applied to every slice as :func:`glmls.imread` applies it to an image (the X and
Y resolutions swapped where it turns the slices a quarter); pages of different orientations
are refused. Every fault of a file is an
:class:`~glmls.errors.InputFileError` naming it.
"""

from __future__ import annotations

import dataclasses
import json
import os
import struct
import zlib
from pathlib import Path

import numpy as np
import tifffile

from ..core.config import check_flag
from ..core.handles3 import as_volume_spacing
from ..core.summary import fields_repr
from ..errors import DtypeError, InputFileError
from .atomic import atomic_write
from .nifti import NiftiHeader, one_line, read_nifti, write_nifti
from .parsing import as_path, not_a_file
from .tiff_spacing import (
    CHANNEL_KEY,
    MOST_PER_UNIT,
    SPACING_KEY,
    fits_resolutions,
    one_channel,
    stack_spacing,
)
from .tiffs import (
    TIFF_SIGNATURES,
    broken_chain,
    check_stack,
    orient,
    quiet_tifffile,
    slice_series,
    stack_orientation,
    transposes,
)

__all__ = [
    "VOLUME_SUFFIXES",
    "NiftiHeader",
    "Volume",
    "flat_npy",
    "is_volume_file",
    "read_volume",
    "volume_suffix",
    "volume_to_world",
    "world_to_volume",
    "write_volume",
]

#: The suffixes of the volume formats; a ``.tif``/``.tiff`` is a volume when it has more than
#: one page (:func:`is_volume_file`).
VOLUME_SUFFIXES = (".nii", ".nii.gz", ".tif", ".tiff", ".npy")
#: The dtypes an ImageJ TIFF holds; others are written as plain TIFF (with a JSON description).
_IMAGEJ_DTYPES = ("uint8", "uint16", "int16", "float32")
_CORRUPT = (
    OSError,
    EOFError,
    ValueError,
    KeyError,
    IndexError,
    OverflowError,
    struct.error,
    zlib.error,
)


def flat_npy(path: str | os.PathLike) -> str | None:
    """For a ``.npy`` file of a 2D array: the one line that says what to do with it (a 2D
    image belongs in an image file); None for any other file."""
    if volume_suffix(path) != ".npy":
        return None
    try:
        shape = np.load(path, mmap_mode="r", allow_pickle=False).shape
    except (*_CORRUPT, TypeError):
        return None  # read_volume says what is wrong with it
    if len(shape) != 2:
        return None
    return (
        f"{path}: a 2D array {shape}, but .npy files are volumes, (D, H, W) or (D, H, W, C): "
        "save a 2D image as an image file (e.g. with glmls.imwrite to .png or .tif)"
    )


def volume_suffix(path: str | os.PathLike) -> str:
    """The format suffix of ``path``, lower case: ``.nii.gz`` for gzipped NIfTI, else its last
    suffix (``.nii``, ``.tif``, ``.npy``, ...)."""
    name = Path(path).name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else Path(name).suffix


def is_volume_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` names a volume: a NIfTI or ``.npy`` file by its suffix, or a TIFF
    whose first series (tifffile's: pages of one shape) has more than one page, or that
    holds a stack written one slice a write (:func:`~.tiffs.slice_series`) (an existing
    file is opened to count them; a TIFF that does not exist yet is not a volume, nor a
    ``.tif`` file of another format by its first bytes, such as a PNG; an image
    with a thumbnail or a pyramid of smaller pages is an image). ``InputFileError`` for an
    existing ``.tif`` file that is empty, a TIFF file of no readable page or whose chain of
    pages breaks off (cut short: its pages before the break are not the file's), or of
    pages that are the channels or time points of one 2D image (axes ``CYX``, ``TYX``:
    neither a volume nor an image glmls reads whole)."""
    suffix = volume_suffix(path)
    if suffix in (".nii", ".nii.gz", ".npy"):
        return True
    if suffix not in (".tif", ".tiff") or not Path(path).is_file():
        return False
    try:  # by content: a PNG or JPEG named .tif is an image, as imread reads it
        with open(path, "rb") as file:
            start = file.read(4)
    except OSError:
        start = TIFF_SIGNATURES[0]  # unreadable: tifffile's error below names it
    if not start:  # neither: its handles would be refused for a volume's or an image's
        raise InputFileError(f"{path}: an empty file (0 bytes), not a TIFF file")
    if start not in TIFF_SIGNATURES:
        return False
    try:
        with quiet_tifffile(), tifffile.TiffFile(path) as tiff:
            pages = len(tiff.pages)
            broken = broken_chain(tiff)
            stacked = len(tiff.series[0].pages) if pages and tiff.series else pages
            series = tiff.series[0] if stacked > 1 else None
            axes, shape = (series.axes, series.shape) if series is not None else ("", ())
            slices = slice_series(tiff) if stacked == 1 and broken is None else None
            if slices is not None:  # a stack written one slice a write: unnamed pages
                stacked, axes, shape = len(slices), "I", (len(slices),)
    except (tifffile.TiffFileError, *_CORRUPT) as error:
        raise InputFileError(f"{path}: not a readable TIFF file: {error}") from None
    if broken is not None:
        raise InputFileError(f"{path}: not a readable TIFF file: {broken}")
    if pages == 0:
        raise InputFileError(f"{path}: not a readable TIFF file: no page")
    if stacked > 1:
        _check_axes(Path(path), axes, shape)
    return stacked > 1


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Volume:
    """A volume and the geometry its file gives.

    Parameters
    ----------
    data : numpy.ndarray
        (D, H, W) or (D, H, W, C), in the dtype of the file.
    spacing : tuple of float or None
        The voxel size (dz, dy, dx), in the order of ``data``'s axes; None where the file
        does not say it.
    affine : numpy.ndarray or None
        The NIfTI affine, (4, 4) float64: it maps the points (x, y, z, 1) of the volume to
        world coordinates; None for the other formats.
    nifti : NiftiHeader or None
        The NIfTI file's codes, units, description, time step, intent, display range,
        auxiliary file and time offset, which :func:`write_volume` writes back to a NIfTI
        file; None for the other formats (a NIfTI file written gets codes 1, scanner, no
        units and no intent).

    Raises
    ------
    ValueError
        For data that is not (D, H, W) or (D, H, W, C), an affine that is not a finite 4 x 4
        matrix, or a spacing of another length than 3 or with a value that is not finite
        and > 0.
    TypeError
        For data or an affine that is not real numbers (complex, objects, strings; a bool
        affine), a spacing that is not a sequence of real numbers (a number, a string), or
        a ``nifti`` that is not a :class:`~glmls.files.NiftiHeader`.

    See Also
    --------
    read_volume, write_volume : the files.

    Examples
    --------
    >>> volume = glmls.Volume(np.zeros((4, 5, 6), np.uint8), spacing=(2.0, 1.0, 1.0))
    >>> volume.shape, volume.spacing, volume.affine
    ((4, 5, 6), (2.0, 1.0, 1.0), None)
    """

    data: np.ndarray
    spacing: tuple[float, float, float] | None = None
    affine: np.ndarray | None = None
    nifti: NiftiHeader | None = None

    def __post_init__(self) -> None:
        data = np.asarray(self.data)
        if data.ndim not in (3, 4) or data.size == 0:
            raise ValueError(
                f"a volume is (D, H, W) or (D, H, W, C) and not empty, got shape {data.shape}"
            )
        if data.dtype.kind not in "biuf":  # no volume format holds complex numbers or objects
            raise TypeError(
                f"a volume holds real numbers (bool, integers or floats), got dtype {data.dtype}"
            )
        object.__setattr__(self, "data", data)
        if self.spacing is not None:
            object.__setattr__(self, "spacing", as_volume_spacing(self.spacing))
        if self.affine is not None:
            affine = _real(self.affine, "affine")
            if affine.shape != (4, 4) or not np.isfinite(affine).all():
                raise ValueError(f"affine must be a finite 4 x 4 matrix, got {affine.shape}")
            affine.flags.writeable = False
            object.__setattr__(self, "affine", affine)
        if self.nifti is not None and not isinstance(self.nifti, NiftiHeader):
            raise TypeError(f"nifti must be a NiftiHeader, got {type(self.nifti).__name__}")

    @property
    def shape(self) -> tuple[int, ...]:
        """The data's shape, (D, H, W) or (D, H, W, C).

        Examples
        --------
        >>> glmls.Volume(np.zeros((4, 5, 6, 3), np.uint8)).shape
        (4, 5, 6, 3)
        """
        return self.data.shape

    def __repr__(self) -> str:
        """The arrays' shapes and dtypes, not their values."""
        return fields_repr(self)


def _affine_spacing(affine: np.ndarray) -> tuple[float, float, float]:
    """(dz, dy, dx): the lengths of the affine's columns k, j, i."""
    lengths = np.linalg.norm(affine[:3, :3], axis=0)
    return (float(lengths[2]), float(lengths[1]), float(lengths[0]))


#: The least ratio of an affine's smallest singular value to its largest that world
#: coordinates are mapped by: one voxel size a millionth of another (or voxel axes as
#: nearly in one plane) makes the world a sheet, its inverse and the warp's frame noise.
_NEARLY_SINGULAR = 1e-6
#: ITK's LPS world from NIfTI's RAS+ one and back: x and y negated.
_LPS = np.array([-1.0, -1.0, 1.0])


def _real(value: object, name: str) -> np.ndarray:
    """``value`` as a float64 array if it holds real numbers (integers or floats);
    ``DtypeError`` naming ``name`` for complex numbers (whose imaginary part a cast would
    drop), bools, objects or strings."""
    array = np.asarray(value)
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    return array.astype(np.float64)


def _world_frame(points: object, affine: object, spacing: object) -> tuple:
    """(points (N, 3) float64, the affine (4, 4), its inverse, the scale (dx, dy, dz))."""
    values = _real(points, "points")
    if values.ndim != 2 or values.shape[1] != 3:
        raise ValueError(f"points must be (N, 3) coordinates (x, y, z), got shape {values.shape}")
    if not np.isfinite(values).all():
        raise ValueError("points must be finite")
    matrix = _real(affine, "affine")
    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
        raise ValueError(f"affine must be a finite 4 x 4 matrix, got shape {matrix.shape}")
    if not np.array_equal(matrix[3], [0.0, 0.0, 0.0, 1.0]):
        # the conversions read the 3 x 4 above it: such a matrix would map as if it were
        # (0, 0, 0, 1), as a NIfTI file written from it would hold it (write_volume refuses)
        raise ValueError(f"affine's last row must be (0, 0, 0, 1), got {matrix[3].tolist()}")
    # relative to its largest, so that a NIfTI of micrometre voxels in metres (1e-6 a side)
    # passes and a voxel axis of 1e-9 beside ones of 1 (a flat world) does not
    sizes = np.linalg.svd(matrix[:3, :3], compute_uv=False)
    if not sizes[2] > _NEARLY_SINGULAR * sizes[0]:
        rows = "; ".join(" ".join(f"{value:.6g}" for value in row) for row in matrix[:3])
        raise ValueError(
            f"affine is singular or nearly so: its 3 x 3 part's singular values are "
            f"{sizes[0]:.3g} to {sizes[2]:.3g}, a ratio under {_NEARLY_SINGULAR:g}, so that it "
            "maps no world point back to one voxel (a voxel size of 0 or nearly, or voxel "
            f"axes in one plane): rows [{rows}]"
        )
    steps = _affine_spacing(matrix) if spacing is None else as_volume_spacing(spacing)
    return values, matrix, np.linalg.inv(matrix), np.array(steps[::-1])


def world_to_volume(
    points: object, affine: object, *, spacing: object = None, lps: bool = False
) -> np.ndarray:
    """World coordinates of a NIfTI file's affine to the frame of glmls's 3D warps.

    The affine maps a voxel's indices (i, j, k, 1) = (x, y, z, 1), glmls's point of the
    voxel ``volume.data[k, j, i]`` (:func:`glmls.read_volume` transposes NIfTI's (i, j, k) array
    to (z, y, x)), to world (scanner) coordinates, those nibabel's ``img.affine`` gives
    (NIfTI's RAS+: x to the right, y to the front, z up). This is its inverse, times the
    spacing: the point (i dx, j dy, k dz), in the units in which :meth:`glmls.MLS.warp` with
    ``spacing`` places the voxels and takes the handles. ITK (SimpleITK, elastix's
    ``point`` files, ITK-SNAP's and 3D Slicer's exported LPS points) gives the same world
    in LPS: x and y negated (ITK's NIfTI reader negates the affine's first two rows);
    ``lps=True`` takes points so. The frame is the world turned, flipped and moved where
    the affine's columns are orthogonal; a sheared affine makes it the world sheared, whose
    distances and angles are not the world's.

    Parameters
    ----------
    points : array_like
        (N, 3) world coordinates (x, y, z).
    affine : array_like
        The 4 x 4 affine (a :class:`glmls.Volume`'s ``affine``).
    spacing : (float, float, float), optional
        (dz, dy, dx) of the warp; default the affine's (the lengths of its columns, as
        :func:`glmls.read_volume` gives a :class:`glmls.Volume`'s ``spacing``).
    lps : bool, default False
        The points are in ITK's LPS world (x to the left, y to the back), not RAS+.

    Returns
    -------
    numpy.ndarray
        (N, 3) float64 points (i dx, j dy, k dz).

    Raises
    ------
    ValueError
        For points that are not (N, 3) finite numbers, an affine that is not a finite 4 x 4
        matrix, whose last row is not (0, 0, 0, 1), or that is singular or nearly so (its
        3 x 3 part's smallest singular value under 1e-6 of its largest: a voxel size of 0,
        or a millionth of another), or a spacing of another length than 3 or with a value
        that is not a finite number > 0.
    TypeError
        For points or an affine that are not real numbers (complex, bool), a spacing that
        is not a sequence of real numbers (a number, a string), or an ``lps`` that is not
        a bool.

    See Also
    --------
    volume_to_world : The inverse.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.files import world_to_volume
    >>> affine = np.diag([0.5, 0.5, 2.0, 1.0])  # dx = dy = 0.5, dz = 2
    >>> affine[:3, 3] = [-10.0, 20.0, 5.0]  # the world point of voxel (0, 0, 0)
    >>> world_to_volume([[-9.0, 21.0, 9.0]], affine).tolist()  # voxel (2, 2, 2)
    [[1.0, 1.0, 4.0]]
    >>> world_to_volume([[9.0, -21.0, 9.0]], affine, lps=True).tolist()  # the same, LPS
    [[1.0, 1.0, 4.0]]
    """
    lps = check_flag("lps", lps)
    values, _, inverse, scale = _world_frame(points, affine, spacing)
    if lps:
        values = values * _LPS
    indices = values @ inverse[:3, :3].T + inverse[:3, 3]
    return indices * scale


def volume_to_world(
    points: object, affine: object, *, spacing: object = None, lps: bool = False
) -> np.ndarray:
    """Points of the frame of glmls's 3D warps to world coordinates of a NIfTI affine.

    The inverse of :func:`world_to_volume`: (i dx, j dy, k dz) divided by the spacing, then
    through the affine.

    Parameters
    ----------
    points : array_like
        (N, 3) points (i dx, j dy, k dz) in the units of ``spacing``.
    affine : array_like
        The 4 x 4 affine (a :class:`glmls.Volume`'s ``affine``).
    spacing : (float, float, float), optional
        (dz, dy, dx); default the affine's.
    lps : bool, default False
        Give the world points in ITK's LPS convention (x and y negated), not RAS+.

    Returns
    -------
    numpy.ndarray
        (N, 3) float64 world coordinates (x, y, z).

    Raises
    ------
    ValueError, TypeError
        As :func:`world_to_volume`.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.files import volume_to_world
    >>> affine = np.diag([0.5, 0.5, 2.0, 1.0])
    >>> affine[:3, 3] = [-10.0, 20.0, 5.0]
    >>> volume_to_world([[1.0, 1.0, 4.0]], affine).tolist()
    [[-9.0, 21.0, 9.0]]
    """
    lps = check_flag("lps", lps)
    values, matrix, _, scale = _world_frame(points, affine, spacing)
    world = (values / scale) @ matrix[:3, :3].T + matrix[:3, 3]
    return world * _LPS if lps else world


def read_volume(path: str | os.PathLike) -> Volume:
    """Read a volume: NIfTI (``.nii``, ``.nii.gz``), a TIFF stack or a ``.npy`` array.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix chooses the format.

    Returns
    -------
    Volume
        ``data`` (D, H, W) or (D, H, W, C) in the file's dtype (a NIfTI with a scale factor
        gives floats), with the spacing and affine the file gives (:class:`Volume`; what each format
        gives: :doc:`/cli`). A ``.npy`` array in C order is a copy-on-write map of the file
        (``numpy.memmap``, ``mode="c"``): it is read as it is used (a warp reads it slab by
        slab), and it can be changed as an array read whole can, in memory only (the file
        keeps its values). :func:`write_volume` (and ``glmls warp``) may write over the file,
        as they replace it whole; a tool that rewrites the file in place while the map is in
        use (``np.save`` to its path) cuts the data from under it.

    Raises
    ------
    InputFileError
        Naming the file: missing, unreadable, corrupt, an unknown suffix, or not a volume
        (a 2D array, a TIFF of one page).
    TypeError
        For a ``path`` that is no path (None, a number).

    See Also
    --------
    write_volume : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ramp.nii.gz"
    >>> data = np.arange(24, dtype=np.uint16).reshape(2, 3, 4)  # (z, y, x)
    >>> glmls.write_volume(path, data, spacing=(3.0, 1.0, 0.5))
    >>> volume = glmls.read_volume(path)
    >>> volume.shape, volume.data.dtype.name, volume.spacing
    ((2, 3, 4), 'uint16', (3.0, 1.0, 0.5))
    >>> volume.affine.diagonal().tolist()  # (dx, dy, dz, 1): x first, as NIfTI has it
    [0.5, 1.0, 3.0, 1.0]
    """
    path = as_path(path)
    suffix = volume_suffix(path)
    if suffix not in VOLUME_SUFFIXES:
        raise InputFileError(
            f"{path}: unknown volume format {suffix or '(no suffix)'}; use "
            f"{', '.join(VOLUME_SUFFIXES)}"
        )
    if not path.is_file():
        raise InputFileError(f"{path}: {not_a_file(path)}")
    try:
        if suffix == ".npy":
            with path.open("rb") as file:  # else numpy speaks of pickles for any bad header
                if file.read(6) != b"\x93NUMPY":
                    raise InputFileError(f"{path}: not a .npy file (no NumPy header)")
            flat = flat_npy(path)
            if flat is not None:
                raise InputFileError(flat)
            volume = Volume(_load_npy(path))
        elif suffix in (".tif", ".tiff"):
            with quiet_tifffile():
                volume = _read_tiff(path)
        else:
            data, affine, fields = read_nifti(path)
            volume = Volume(data, spacing=_affine_spacing(affine), affine=affine, nifti=fields)
    except InputFileError:
        raise
    except (tifffile.TiffFileError, ImportError, TypeError, *_CORRUPT) as error:
        if isinstance(error, (TypeError, ValueError)) and str(error).startswith("a volume "):
            raise InputFileError(f"{path}: {error}") from None
        raise InputFileError(f"{path}: not a readable {suffix} volume: {one_line(error)}") from None
    return volume


def _load_npy(path: Path) -> np.ndarray:
    """The array of a ``.npy`` file, mapped where it is in C order: a warp uploads it slab by
    slab, and a volume of gigabytes is not read whole before. Copy-on-write, so that the array
    can be changed as one read whole (a page changed becomes the process's own; the file
    never changes). A Fortran-order
    array is read whole (the warp makes a C-order copy of it anyway, which would read a map
    out of order)."""
    try:
        mapped = np.load(path, mmap_mode="c", allow_pickle=False)
    except ValueError:  # an object array, a file shorter than its header says: named below
        mapped = None
    if mapped is None or not mapped.flags.c_contiguous:
        return np.load(path, allow_pickle=False)
    return mapped


def _read_tiff(path: Path) -> Volume:
    with tifffile.TiffFile(path) as tiff:
        if len(tiff.pages) == 0:
            raise InputFileError(f"{path}: not a readable {path.suffix.lower()} volume: no pages")
        broken = broken_chain(tiff)
        if broken is not None:
            raise InputFileError(f"{path}: not a readable {path.suffix.lower()} volume: {broken}")
        if len(tiff.pages) == 1:
            raise InputFileError(
                f"{path}: a TIFF of one page is an image (glmls.imread), not a volume"
            )
        series = tiff.series[0]
        slices = slice_series(tiff)  # written one slice a write: a series each
        pages = series.pages if slices is None else [one.pages[0] for one in slices]
        try:
            check_stack(path, tiff, series, slices=slices is not None)
            orientation = stack_orientation(path, tiff, pages)
        except tifffile.TiffFileError as error:  # a page's tags (a ValueError too)
            raise InputFileError(
                f"{path}: not a readable {path.suffix.lower()} volume: {error}"
            ) from None
        except ValueError as error:
            raise InputFileError(str(error)) from None
        if slices is None:
            data, axes = series.asarray(), series.axes
        else:  # unnamed pages (I), each slice as its series holds it (YX, YXS)
            data, axes = np.stack([one.asarray() for one in slices]), "I" + series.axes
        spacing = stack_spacing(tiff)
        channel = data.ndim == 3 and one_channel(tiff)
    _check_axes(path, axes, data.shape)
    if "T" in axes:  # a time series of volumes: its time points are no slices nor channels
        raise InputFileError(
            f"{path}: a TIFF of axes {axes} {data.shape}, {data.shape[axes.index('T')]} time "
            "points of a volume; glmls reads one volume (axes ZYX, with C or S for channels): "
            "save each time point as a stack of its own"
        )
    if data.ndim == 4 and axes[1] in "CS":  # an ImageJ hyperstack (Z, C, Y, X), or planes
        data = np.moveaxis(data, 1, -1)
    elif data.ndim == 4 and axes[0] in "CS" and axes[1] == "Z":  # OME's XYZCT order: (C, Z, Y, X)
        data = np.moveaxis(data, 0, -1)
    elif data.ndim == 4 and axes == "QYXQ" and data.shape[3] == 1:
        pass  # tifffile's shaped description of a (D, H, W, 1) array, as imwrite writes it
    elif data.ndim == 4 and axes[-1] not in "SC":
        raise InputFileError(f"{path}: a TIFF of axes {axes} {data.shape}: expected a stack")
    if data.ndim not in (3, 4):
        raise InputFileError(
            f"{path}: a TIFF of axes {axes} {data.shape}: expected a stack of pages of one size"
        )
    if channel:  # written from (D, H, W, 1): the pages hold one sample, not the axis
        data = data[..., np.newaxis]
    if transposes(orientation) and spacing is not None:  # the resolutions are the stored axes'
        spacing = (spacing[0], spacing[2], spacing[1])
    return Volume(np.ascontiguousarray(orient(data, orientation, axes=(1, 2))), spacing=spacing)


#: What the first axis of a TIFF's series without a Z axis holds (tifffile's axis letters).
_AXIS_NAMES = {"C": "channels", "T": "time points", "S": "samples"}


def _check_axes(path: Path, axes: str, shape: tuple[int, ...]) -> None:
    """``InputFileError`` for a TIFF series of neither a Z axis nor unnamed pages first (I, Q):
    the channels or time points of one 2D image, whose pages are no slices."""
    if "Z" in axes or axes[0] in "IQ":
        return
    what = f"{shape[0]} {_AXIS_NAMES.get(axes[0], f'steps along {axes[0]}')} of a 2D image"
    what = "one 2D image" if axes[0] == "Y" else what
    raise InputFileError(
        f"{path}: a TIFF of axes {axes} {tuple(shape)}, {what}, not a volume (a stack of "
        "slices: axis Z, or pages without axes)"
    )


def write_volume(
    path: str | os.PathLike,
    volume: object,
    *,
    affine: object = None,
    spacing: object = None,
) -> None:
    """Write a volume to a file whose suffix names its format, whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        ``.nii``, ``.nii.gz``, ``.tif``/``.tiff`` (a stack of D pages; a volume of one
        channel, (D, H, W, 1), is written as the stack (D, H, W) with ``channel_axis=true``
        in its description, and reads back (D, H, W, 1), as from ``.npy`` and NIfTI) or
        ``.npy``.
    volume : Volume or array_like
        (D, H, W) or (D, H, W, C); a :class:`Volume` brings its spacing and affine.
    affine : array_like, optional
        NIfTI: the 4 x 4 affine of the points (x, y, z, 1); default the volume's, else a
        diagonal one of the spacing, else the identity. Written as the sform, and as the
        qform where a qform holds it (a sheared affine's qform is left unset, code 0, so
        that no tool reads another geometry from it), with the codes of the volume's
        :class:`~glmls.files.NiftiHeader` (1, scanner, where it has none or ``affine`` is
        given). The header's units, description, intent, display range, auxiliary file and
        time offset are written too, and a time series (its ``time_step`` not None) is written 4D
        (i, j, k, T) with that step, as it was read; other channels are the vector
        dimension (i, j, k, 1, C), intent ``vector`` where the header gives none. Given
        with another format: refused (a :class:`Volume`'s own affine and header are left
        out of other formats).
    spacing : sequence of float, optional
        The voxel size (dz, dy, dx); default the volume's. NIfTI: used where no affine is
        given; TIFF: written as an ImageJ stack's spacing and X/Y resolutions (uint8,
        uint16, int16 and float32 data: a stack, an RGB stack for 3 channels of uint8, a
        hyperstack (Z, C, Y, X) for other channels, as Fiji opens them), or for other dtypes
        (a plain TIFF) as X/Y resolutions (where 32-bit fractions hold them) and
        ``{"spacing": [dz, dy, dx]}`` in the JSON description of the first page; every dtype
        reads back with it. NIfTI lacks bool and
        float16: they are written as uint8 and float32. ``.npy`` holds none.

    Raises
    ------
    ValueError
        Before writing anything: an unknown suffix, a wrong shape, an affine with another
        format than NIfTI, a bad affine (singular, a last row other than (0, 0, 0, 1), or,
        from it or the spacing, values beyond float32's range, in which NIfTI holds them, or
        voxel sizes float32 makes 0), a volume of one slice as TIFF (a TIFF of one page
        is an image), a spacing of another length than 3 or with a value that is not a
        finite number > 0, or, for an ImageJ TIFF stack, a pixel width or height whose X/Y
        resolution is no 32-bit fraction (under about 2.3e-10 or over 4.3e9).
    TypeError
        Before writing anything: data that is not real numbers (complex, objects), numbers
        of more than 64 bits (``numpy.longdouble``) as TIFF (a :class:`~glmls.DtypeError`,
        a ``ValueError`` too), a spacing that is not a sequence of real numbers, or a
        ``path`` that is no path (the volume given in its place).
    OSError
        Naming ``path``, for a file that cannot be written.

    See Also
    --------
    read_volume : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "stack.tif"
    >>> glmls.write_volume(path, np.ones((3, 4, 5), np.float32), spacing=(2.0, 0.5, 0.5))
    >>> volume = glmls.read_volume(path)
    >>> volume.shape, volume.data.dtype.name, volume.spacing
    ((3, 4, 5), 'float32', (2.0, 0.5, 0.5))
    >>> glmls.write_volume(path, glmls.Volume(np.ones((3, 4, 5)), spacing=(2.0, 1.0, 0.5)))
    >>> volume = glmls.read_volume(path)
    >>> volume.data.dtype.name, volume.spacing
    ('float64', (2.0, 1.0, 0.5))
    """
    path = as_path(path)
    suffix = volume_suffix(path)
    if suffix not in VOLUME_SUFFIXES:
        raise ValueError(
            f"{path}: unknown volume format {suffix or '(no suffix)'}; use "
            f"{', '.join(VOLUME_SUFFIXES)}"
        )
    nifti = suffix in (".nii", ".nii.gz")
    if affine is not None and not nifti:
        raise ValueError(f"{path}: only NIfTI files hold an affine; {suffix} does not")
    header = None
    if isinstance(volume, Volume):
        spacing = volume.spacing if spacing is None else spacing
        if nifti and volume.nifti is not None:
            # another affine is another world: only the codes go with the volume's own
            header = volume.nifti
            if affine is not None:
                header = dataclasses.replace(header, sform_code=1, qform_code=1, qform=None)
        affine = (volume.affine if nifti else None) if affine is None else affine
        volume = volume.data
    checked = Volume(np.asarray(volume), spacing=spacing, affine=affine, nifti=header)
    if checked.affine is not None and not abs(np.linalg.det(checked.affine[:3, :3])) > 0:
        # nibabel's decomposition of it would warn, then fail with the matrix in its message
        raise ValueError(f"{path}: the affine is singular (its 3 x 3 part has no inverse)")
    if suffix in (".tif", ".tiff") and checked.shape[0] == 1:
        raise ValueError(
            f"{path}: a volume of one slice would be a TIFF of one page, which reads back as "
            "an image; write it as .nii, .nii.gz or .npy"
        )
    if suffix in (".tif", ".tiff") and checked.data.dtype.itemsize > 8:  # tifffile asserts
        raise DtypeError(
            f"{path}: TIFF holds numbers of up to 64 bits, got dtype {checked.data.dtype}: "
            "convert it (to float64) or write it as .npy"
        )
    if suffix == ".npy":
        with atomic_write(path) as tmp, open(tmp, "wb") as file:
            np.save(file, np.ascontiguousarray(checked.data), allow_pickle=False)
    elif suffix in (".tif", ".tiff"):
        _write_tiff(path, checked)
    else:
        affine = checked.affine
        if affine is None:
            dz, dy, dx = checked.spacing or (1.0, 1.0, 1.0)
            affine = np.diag([dx, dy, dz, 1.0])
        write_nifti(path, checked.data, affine, checked.nifti, compress=suffix == ".nii.gz")


def _write_tiff(path: Path, volume: Volume) -> None:
    """An ImageJ stack for ImageJ's dtypes (Fiji opens it with its calibration): one channel
    (Z, Y, X), 3 channels of uint8 an RGB stack, other channels a hyperstack (Z, C, Y, X);
    other dtypes a plain TIFF of D pages, channels as samples (bool's as planes: tifffile
    reads 1-bit samples side by side wrongly); one channel (D, H, W, 1) a stack (D, H, W),
    which other programs open as one, marked ``channel_axis=true`` (ImageJ's description, or
    the JSON description of the first page) for :func:`glmls.read_volume` to give it back 4D.
    The data goes to tifffile with its samples axis S, 1 where there is none (ImageJ's), or
    a page at a time (plain stacks): else tifffile takes a width of 1 for that axis and
    writes one page, or a hyperstack's pages of another shape. The spacing is the X/Y
    resolutions of every page, and the voxel depth ImageJ's ``spacing``, or for other dtypes
    (which ImageJ's metadata does not hold) the whole spacing in the JSON description of the
    first page (:func:`~glmls.files.tiff_spacing.stack_spacing`)."""
    data = np.ascontiguousarray(volume.data)
    channel = data.ndim == 4 and data.shape[3] == 1
    if channel:  # as a stack, marked (the hyperstack needs C > 1; a page has no such axis)
        data = data[..., 0]
    channels = 1 if data.ndim == 3 else data.shape[3]
    options: dict = {}
    if volume.spacing is not None and fits_resolutions(volume.spacing):
        _, dy, dx = volume.spacing
        options["resolution"] = (1 / dx, 1 / dy)
    if data.dtype.name in _IMAGEJ_DTYPES:
        if volume.spacing is not None and "resolution" not in options:
            raise ValueError(
                f"{path}: spacing {volume.spacing}: an ImageJ TIFF stack holds a pixel width and "
                f"height of {1 / MOST_PER_UNIT:.3g} to {MOST_PER_UNIT:.3g} (X/Y resolutions, "
                "32-bit fractions); write it as .nii, .nii.gz, or with other units"
            )
        metadata: dict = {"axes": "ZYXS"}
        if channels == 3 and data.dtype == np.uint8:
            options["photometric"] = "rgb"
        elif channels > 1:
            data = np.ascontiguousarray(np.moveaxis(data, 3, 1))[..., np.newaxis]
            metadata["axes"] = "ZCYXS"
        else:
            data = data[..., np.newaxis]
        if volume.spacing is not None:
            metadata["spacing"] = volume.spacing[0]
        if channel:
            metadata[CHANNEL_KEY] = True  # the description's line channel_axis=true
        options.update(imagej=True, metadata=metadata)
    else:
        described: dict = {} if volume.spacing is None else {SPACING_KEY: list(volume.spacing)}
        if channels == 1:
            described.update({CHANNEL_KEY: True} if channel else {})
            _write_pages(path, data, described, options.get("resolution"))
            return
        options["metadata"] = described  # beside the shape in tifffile's JSON description
        if data.dtype == np.bool_:
            data = np.ascontiguousarray(np.moveaxis(data, 3, 1))  # (Z, S, Y, X): planes
            options.update(photometric="minisblack", planarconfig="separate")
        else:
            options["photometric"] = "rgb" if channels in (3, 4) else "minisblack"
            options["planarconfig"] = "contig"
            if channels in (2, 4):
                options["extrasamples"] = ["unassalpha"]
    with atomic_write(path) as tmp:
        tifffile.imwrite(tmp, data, **options)


def _write_pages(path: Path, data: np.ndarray, described: dict, resolution: tuple | None) -> None:
    """A plain stack (D, H, W), a page at a time; the spacing and the channel mark a JSON
    description of the first page without tifffile's ``shape``: tifffile reads a shaped
    series of pages written one by one as if its data were contiguous, which it is not."""
    description = json.dumps(described) if described else None
    with atomic_write(path) as tmp, tifffile.TiffWriter(tmp, bigtiff=_big(data)) as tiff:
        for index, page in enumerate(data):
            tiff.write(
                page,
                photometric="minisblack",
                metadata=None,
                description=description if index == 0 else None,
                resolution=resolution,
            )


def _big(data: np.ndarray) -> bool:
    """Whether a TIFF of ``data`` needs BigTIFF's 64-bit offsets (as tifffile.imwrite says)."""
    return data.nbytes > 2**32 - 2**25
