"""NIfTI files through nibabel: the header fields a volume carries (:class:`NiftiHeader`),
and the reading and writing that :func:`glmls.files.volumes.read_volume` and
:func:`~glmls.files.volumes.write_volume` do for ``.nii`` and ``.nii.gz``; the conventions
are described in :mod:`glmls.files.volumes`."""

from __future__ import annotations

import dataclasses
import gzip
from pathlib import Path

import numpy as np

from ..core.config import check_real
from ..errors import InputFileError
from .atomic import atomic_write

__all__ = ["NiftiHeader", "one_line", "read_nifti", "write_nifti"]

#: dtypes NIfTI lacks, written as the nearest it has: masks as uint8, half floats as float32.
_NIFTI_AS = {"bool": np.uint8, "float16": np.float32}


@dataclasses.dataclass(frozen=True)
class NiftiHeader:
    """The fields of a NIfTI header that a volume read from it carries, to be written back.

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

    Raises
    ------
    ValueError
        For a code outside 0..32767, a units byte outside 0..255, a description longer than
        80 characters or not Latin-1, a time step that is not finite, or a qform that is not
        a finite 4 x 4 matrix.
    TypeError
        For a code or units value that is not an integer.

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
    """

    sform_code: int = 1
    qform_code: int = 1
    xyzt_units: int = 0
    descrip: str = ""
    time_step: float | None = None
    qform: tuple | None = None

    def __post_init__(self) -> None:
        for name, top in (("sform_code", 32767), ("qform_code", 32767), ("xyzt_units", 255)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise TypeError(f"{name} must be an integer, got {value!r}")
            if not 0 <= value <= top:
                raise ValueError(f"{name} must be in 0..{top}, got {value}")
            object.__setattr__(self, name, int(value))
        try:
            size = len(str(self.descrip).encode("latin-1"))
        except UnicodeEncodeError:
            raise ValueError("descrip must be Latin-1 text") from None
        if size > 80:
            raise ValueError(f"descrip holds at most 80 characters, got {size}")
        if self.time_step is not None:
            object.__setattr__(self, "time_step", check_real("time_step", self.time_step))
        if self.qform is not None:
            matrix = np.asarray(self.qform, dtype=np.float64)
            if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
                raise ValueError(f"qform must be a finite 4 x 4 matrix, got {matrix.shape}")
            object.__setattr__(self, "qform", tuple(tuple(row) for row in matrix.tolist()))


def _nibabel():
    import nibabel  # a dependency; imported where used: it is slow to import

    return nibabel


def read_nifti(path: Path) -> tuple[np.ndarray, np.ndarray, NiftiHeader]:
    """(data (z, y, x[, C]), the affine (4, 4) float64, the header's fields) of a NIfTI
    file; ``InputFileError`` naming it where it is not one glmls reads."""
    nib = _nibabel()
    refused = (
        nib.filebasedimages.ImageFileError,
        nib.spatialimages.HeaderDataError,
        nib.spatialimages.HeaderTypeError,
    )
    try:
        with nib.imageglobals.LoggingOutputSuppressor():  # its repairs, logged to stderr
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
        descrip=bytes(header["descrip"]).split(b"\0", 1)[0].decode("latin-1"),
        time_step=(step if np.isfinite(step) else 0.0) if time else None,
        qform=_own_qform(header, affine),
    )
    return volume, affine, fields


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
    if data.ndim == 5:
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
    # no affine given to nibabel: with one, it would rewrite the codes where they are 0
    image = nib.Nifti1Image(data, None, header=header, dtype=data.dtype)
    content = image.to_bytes()
    if compress:
        content = gzip.compress(content, compresslevel=6, mtime=0)
    with atomic_write(path) as tmp:
        tmp.write_bytes(content)
