"""Reading and writing images without loss of depth.

- PNG: Pillow, except 16-bit colour and grey-with-alpha PNGs (Pillow reduces them to 8 bits),
  which imagecodecs (libpng) decodes and encodes; the orientation of an ``eXIf`` chunk applied.
- TIFF: tifffile (16-bit colour, float32, float64 as they are); the orientation tag applied;
  palette, CMYK, YCbCr, min-is-white and 1-bit TIFFs converted to the colours shown, as Pillow
  converts them; CIE L*a*b* and LogLuv TIFFs refused.
- 16-bit colour PPM: read here (Pillow reduces it to 8 bits), as uint16.
- Everything else Pillow reads: JPEG, BMP, WebP, GIF, ...; the EXIF orientation is applied, and
  an animated image gives its first frame with an :class:`~glmls.errors.ImageWarning`.

A corrupt or truncated file raises ``ValueError`` naming the file; an image larger than
``max_pixels`` (default :data:`DEFAULT_MAX_PIXELS`, the largest texture OpenGL drivers commonly
take) raises ``ValueError`` before it is decoded.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import struct
import threading
import warnings
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import NoReturn

import imagecodecs
import numpy as np
import tifffile
from PIL import Image, ImageOps, UnidentifiedImageError

from ..core.config import check_integer
from ..errors import ImageWarning
from .atomic import atomic_write
from .netpbm import is_ppm16, ppm16
from .parsing import as_path, read_head
from .profiles import profile_problem, with_png_profile
from .tiffs import TIFF_SIGNATURES, orient, quiet_tifffile

__all__ = [
    "DEFAULT_MAX_PIXELS",
    "WRITABLE",
    "check_writable",
    "image_bytes",
    "imread",
    "imwrite",
    "shown_shape",
]

#: Images of more pixels are refused unless ``max_pixels`` says otherwise: 16384 x 16384, the
#: texture limit of common OpenGL drivers (a 4-channel float32 copy of it is 4 GB).
DEFAULT_MAX_PIXELS = 16384 * 16384
#: What each output suffix takes: dtypes, and whether an alpha channel fits.
WRITABLE = {
    ".png": (("uint8", "uint16"), True),
    ".tif": (("uint8", "uint16", "float32", "float64"), True),
    ".tiff": (("uint8", "uint16", "float32", "float64"), True),
    ".jpg": (("uint8",), False),
    ".jpeg": (("uint8",), False),
    ".bmp": (("uint8",), False),  # Pillow reads a 32-bit BMP's fourth channel as nothing
    ".webp": (("uint8",), True),
}
#: Formats of colour images only: a grey image would come back RGB (or RGBA).
_COLOUR_ONLY = (".webp",)
_PNG = b"\x89PNG\r\n\x1a\n"
#: The most of a compressed PNG text chunk decoded (Pillow's limit).
_MAX_TEXT = 1 << 20
#: Decoding failures of a corrupt file, whichever library meets them.
_CORRUPT = (
    OSError,
    SyntaxError,
    ValueError,
    EOFError,
    IndexError,
    KeyError,
    struct.error,
    zlib.error,
    RuntimeError,
    tifffile.TiffFileError,
)
_pillow_lock = threading.Lock()
_pillow_saved: int | None = None  # Pillow's own limit while a read has set ours
#: TIFF photometric interpretations whose stored values are not the colours shown.
_MINISWHITE, _RGB, _PALETTE, _CMYK, _YCBCR = 0, 2, 3, 5, 6
#: The TIFF colour types Pillow converts to RGB: its mode and their samples a pixel.
_PILLOW_COLOURS = {_CMYK: ("CMYK", 4), _YCBCR: ("YCbCr", 3)}
#: CIE L*a*b* (8 bits, ICC, ITU) and LogL, LogLuv: encodings glmls does not convert.
_UNCONVERTED = {8: "CIE L*a*b*", 9: "ICC L*a*b*", 10: "ITU L*a*b*", 32844: "LogL", 32845: "LogLuv"}
#: TIFF compressions by JPEG (old and new), whose decoder turns YCbCr into RGB.
_JPEG = (6, 7)
_SEPARATE = 2  # TIFF planar configuration: each sample a plane of its own


def _too_large(path: Path, width: int, height: int, max_pixels: int) -> None:
    if width * height > max_pixels:
        _refuse(path, f"{width} x {height} = {width * height:,}", max_pixels)


def _refuse(path: Path, pixels: str, max_pixels: int) -> NoReturn:
    raise ValueError(
        f"{path}: {pixels} pixels exceeds the limit of {max_pixels:,} "
        "(raise it with max_pixels=, or glmls's --max-pixels)"
    )


def _check_max_pixels(max_pixels: object) -> int:
    """Before any file is read: a bad limit would else surface as a corrupt file (glmls's
    integer rule: a float, a bool or a string is a ``TypeError``, a count below 1 a
    ``ValueError``)."""
    return check_integer("max_pixels", max_pixels, 1)


def imread(path: str | os.PathLike, *, max_pixels: int = DEFAULT_MAX_PIXELS) -> np.ndarray:
    """Read an image file into an array, without loss of depth.

    PNG (16-bit too), TIFF (16-bit, float32, float64 as they are), and everything else Pillow
    reads (JPEG, BMP, WebP, GIF, ...). The EXIF (or TIFF) orientation is applied in every
    format, as ``PIL.ImageOps.exif_transpose`` applies it: the array is the image as viewers
    show it. Palette and other modes become RGB or RGBA; a transparent colour (a PNG's
    ``tRNS``, a GIF's transparent index) becomes an alpha channel.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    max_pixels : int, default 268435456
        The largest image read (W x H; the default is 16384²);
        larger ones are refused before they are decoded.

    Returns
    -------
    numpy.ndarray
        H x W (grey) or H x W x C; uint8, uint16 (16-bit PNG, TIFF, PPM), float32 or float64
        (TIFF); a TIFF of another dtype (int8, int16, int32, uint32, float16, ...) as it is
        stored, which :func:`glmls.warp` takes converted (to float32, say).

    Raises
    ------
    FileNotFoundError, PermissionError
        For a missing or unreadable file.
    ValueError
        Naming the file, for a corrupt or unsupported one, a folder, or one of more than
        ``max_pixels``; for ``max_pixels`` below 1.
    TypeError
        For ``max_pixels`` that is not an integer, or a ``path`` that is not a file path
        (None, a number).

    Warns
    -----
    ImageWarning
        For an animation or a multi-page TIFF, of which the first frame is read.

    See Also
    --------
    imwrite : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ramp.png"
    >>> glmls.imwrite(path, np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000)
    >>> image = glmls.imread(path)
    >>> image.shape, image.dtype.name, image[2].tolist()
    ((3, 4), 'uint16', [40000, 45000, 50000, 55000])
    """
    max_pixels = _check_max_pixels(max_pixels)
    path = as_path(path)
    head = read_head(path, 32)
    try:
        if head.startswith(_PNG) and len(head) >= 26 and head[24] == 16:
            return _read_png16(path, head, max_pixels)
        if head[:2] in (b"P3", b"P6") and (header := is_ppm16(read_head(path, 4096))):
            return _read_ppm16(path, header, max_pixels)
        if head[:4] in TIFF_SIGNATURES:
            return _read_tiff(path, max_pixels)
        return _read_pillow(path, max_pixels)
    except _CORRUPT as error:
        if isinstance(error, (FileNotFoundError, PermissionError, IsADirectoryError)):
            raise
        if isinstance(error, ValueError) and str(error).startswith(str(path)):
            raise  # already ours
        raise ValueError(f"{path}: not a readable image (corrupt or truncated?): {error}") from None


def shown_shape(path: str | os.PathLike) -> tuple[int, int] | None:
    """The (H, W) of the array :func:`imread` gives for ``path``, from the file's header and
    orientation, without decoding its pixels (but a PNG whose text chunks follow them, which
    Pillow reads whole): a quarter turn (EXIF or TIFF orientation 5 to 8) swaps the stored
    sides, each format's orientation read where :func:`imread` reads it. None where the
    header does not say (:func:`imread` then names what is wrong)."""
    path = as_path(path)
    try:
        head = read_head(path, 32)
        if head.startswith(_PNG) and len(head) >= 26 and head[24] == 16:
            width, height = struct.unpack(">II", head[16:24])
            code = _png_chunks(path.read_bytes())[0]
        elif head[:2] in (b"P3", b"P6") and (header := is_ppm16(read_head(path, 4096))):
            (width, height), code = header[:2], 1
        elif head[:4] in TIFF_SIGNATURES:
            with quiet_tifffile(), tifffile.TiffFile(path) as tiff:
                page = tiff.pages[0]
                width, height = int(page.imagewidth), int(page.imagelength)
                orientation = page.tags.get("Orientation")
                code = int(orientation.value) if orientation is not None else 1
        else:
            with Image.open(path) as image:
                (width, height), code = image.size, int(image.getexif().get(0x0112, 1))
    except Exception:  # whatever the header lacks, the read names
        return None
    return (width, height) if code in (5, 6, 7, 8) else (height, width)


def _read_png16(path: Path, head: bytes, max_pixels: int) -> np.ndarray:
    width, height = struct.unpack(">II", head[16:24])
    _too_large(path, width, height, max_pixels)
    data = path.read_bytes()
    try:
        array = np.asarray(imagecodecs.png_decode(data))
    except (imagecodecs.PngError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: corrupt or truncated 16-bit PNG ({error})") from None
    orientation, frames = _png_chunks(data)
    if frames > 1:  # libpng decodes the default image: an APNG's first frame
        warnings.warn(f"{path}: {frames} frames; reading the first", ImageWarning, stacklevel=4)
    return orient(array, orientation)


def _read_ppm16(path: Path, header: tuple[int, int, int, int], max_pixels: int) -> np.ndarray:
    _too_large(path, header[0], header[1], max_pixels)
    try:
        return ppm16(path.read_bytes(), header)
    except ValueError as error:
        raise ValueError(f"{path}: corrupt or truncated 16-bit PPM ({error})") from None


def _png_chunks(data: bytes) -> tuple[int, int]:
    """A PNG's EXIF orientation and frames, as Pillow finds them for the PNGs it decodes:
    the orientation of an ``eXIf`` chunk, else of ImageMagick's "Raw profile type exif"
    text chunk (1 where there is none or it is unreadable); the frames of an APNG's
    ``acTL`` chunk (1 for a still image)."""
    exif, raw, frames = None, None, 1
    at = len(_PNG)
    while at + 8 <= len(data):
        size = struct.unpack(">I", data[at : at + 4])[0]
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + size]
        if kind == b"eXIf" and exif is None:
            exif = body
        elif kind in (b"tEXt", b"zTXt", b"iTXt") and raw is None:
            raw = _raw_exif(kind, body)
        elif kind == b"acTL" and len(body) >= 4:
            frames = max(1, struct.unpack(">I", body[:4])[0])
        elif kind == b"IEND":
            break
        at += 12 + size
    found = exif if exif is not None else raw
    if found is None:
        return 1, frames
    try:
        loaded = Image.Exif()
        loaded.load(found)
        return int(loaded.get(0x0112, 1)), frames
    except _CORRUPT:
        return 1, frames


def _raw_exif(kind: bytes, body: bytes) -> bytes | None:
    """The EXIF of a text chunk keyed "Raw profile type exif" (ImageMagick's: a name, the
    length, then the bytes in hexadecimal, on lines of their own), else None."""
    keyword, _, text = body.partition(b"\0")
    if keyword != b"Raw profile type exif":
        return None
    compressed = kind == b"zTXt"
    if kind == b"iTXt":  # compression flag and method, language, translated keyword
        fields = text[2:].split(b"\0", 2)
        compressed, text = text[:1] == b"\x01", fields[-1] if len(fields) == 3 else b""
    elif compressed:
        text = text[1:]
    try:
        if compressed:  # bounded, as Pillow bounds text chunks: no decompression bomb
            text = zlib.decompressobj().decompress(text, _MAX_TEXT)
        return bytes.fromhex("".join(text.decode("latin-1").split("\n")[3:]))
    except (zlib.error, ValueError):
        return None


def _read_tiff(path: Path, max_pixels: int) -> np.ndarray:
    with quiet_tifffile(), tifffile.TiffFile(path) as tiff:
        page = tiff.pages[0]
        shape = page.shape
        _too_large(path, shape[1] if len(shape) > 1 else 1, shape[0], max_pixels)
        if len(tiff.pages) > 1:
            warnings.warn(
                f"{path}: {len(tiff.pages)} pages; reading the first", ImageWarning, stacklevel=4
            )
        array = page.asarray()
        photometric, colormap = int(page.photometric), page.colormap
        planar = int(page.planarconfig) == _SEPARATE
        if photometric == _YCBCR and int(page.compression) in _JPEG:
            photometric = _RGB  # the JPEG decoder gives RGB
        orientation = page.tags.get("Orientation")
        code = int(orientation.value) if orientation is not None else 1
    if array.ndim not in (2, 3) or not array.size:
        raise ValueError(f"{path}: not an image: its first page is of shape {array.shape}")
    if array.ndim == 3 and planar:
        array = np.moveaxis(array, 0, -1)  # planar storage: samples first
    return orient(np.ascontiguousarray(_as_shown(path, array, photometric, colormap)), code)


def _as_shown(
    path: Path, array: np.ndarray, photometric: int, colormap: np.ndarray | None
) -> np.ndarray:
    """A TIFF's stored numbers as the colours they show, as Pillow converts them: palette
    indices through the colormap, CMYK inks to RGB, YCbCr to RGB, min-is-white inverted, 1-bit
    to RGB; a CIE L*a*b* or LogLuv TIFF is refused."""
    if photometric in _UNCONVERTED:
        raise ValueError(
            f"{path}: a TIFF of {_UNCONVERTED[photometric]} colours; glmls reads grey, RGB, "
            "palette, CMYK and YCbCr TIFFs: convert it to RGB"
        )
    if array.dtype == bool:
        white = array != (photometric == _MINISWHITE)
        return np.repeat((white * np.uint8(255))[..., None], 3, axis=2)
    if photometric == _PALETTE and colormap is not None and array.ndim == 2:
        if array.dtype == np.uint8:  # 8-bit entries: the high bytes, as Pillow and libtiff
            colormap = (colormap >> 8).astype(np.uint8)
        return np.moveaxis(colormap, 0, -1)[array]
    if photometric == _MINISWHITE and array.dtype.kind == "u":
        return np.iinfo(array.dtype).max - array
    if photometric in _PILLOW_COLOURS:
        mode, samples = _PILLOW_COLOURS[photometric]
        if array.dtype != np.uint8 or array.ndim != 3 or array.shape[2] != samples:
            raise ValueError(
                f"{path}: a {mode} TIFF of {array.dtype.name} x {array.shape[-1]}; glmls reads "
                f"8-bit {mode}: convert it to RGB"
            )
        return np.asarray(Image.fromarray(array, mode).convert("RGB"))
    return array


@contextlib.contextmanager
def _pillow_limit(max_pixels: int) -> Iterator[None]:
    """Pillow's own decompression-bomb limit set to ours while it opens the file (its warning
    silenced: glmls checks the size itself; Pillow refuses beyond twice the limit)."""
    global _pillow_saved
    with _pillow_lock, warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        _pillow_saved = Image.MAX_IMAGE_PIXELS
        Image.MAX_IMAGE_PIXELS = max_pixels
        try:
            yield
        finally:
            Image.MAX_IMAGE_PIXELS, _pillow_saved = _pillow_saved, None


def _after_fork_in_child() -> None:
    """A read that another thread of the parent was doing at the fork never ends here: its
    lock is made anew (else every read here would wait for ever) and Pillow's limit put back."""
    global _pillow_lock, _pillow_saved
    _pillow_lock = threading.Lock()
    if _pillow_saved is not None:
        Image.MAX_IMAGE_PIXELS, _pillow_saved = _pillow_saved, None


