"""NIfTI files through nibabel: the header fields a volume carries (:class:`NiftiHeader`),
and the reading and writing that :func:`glmls.files.volumes.read_volume` and
:func:`~glmls.files.volumes.write_volume` do for ``.nii`` and ``.nii.gz``; the conventions
are described in :mod:`glmls.files.volumes`."""

from __future__ import annotations

import contextlib
import dataclasses
import gzip
import logging
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..core.config import check_real
from ..errors import InputFileError
from .atomic import atomic_write

__all__ = ["NiftiHeader", "one_line", "read_nifti", "write_nifti"]

#: dtypes NIfTI lacks, written as the nearest it has: masks as uint8, half floats as float32.
_NIFTI_AS = {"bool": np.uint8, "float16": np.float32}
#: The largest float32, the type of the NIfTI header's affine.
_FLOAT32_MAX = float(np.finfo(np.float32).max)


#: Intents whose values are components in the space's frame (vectors, displacements,
#: matrices, quaternions, points, FSL's warp fields and their spline or DCT coefficients): a
#: warp moves the voxels but neither turns nor recomputes those components, so the intent
#: would no longer describe the warped values; read as no intent.
_SPATIAL_INTENTS = frozenset(
    (1004, 1005, 1006, 1007, 1008, 1009, 1010, 2006, 2007, 2008, 2009, 2016, 2017)
)


