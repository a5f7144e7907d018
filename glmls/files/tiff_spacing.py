"""The voxel spacing (dz, dy, dx) of a TIFF stack, as :mod:`.volumes` reads and writes it: a
calibrated ImageJ stack's (its ``spacing`` and X/Y resolutions), an OME-TIFF's
(``PhysicalSizeZ``, ``Y``, ``X``), or the ``"spacing"`` of the JSON description that
:func:`~glmls.files.volumes.write_volume` writes for the dtypes ImageJ does not hold; and the
mark that :func:`~glmls.files.volumes.write_volume` leaves on a stack of one channel,
(D, H, W, 1), whose channel axis a TIFF's pages (one sample each) do not hold."""

from __future__ import annotations

import json

import tifffile

from ..core.handles3 import as_volume_spacing

__all__ = [
    "CHANNEL_KEY",
    "MOST_PER_UNIT",
    "SPACING_KEY",
    "fits_resolutions",
    "one_channel",
    "stack_spacing",
]

#: The key of the spacing [dz, dy, dx] in the JSON description of the first page of a stack
#: of a dtype ImageJ does not hold.
SPACING_KEY = "spacing"
#: The key, true, in an ImageJ description (``channel_axis=true``) or in the JSON description
#: of the first page, of a stack that is a volume of one channel (D, H, W, 1): its pages are
#: those of the stack (D, H, W), as other programs open it, and glmls reads the axis back.
CHANNEL_KEY = "channel_axis"
#: The largest numerator or denominator of a TIFF resolution (an unsigned 32-bit fraction).
MOST_PER_UNIT = 2**32 - 1


def fits_resolutions(spacing: tuple[float, float, float]) -> bool:
    """Whether the X/Y resolutions (pixels per unit) of ``spacing`` are TIFF fractions: else
    tifffile refuses them, or rounds them to 0, which no reader takes for a pixel size."""
    return all(1 / MOST_PER_UNIT <= step <= MOST_PER_UNIT for step in spacing[1:])


def stack_spacing(tiff: tifffile.TiffFile) -> tuple[float, float, float] | None:
    """(dz, dy, dx) of a TIFF stack: ImageJ's, else OME's, else the JSON description's; None
    where the file says none."""
    return _tiff_spacing(tiff) or _ome_spacing(tiff) or _json_spacing(tiff)


def one_channel(tiff: tifffile.TiffFile) -> bool:
    """Whether a TIFF stack says it is a volume of one channel (D, H, W, 1): ``CHANNEL_KEY``
    true in its ImageJ description, or in the JSON description of its first page."""
    metadata = tiff.imagej_metadata
    if metadata is None:
        metadata = _json_description(tiff)
    return metadata.get(CHANNEL_KEY) is True


def _json_description(tiff: tifffile.TiffFile) -> dict:
    """The JSON object of the description of a stack's first page; empty for another
    description (none, ImageJ's, OME's XML, text)."""
    description = tiff.pages[0].description
    if not description.startswith("{"):
        return {}
    try:
        value = json.loads(description)
    except (RecursionError, ValueError):  # not one of glmls's
        return {}
    return value if isinstance(value, dict) else {}


def _tiff_spacing(tiff: tifffile.TiffFile) -> tuple[float, float, float] | None:
    """(dz, dy, dx) of a calibrated ImageJ stack, None for others.

    ImageJ (Fiji) writes a calibrated stack's unit (``unit=``), the pixel size as the X/Y
    resolutions, and ``spacing=`` (the voxel depth) only where that depth is neither 0 nor 1:
    a stack of 0.25 x 0.25 x 1 um voxels has no ``spacing``, and its depth is 1."""
    metadata = tiff.imagej_metadata or {}
    unit = str(metadata.get("unit", "pixel")).lower()
    if "spacing" not in metadata and unit in ("pixel", "pixels", ""):
        return None  # not calibrated
    tags = tiff.pages[0].tags
    try:
        dz = float(metadata.get("spacing", 1.0))
        dx = _resolution(tags["XResolution"].value) if "XResolution" in tags else 1.0
        dy = _resolution(tags["YResolution"].value) if "YResolution" in tags else 1.0
        return as_volume_spacing((dz, dy, dx))
    except (TypeError, ValueError, ZeroDivisionError):
        return None


#: OME's length units in micrometres, to put the axes of an OME-TIFF in one unit.
_OME_MICROMETRES = {
    "pm": 1e-6,
    "Å": 1e-4,
    "nm": 1e-3,
    "µm": 1.0,
    "μm": 1.0,
    "um": 1.0,
    "mm": 1e3,
    "cm": 1e4,
    "m": 1e6,
}


def _ome_spacing(tiff: tifffile.TiffFile) -> tuple[float, float, float] | None:
    """(dz, dy, dx) of an OME-TIFF's first image: its ``PhysicalSizeZ``, ``Y`` and ``X`` (1
    where one is missing; None where all are), in their unit (OME's default, um), or in
    micrometres where the axes' units differ."""
    if not tiff.is_ome or not tiff.ome_metadata:
        return None
    import xml.etree.ElementTree as ElementTree

    try:
        root = ElementTree.fromstring(tiff.ome_metadata)
    except ElementTree.ParseError:
        return None
    pixels = next((e for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "Pixels"), None)
    if pixels is None or not any(f"PhysicalSize{a}" in pixels.attrib for a in "XYZ"):
        return None
    units = [pixels.get(f"PhysicalSize{a}Unit", "µm") for a in "ZYX"]
    try:
        steps = [float(pixels.get(f"PhysicalSize{a}", 1.0)) for a in "ZYX"]
        if len(set(units)) > 1:
            steps = [step * _OME_MICROMETRES[unit] for step, unit in zip(steps, units, strict=True)]
        return as_volume_spacing(steps)
    except (KeyError, TypeError, ValueError):
        return None


def _json_spacing(tiff: tifffile.TiffFile) -> tuple[float, float, float] | None:
    """(dz, dy, dx) of a stack written in a dtype ImageJ does not hold: the ``"spacing"``
    list of the JSON description of its first page (tifffile's shaped one, for channels);
    None for another description or a value that is no spacing."""
    spacing = _json_description(tiff).get(SPACING_KEY)
    if not isinstance(spacing, list) or len(spacing) != 3:
        return None  # none, or another program's metadata of that name
    try:
        return as_volume_spacing(spacing)
    except (TypeError, ValueError):  # not one of glmls's
        return None


def _resolution(value: tuple[int, int]) -> float:
    """The pixel size of a TIFF resolution (pixels per unit, a fraction)."""
    numerator, denominator = value
    return denominator / numerator