os.register_at_fork(after_in_child=_after_fork_in_child)


def _read_pillow(path: Path, max_pixels: int) -> np.ndarray:
    try:
        with _pillow_limit(max_pixels):
            image = Image.open(path)
    except Image.DecompressionBombError as error:
        # Pillow's message names the pixels and twice its limit: say ours
        found = re.search(r"\((\d+) pixels\)", str(error))
        _refuse(path, f"{int(found[1]):,}" if found else "the image's", max_pixels)
    except UnidentifiedImageError:
        size = path.stat().st_size
        with open(path, "rb") as file:
            png = file.read(8) == _PNG
        if png:
            raise ValueError(f"{path}: corrupt or truncated PNG ({size} bytes)") from None
        raise ValueError(f"{path}: not an image format glmls reads ({size} bytes)") from None
    with image:
        _too_large(path, *image.size, max_pixels)
        frames = getattr(image, "n_frames", 1)
        if frames > 1:
            warnings.warn(f"{path}: {frames} frames; reading the first", ImageWarning, stacklevel=4)
        image.load()
        oriented = ImageOps.exif_transpose(image) or image
        return _as_array(oriented)


def _as_array(image: Image.Image) -> np.ndarray:
    mode = image.mode
    if mode in ("I;16", "I;16B", "I;16L"):
        return np.asarray(image).astype(np.uint16)
    if mode == "I":
        array = np.asarray(image)
        if array.size and array.min() >= 0 and array.max() <= 65535:
            return array.astype(np.uint16)
        return array
    if mode == "F":
        return np.asarray(image, dtype=np.float32)
    if mode in ("L", "RGB") and "transparency" in image.info:
        # a PNG's tRNS colour: an alpha channel, as for a palette's transparent entries
        return np.asarray(image.convert("RGBA" if mode == "RGB" else "LA")).copy()
    if mode not in ("L", "LA", "RGB", "RGBA"):
        alpha = "A" in mode or "transparency" in image.info
        image = image.convert("RGBA" if alpha else "RGB")
    return np.asarray(image).copy()