@dataclasses.dataclass(frozen=True)
class NiftiHeader:
    """The fields of a NIfTI header that a volume read from it carries, to be written back.

    They are those that stay true of the volume warped in space; ``dim_info`` and the slice
    timing, which the warp's moved slices no longer follow, are not among them.

    Parameters
    ----------
    sform_code, qform_code : int, default 1
        What world the affine maps to (NIfTI's ``NIFTI_XFORM_*`` codes: 0 unknown, 1 scanner,
        2 aligned to another volume, 3 Talairach, 4 MNI 152, 5 a template), for the sform and
        the qform; 0 for no sform or qform.
    xyzt_units : int, default 0
        NIfTI's units byte: the space unit (1 m, 2 mm, 3 um) plus the time unit (8 s, 16 ms,
        24 us); 0 where the file says none.
    descrip : str, default ""
        The file's description, at most 80 characters (of Latin-1).
    time_step : float or None, default None
        Not None where the volume's channels are the file's time points (its 4th dimension,
        (i, j, k, T)): the time between two of them (``pixdim[4]``, in the time unit); the
        volume is written back so. None where the channels are a vector (5th) dimension or
        RGB, or there are none.
    qform : tuple or None, default None
        The file's qform, a 4 x 4 matrix as a tuple of 4 rows, where the file has both a
        qform and an sform (codes > 0) and they differ (the sform, the volume's affine, maps
        to another world, an atlas's, than the qform's scanner): written back as the
        qform, beside the affine as the sform. None where the affine is both.
    intent_code : int, default 0
        What the values are (NIfTI's ``NIFTI_INTENT_*`` codes: 3 a t statistic, 5 a z
        score, 22 a p value, 1002 labels, ...); 0 for none. A volume of channels with no
        intent is written with intent 1007, ``vector``. Reading leaves out the intents of
        components in the space's frame, which a warp moves without turning them (1004 to
        1010: matrices, displacements, vectors, points, quaternions; FSL's warp fields and
        their coefficients, 2006 to 2009, 2016, 2017): such a volume is read with none.
    intent_params : tuple of 3 float, default (0.0, 0.0, 0.0)
        The intent's parameters ``intent_p1`` to ``intent_p3`` (a t statistic's degrees of
        freedom, an F statistic's two).
    intent_name : str, default ""
        The intent's name (``intent_name``), at most 16 characters (of Latin-1).
    cal_min, cal_max : float, default 0.0
        The display range of the values (both 0 where the file gives none). Nearest and
        trilinear sampling give values within the input's range, so the range stays true
        of a warped volume (but for the background where it lies outside).
    aux_file : str, default ""
        The name of an auxiliary file (a colour table), at most 24 characters (of Latin-1).
    toffset : float, default 0.0
        The time of the first time point (``toffset``, in the time unit).

    Raises
    ------
    ValueError
        For a code or intent code outside 0..32767, a units byte outside 0..255, a
        description, intent name or auxiliary file name longer than its field or not
        Latin-1, a time step, intent parameter, display bound or time offset that is not
        finite, a ``cal_min`` above ``cal_max``, intent parameters that are not 3, or a
        qform that is not a finite 4 x 4 matrix.
    TypeError
        For a code or units value that is not an integer, a text that is not a ``str``, or a
        number that is not a real one.

    See Also
    --------
    glmls.Volume : what carries it.

    Examples
    --------
    >>> from glmls.files import NiftiHeader
    >>> header = NiftiHeader(sform_code=4, qform_code=4, xyzt_units=2 + 8)  # MNI; mm and s
    >>> volume = glmls.Volume(np.zeros((4, 5, 6), np.int16), affine=np.eye(4), nifti=header)
    >>> volume.nifti.sform_code
    4

    A t statistic of 12 degrees of freedom, shown from -5 to 5:

    >>> tmap = NiftiHeader(intent_code=3, intent_params=(12, 0, 0), cal_min=-5, cal_max=5)
    >>> tmap.intent_params, tmap.cal_max
    ((12.0, 0.0, 0.0), 5.0)
    """

    sform_code: int = 1
    qform_code: int = 1
    xyzt_units: int = 0
    descrip: str = ""
    time_step: float | None = None
    qform: tuple | None = None
    intent_code: int = 0
    intent_params: tuple = (0.0, 0.0, 0.0)
    intent_name: str = ""
    cal_min: float = 0.0
    cal_max: float = 0.0
    aux_file: str = ""
    toffset: float = 0.0

    def __post_init__(self) -> None:
        integers = (
            ("sform_code", 32767),
            ("qform_code", 32767),
            ("xyzt_units", 255),
            ("intent_code", 32767),
        )
        for name, top in integers:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise TypeError(f"{name} must be an integer, got {value!r}")
            if not 0 <= value <= top:
                raise ValueError(f"{name} must be in 0..{top}, got {value}")
            object.__setattr__(self, name, int(value))
        for name, size in (("descrip", 80), ("intent_name", 16), ("aux_file", 24)):
            _check_text(name, getattr(self, name), size)
        for name in ("cal_min", "cal_max", "toffset"):
            object.__setattr__(self, name, check_real(name, getattr(self, name)))
        if self.cal_min > self.cal_max:
            raise ValueError(f"cal_min {self.cal_min} is above cal_max {self.cal_max}")
        params = self.intent_params
        if isinstance(params, str) or not isinstance(params, tuple | list | np.ndarray):
            raise TypeError(f"intent_params must be 3 real numbers, got {params!r}")
        if len(params) != 3:
            raise ValueError(f"intent_params must be 3 real numbers, got {len(params)}")
        params = tuple(check_real(f"intent_p{i + 1}", p) for i, p in enumerate(params))
        object.__setattr__(self, "intent_params", params)
        if self.time_step is not None:
            object.__setattr__(self, "time_step", check_real("time_step", self.time_step))
        if self.qform is not None:
            matrix = np.asarray(self.qform, dtype=np.float64)
            if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
                raise ValueError(f"qform must be a finite 4 x 4 matrix, got {matrix.shape}")
            object.__setattr__(self, "qform", tuple(tuple(row) for row in matrix.tolist()))