def _channels(array: np.ndarray) -> int:
    return 1 if array.ndim == 2 else array.shape[2]


def check_writable(path: str | os.PathLike, dtype: object = None, channels: int | None = None):
    """``ValueError`` unless ``path``'s suffix names a format glmls writes, for ``dtype`` and
    ``channels`` where given (call it before any work, then again with the image)."""
    suffix = Path(path).suffix.lower()
    if suffix not in WRITABLE:
        known = ", ".join(WRITABLE)
        raise ValueError(f"{path}: unknown image format {suffix or '(no suffix)'}; use {known}")
    dtypes, alpha = WRITABLE[suffix]
    if dtype is not None and np.dtype(dtype).name not in dtypes:  # type: ignore[call-overload]
        fits = [s for s, (d, _) in WRITABLE.items() if np.dtype(dtype).name in d]  # type: ignore[call-overload]
        where = f"; write it as {', '.join(fits[:-1])} or {fits[-1]}" if len(fits) > 1 else ""
        where = f"; write it as {fits[0]}" if len(fits) == 1 else where
        raise ValueError(f"{path}: {suffix} cannot hold {np.dtype(dtype).name} images{where}")  # type: ignore[call-overload]
    if channels is not None and channels in (2, 4) and not alpha:
        fits = _suffixes(dtype, channels)
        raise ValueError(f"{path}: {suffix} has no alpha channel; write {fits}")
    if channels is not None and channels in (1, 2) and suffix in _COLOUR_ONLY:
        fits = _suffixes(dtype, channels)
        raise ValueError(f"{path}: {suffix} holds colour images only, not grey; write {fits}")