def _check_text(name: str, value: object, size: int) -> None:
    """``TypeError`` for a text field that is not a ``str``, ``ValueError`` for one that is
    not Latin-1 or longer than the header's ``size`` bytes."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, got {type(value).__name__}")
    try:
        length = len(value.encode("latin-1"))
    except UnicodeEncodeError:
        raise ValueError(f"{name} must be Latin-1 text, got {value!r}") from None
    if length > size:
        raise ValueError(f"{name} holds at most {size} characters, got {length}")


def _nibabel():
    import nibabel  # a dependency; imported where used: it is slow to import

    return nibabel


_quiet_lock = threading.Lock()
_quiet_depth = 0


@contextlib.contextmanager
def _quiet_nibabel(nib: object) -> Iterator[None]:
    """Within the block, nibabel's header repairs (``pixdim[1,2,3] should be non-zero;
    setting 0 dims to 1``), which it logs to stderr, are dropped; its logger is as it was
    after the last of nested or concurrent blocks. Not nibabel's own
    ``LoggingOutputSuppressor``: it loses the logger's handlers, after which Python's
    last-resort handler prints the repairs all the same."""
    global _quiet_depth
    logger: logging.Logger = nib.imageglobals.logger
    with _quiet_lock:
        if _quiet_depth == 0:
            logger.disabled = True
        _quiet_depth += 1
    try:
        yield
    finally:
        with _quiet_lock:
            _quiet_depth -= 1
            if _quiet_depth == 0:
                logger.disabled = False


#: The first bytes of a gzip stream.
_GZIP_MAGIC = b"\x1f\x8b"
#: The first 4 bytes of a NIfTI-1 or NIfTI-2 file (its header's size, 348 or 540), in
#: either byte order.
_NIFTI_STARTS = tuple(size.to_bytes(4, order) for size in (348, 540) for order in ("little", "big"))


def _check_compression(path: Path) -> None:
    """``InputFileError`` for a file whose name says the other of gzipped and plain NIfTI
    (nibabel goes by the name, and its message for a gzip stream named ``.nii`` does not say
    why)."""
    try:
        with path.open("rb") as file:
            start = file.read(4)
    except OSError:
        return  # nibabel's own error names it
    named = path.name.lower().endswith(".gz")
    if start[:2] == _GZIP_MAGIC and not named:
        raise InputFileError(
            f"{path}: a gzip-compressed file named {path.suffix}: name it .nii.gz, or "
            "decompress it (gunzip)"
        )
    if named and start in _NIFTI_STARTS:
        raise InputFileError(
            f"{path}: not gzip-compressed, though named .gz: name it .nii (a NIfTI file), or "
            "compress it (gzip)"
        )


def read_nifti(path: Path) -> tuple[np.ndarray, np.ndarray, NiftiHeader]:
    """(data (z, y, x[, C]), the affine (4, 4) float64, the header's fields) of a NIfTI
    file; ``InputFileError`` naming it where it is not one glmls reads."""
    nib = _nibabel()
    refused = (
        nib.filebasedimages.ImageFileError,
        nib.spatialimages.HeaderDataError,
        nib.spatialimages.HeaderTypeError,
    )
    _check_compression(path)
    try:
        with _quiet_nibabel(nib):  # its repairs, logged to stderr
            image = nib.load(path)
    except refused as error:  # no NIfTI, or a header of a dimension or dtype NIfTI has not
        raise InputFileError(f"{path}: not a NIfTI file: {one_line(error)}") from None
    if not isinstance(image, nib.Nifti1Image | nib.Nifti2Image):
        raise InputFileError(f"{path}: not a NIfTI image ({type(image).__name__})")
    _check_nifti_size(path, image.dataobj)
    try:
        data = np.asanyarray(image.dataobj)
    except MemoryError:
        raise InputFileError(f"{path}: too large to read into memory") from None
    header = image.header
    time = data.ndim == 4 and not data.dtype.names  # (x, y, z, T): NIfTI's 4th is time
    if data.dtype.names:  # RGB24/RGBA32: a record per voxel
        data = np.stack([data[name] for name in data.dtype.names], axis=-1)
        data = data.reshape(*data.shape[:3], -1)
    elif data.ndim == 5 and data.shape[3] == 1:  # (x, y, z, 1, C): the vector convention
        data = data[:, :, :, 0]
    if data.ndim not in (3, 4):
        raise InputFileError(
            f"{path}: a {data.ndim}D NIfTI image {data.shape}; a volume is (x, y, z) or "
            "(x, y, z, C)"
        )
    volume = np.ascontiguousarray(np.swapaxes(data, 0, 2))  # (x, y, z[, C]) -> (z, y, x[, C])
    affine = np.asarray(image.affine, dtype=np.float64)
    _check_affine(path, header, affine)
    step = float(header["pixdim"][4])
    fields = NiftiHeader(
        sform_code=int(header["sform_code"]),
        qform_code=int(header["qform_code"]),
        xyzt_units=int(header["xyzt_units"]),
        descrip=_text(header["descrip"]),
        time_step=(step if np.isfinite(step) else 0.0) if time else None,
        qform=_own_qform(header, affine),
        **_kept_fields(header),
    )
    return volume, affine, fields


def _text(field: object) -> str:
    """A header's text field: its bytes up to the first NUL, as Latin-1."""
    return bytes(field).split(b"\0", 1)[0].decode("latin-1")


def _finite(value: object) -> float:
    """A header's float field, 0 where it is not finite (no number to keep)."""
    number = float(value)
    return number if np.isfinite(number) else 0.0


def _kept_fields(header: object) -> dict:
    """The intent, display range, auxiliary file and time offset of ``header``, as
    :class:`NiftiHeader` takes them; an intent of components in the space's frame, a
    negative code or parameters that are not finite read as no intent, a display range
    that is not finite or reversed as none. ``dim_info`` and the slice timing are left
    out: a warp moves the slices, so the acquisition's slice axis and order no longer
    describe the output's."""
    fields: dict = {"aux_file": _text(header["aux_file"]), "toffset": _finite(header["toffset"])}
    code = int(header["intent_code"])
    params = [float(header[f"intent_p{i}"]) for i in (1, 2, 3)]
    if 0 < code and code not in _SPATIAL_INTENTS and np.isfinite(params).all():
        fields.update(
            intent_code=code,
            intent_params=tuple(params),
            intent_name=_text(header["intent_name"]),
        )
    low, high = float(header["cal_min"]), float(header["cal_max"])
    if np.isfinite([low, high]).all() and low <= high:
        fields.update(cal_min=low, cal_max=high)
    return fields


#: The most bytes a gzip file's one byte of deflate data expands to (deflate's limit, 1032:1).
_DEFLATE_RATIO = 1032


def one_line(error: BaseException) -> str:
    """An error's message on one line (nibabel's may hold line breaks)."""
    return " ".join(str(error).split())


def _check_nifti_size(path: Path, proxy: object) -> None:
    """``InputFileError`` where the header's data (its shape, dtype and offset) cannot be in
    the file: a negative size, more bytes than a ``.nii`` holds after the offset, or than a
    ``.nii.gz`` of its size could expand to; before any of it is read or allocated."""
    shape = tuple(int(n) for n in proxy.shape)
    if any(n < 0 for n in shape):
        raise InputFileError(f"{path}: not a readable NIfTI file: its header's shape {shape}")
    needed = int(np.prod(shape, dtype=object)) * proxy.dtype.itemsize + int(proxy.offset)
    size = path.stat().st_size
    compressed = path.name.lower().endswith(".gz")
    if needed > (size * _DEFLATE_RATIO if compressed else size):
        holds = (
            f"a gzip file of {size} bytes holds at most {size * _DEFLATE_RATIO}"
            if (compressed)
            else f"the file has {size}"
        )
        raise InputFileError(
            f"{path}: not a readable NIfTI file: its header's {shape} voxels of "
            f"{proxy.dtype} need {needed} bytes, {holds} (truncated, or a damaged header)"
        )


def _check_affine(path: Path, header: object, affine: np.ndarray) -> None:
    """``InputFileError`` naming the header's field for an affine that is not finite, has a
    voxel axis of length 0 (no voxel size) or is singular (no world place of the voxels,
    and no affine :func:`write_nifti` writes back)."""
    if int(header["sform_code"]) > 0:
        field = "sform (srow_x, srow_y, srow_z)"
    else:
        field = (
            "qform (quatern_*, qoffset_*, pixdim)" if int(header["qform_code"]) > 0 else "pixdim"
        )
    if not np.isfinite(affine).all():
        fault = "holds a value that is not finite"
    elif not (np.linalg.norm(affine[:3, :3], axis=0) > 0).all():
        fault = "gives a voxel axis of length 0"
    elif not abs(np.linalg.det(affine[:3, :3])) > 0:  # as write_nifti's check
        fault = "is singular (its voxel axes lie in one plane)"
    else:
        return
    raise InputFileError(f"{path}: not a readable NIfTI file: the affine of its {field} {fault}")


def _own_qform(header: object, affine: np.ndarray) -> tuple | None:
    """The header's qform where it has both a qform and an sform and they differ (a tool's
    write of the qform beside the sform would otherwise lose it), else None."""
    if int(header["qform_code"]) == 0 or int(header["sform_code"]) == 0:
        return None
    qform = np.asarray(header.get_qform(), dtype=np.float64)
    tolerance = 1e-6 * max(1.0, float(np.abs(affine).max()))
    if np.allclose(qform, affine, rtol=0, atol=tolerance):
        return None
    return tuple(tuple(row) for row in qform.tolist())


def _check_written_affine(path: Path, affine: np.ndarray) -> None:
    """``ValueError`` naming ``path`` for an affine NIfTI cannot hold: a last row other than
    (0, 0, 0, 1) (the header holds the 3 x 4 rows above it), values beyond float32's range, or
    voxel axes that float32, the header's numbers, makes of length 0 or in one plane: such a
    file would hold another affine than the one given, or one :func:`read_nifti` refuses."""
    affine = np.asarray(affine, dtype=np.float64)
    if not np.array_equal(affine[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(
            f"{path}: an affine's last row must be (0, 0, 0, 1), as NIfTI holds it; got "
            f"{affine[3].tolist()}"
        )
    if (np.abs(affine) > _FLOAT32_MAX).any():
        raise ValueError(
            f"{path}: the affine holds values beyond float32's range (±3.4e38), in which "
            f"NIfTI holds it; its largest is {float(np.abs(affine).max()):g}"
        )
    held = affine[:3, :3].astype(np.float32).astype(np.float64)
    if not (np.linalg.norm(held, axis=0) > 0).all() or not abs(np.linalg.det(held)) > 0:
        sizes = [float(size) for size in np.linalg.norm(affine[:3, :3], axis=0)]
        raise ValueError(
            f"{path}: NIfTI holds the affine in float32, in which its voxel axes (voxel sizes "
            f"(dx, dy, dz) = {sizes}) have length 0 or lie in one plane"
        )


def write_nifti(
    path: Path,
    volume: np.ndarray,
    affine: np.ndarray,
    fields: NiftiHeader | None,
    *,
    compress: bool,
) -> None:
    """Write the checked ``volume`` (z, y, x[, C]) with its affine and header fields (codes 1
    and no units where None), whole or not at all; ``ValueError`` naming ``path`` for a
    volume NIfTI cannot hold."""
    _check_written_affine(path, affine)
    nib = _nibabel()
    data = np.ascontiguousarray(np.swapaxes(volume, 0, 2))  # (z, y, x) -> (x, y, z)
    data = data.astype(_NIFTI_AS.get(data.dtype.name, data.dtype), copy=False)
    fields = fields or NiftiHeader()
    time = data.ndim == 4 and fields.time_step is not None
    if data.ndim == 4 and not time:  # channels: NIfTI's vector dimension, the 5th
        data = data[:, :, :, np.newaxis, :]
    header = nib.Nifti1Header()
    try:
        header.set_data_dtype(data.dtype)
        header.set_data_shape(data.shape)
    except (nib.spatialimages.HeaderDataError, ValueError) as error:
        raise ValueError(f"{path}: NIfTI cannot hold this volume: {error}") from None
    if fields.intent_code:
        header["intent_code"] = fields.intent_code  # a number: nibabel's table lacks some
        for i, value in enumerate(fields.intent_params, 1):
            header[f"intent_p{i}"] = value
        header["intent_name"] = fields.intent_name.encode("latin-1")
    elif data.ndim == 5:
        header.set_intent("vector")
    if time:
        header["pixdim"][4] = fields.time_step
    header.set_sform(np.asarray(affine))
    # a qform is a rotation (or a reflection of one), voxel sizes and a translation: for a
    # sheared affine nibabel would write the nearest one, another geometry for the tools
    # that read the qform first (ITK where its code is > 0); there the qform is left unset
    # the file's own qform where it differs from the sform (another world, its own code)
    own = fields.qform is not None and fields.sform_code > 0
    qform = np.asarray(fields.qform if own else affine, dtype=np.float64)
    header.set_qform(qform)
    tolerance = 1e-6 * max(1.0, float(np.abs(qform).max()))
    held = np.allclose(header.get_qform(), qform, rtol=0, atol=tolerance)
    # set as numbers: nibabel's setters know only the codes of its own table
    header["sform_code"] = fields.sform_code or (0 if held else fields.qform_code)
    header["qform_code"] = fields.qform_code if held else 0
    header["xyzt_units"] = fields.xyzt_units
    header["descrip"] = fields.descrip.encode("latin-1")
    header["aux_file"] = fields.aux_file.encode("latin-1")
    header["cal_min"], header["cal_max"] = fields.cal_min, fields.cal_max
    header["toffset"] = fields.toffset
    # no affine given to nibabel: with one, it would rewrite the codes where they are 0
    image = nib.Nifti1Image(data, None, header=header, dtype=data.dtype)
    content = image.to_bytes()
    if compress:
        content = gzip.compress(content, compresslevel=6, mtime=0)
    with atomic_write(path) as tmp:
        tmp.write_bytes(content)