def _suffixes(dtype: object, channels: int) -> str:
    """The suffixes that hold images of ``dtype`` (any, where None) and ``channels``."""
    fits = [
        suffix
        for suffix, (dtypes, alpha) in WRITABLE.items()
        if (dtype is None or np.dtype(dtype).name in dtypes)  # type: ignore[call-overload]
        and (alpha or channels not in (2, 4))
        and not (suffix in _COLOUR_ONLY and channels in (1, 2))
    ]
    return ", ".join(fits[:-1]) + f" or {fits[-1]}" if len(fits) > 1 else fits[0]


def imwrite(path: str | os.PathLike, image: object, *, icc_profile: bytes | None = None) -> None:
    """Write an image to a file whose suffix names its format.

    uint8 to any format of ``WRITABLE``, uint16 to PNG or TIFF, float32 and float64 to
    TIFF; 2 or 4 channels (with alpha) to PNG or TIFF, and 4 to WebP, which holds colour
    images only (3 or 4 channels). PNG, TIFF and BMP are lossless;
    JPEG and WebP are lossy, at Pillow's default quality (75 and 80).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (``.png``, ``.jpg``, ``.tif``, ...) chooses the format.
    image : array_like
        H x W or H x W x C with C in 1..4 (H x W x 1 is written as grey: it reads back
        H x W).
    icc_profile : bytes, optional
        An ICC colour profile written with the image (PNG, TIFF, JPEG and WebP hold one): an
        RGB profile for 3 or 4 channels, a grey one for 1 or 2. A photograph's own,
        ``glmls.files.read_icc_profile(path)``, keeps its colours as viewers show
        them; without one, viewers take the pixels for sRGB.

    Raises
    ------
    ValueError
        Before writing anything, for an unknown suffix, a format that cannot hold the image's
        dtype or alpha (or a grey image: WebP), an empty image or a wrong shape, or an
        ``icc_profile`` that is not an ICC profile, does not fit the image's channels or that
        the format cannot hold.
    TypeError
        For a ``path`` that is not a file path (None, a number).
    OSError
        ``PATH: cannot write: ...``, for a failed write (a full disk, no permission): the
        file is written whole or not at all.

    See Also
    --------
    imread : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> glmls.imwrite(folder / "depth.tif", np.full((2, 3), 0.25, np.float32))
    >>> glmls.imread(folder / "depth.tif").dtype.name
    'float32'
    >>> glmls.imwrite(folder / "depth.jpg", np.zeros((2, 3), np.float32))
    Traceback (most recent call last):
        ...
    ValueError: ...depth.jpg: .jpg cannot hold float32 images; write it as .tif or .tiff
    """
    path = as_path(path)
    data = image_bytes(path, image, icc_profile=icc_profile)
    # a checked write of bytes encoded in memory: Pillow's encoders write to the file
    # descriptor and pass over a short write (a full disk), leaving a truncated file
    with atomic_write(path) as tmp, open(tmp, "wb") as file:
        file.write(data)


def image_bytes(
    path: str | os.PathLike, image: object, *, icc_profile: bytes | None = None
) -> bytes:
    """The file :func:`imwrite` writes, as bytes: for a writer of its own (a temporary name
    that it renames), checked as :func:`imwrite` checks (``ValueError``)."""
    path = as_path(path)
    array = np.asarray(image)
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[..., 0]
    if array.ndim not in (2, 3) or (array.ndim == 3 and not 2 <= array.shape[2] <= 4):
        raise ValueError(f"image must be H x W or H x W x C with C in 1..4, got {array.shape}")
    if array.size == 0:
        raise ValueError(f"image is empty: shape {array.shape}")
    check_writable(path, array.dtype, _channels(array))
    if icc_profile is not None:
        problem = profile_problem(path, icc_profile, _channels(array))
        if problem:
            raise ValueError(f"{path}: {problem}")
        icc_profile = bytes(icc_profile)
    return _encode(Path(path).suffix.lower(), np.ascontiguousarray(array), icc_profile)


def _encode(suffix: str, array: np.ndarray, icc_profile: bytes | None) -> bytes:
    """The file of format ``suffix`` holding ``array`` (checked by :func:`imwrite`)."""
    if suffix in (".tif", ".tiff"):
        channels = _channels(array)
        photometric = "rgb" if channels >= 3 else "minisblack"
        extra = ["unassalpha"] if channels in (2, 4) else None
        buffer = io.BytesIO()
        tifffile.imwrite(
            buffer, array, photometric=photometric, extrasamples=extra, iccprofile=icc_profile
        )
        return buffer.getvalue()
    if array.dtype == np.uint16:
        png = imagecodecs.png_encode(array, level=6)
        return with_png_profile(png, icc_profile) if icc_profile else png
    buffer = io.BytesIO()
    options = {"icc_profile": icc_profile} if icc_profile else {}
    Image.fromarray(array).save(buffer, format=Image.registered_extensions()[suffix], **options)
    return buffer.getvalue()
