"""Study manifests: the images, handles and reference points of a study over an image set.

A manifest is a JSON file::

    {"items": [
        {"name": "cat", "image": "cat.jpg", "handles": "cat_handles.json",
         "reference": "cat_reference.json"},
        ...
    ]}

(a bare list of the items is accepted too). Paths are relative to the manifest's folder (or
absolute); ``handles`` is any handles file that :func:`glmls.files.landmarks.read_handle_set`
reads (JSON, CSV or BigWarp: 2D points, segments, polylines) and ``reference`` a reference-points
file (:func:`~glmls.files.landmarks.read_points`, at least 3 points, no point twice, not all on
one line). ``name`` is optional (default: the image's file name without its suffix) and must
be unique, since it names the item's column in the study's table and its output folder; other
keys (``"description"``) are ignored. Only the image's header is read (its size): a study
needs the image's shape only.

Every fault is an :class:`~glmls.errors.InputFileError` naming the manifest, the item and the
field: ``set.json: "items"[2] (cat): "handles": cat.json: no such file``.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from ..core.handles import check_reference_points
from ..core.handleset import HandleSet
from ..errors import InputFileError
from ..files.images import DEFAULT_MAX_PIXELS, imread
from ..files.landmarks import handle_dimension, read_handle_set, read_points
from ..files.parsing import brief, fail, read_text

__all__ = ["MIN_REFERENCE_POINTS", "StudyItem", "read_manifest"]

#: The reference triangles need at least one triangle.
MIN_REFERENCE_POINTS = 3
_FIELDS = ("image", "handles", "reference")
#: a name must be usable as a folder name and a CSV column
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}$")


@dataclass(frozen=True, eq=False)
class StudyItem:
    """One image of a study: its name, size, handles and reference points.

    Parameters
    ----------
    name : str
        The item's name (its column in the study's table, its output folder).
    shape : tuple of int
        The image's (H, W).
    handles : HandleSet
        The handles of the item's edit.
    reference : numpy.ndarray
        Reference points for the triangle errors, (K, 2) with K >= 3.
    image_path : pathlib.Path or None
        Where the image is (:meth:`image` reads it); None for an item without a file.
    handles_path, reference_path : pathlib.Path or None
        The files the handles and the reference points were read from (None where they
        were given as values): a study keeps its outputs off every file it reads.

    See Also
    --------
    read_manifest : the items of a manifest.

    Examples
    --------
    >>> item = glmls.data.study_set()[0]
    >>> item.name, item.shape, len(item.handles), item.reference.shape
    ('astronaut', (512, 512), 10, (13, 2))
    >>> item.image().shape
    (512, 512, 3)
    """

    name: str
    shape: tuple[int, int]
    handles: HandleSet
    reference: np.ndarray
    image_path: Path | None = None
    handles_path: Path | None = None
    reference_path: Path | None = None

    def image(self) -> np.ndarray:
        """The image's pixels, read now.

        Returns
        -------
        numpy.ndarray
            As :func:`glmls.imread` reads it.

        Raises
        ------
        ValueError
            When the item has no image file.

        Examples
        --------
        >>> item = glmls.data.study_set()[0]
        >>> item.image().shape[:2] == item.shape
        True
        >>> handles = glmls.HandleSet.validate([[0, 0]], [[1, 0]])
        >>> glmls.data.StudyItem("drawn", (8, 8), handles, np.zeros((3, 2))).image()
        Traceback (most recent call last):
            ...
        ValueError: drawn: no image file
        """
        if self.image_path is None:
            raise ValueError(f"{self.name}: no image file")
        return imread(self.image_path)


def image_shape(path: Path) -> tuple[int, int]:
    """(H, W) from the image's header (the whole image only where Pillow cannot read it)."""
    try:
        with Image.open(path) as image:
            width, height = image.size
    except FileNotFoundError:
        raise
    except (OSError, ValueError, Image.DecompressionBombError):
        height, width = imread(path).shape[:2]  # 16-bit colour PNG, float TIFF...
    if width * height > DEFAULT_MAX_PIXELS:
        raise ValueError(f"{path}: {width} x {height} pixels, more than {DEFAULT_MAX_PIXELS}")
    return height, width


def read_manifest(path: str | os.PathLike) -> list[StudyItem]:
    """The items of a study manifest, checked.

    A manifest is a JSON file ``{"items": [{"name": ..., "image": ..., "handles": ...,
    "reference": ...}, ...]}`` (see ``glmls.data.manifest``); paths are relative to its
    folder. Only each image's header is read.

    Parameters
    ----------
    path : str or os.PathLike
        The manifest.

    Returns
    -------
    list of StudyItem
        The items, in the file's order.

    Raises
    ------
    InputFileError
        A ``ValueError`` naming the manifest, the item and the field: invalid JSON, no items,
        a missing or unreadable file, a file of 3D handles (a study deforms 2D images), fewer
        than 3 reference points, or reference points that cannot be triangulated (the same
        point twice, all on one line), a name taken twice.

    Examples
    --------
    >>> items = glmls.data.read_manifest(glmls.data.study_manifest())
    >>> len(items), items[1].name, items[1].shape
    (6, 'chelsea', (300, 451))
    """
    path = Path(path)
    text = read_text(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise fail(path, f"line {error.lineno}", f"invalid JSON: {error.msg}") from None
    except (ValueError, RecursionError) as error:
        raise fail(path, "content", f"invalid JSON: {error}") from None
    where = "top level"
    if isinstance(data, dict):
        if "items" not in data:
            raise fail(path, where, 'missing the key "items"')
        data, where = data["items"], '"items"'
    if not isinstance(data, list):
        raise fail(path, where, f"expected a list of items, got {type(data).__name__}")
    if not data:
        raise fail(path, where, "no items")
    items: list[StudyItem] = []
    seen: dict[str, int] = {}
    for index, entry in enumerate(data):
        item = _item(path, f"{where}[{index}]", entry)
        if item.name in seen:
            raise fail(
                path,
                f"{where}[{index}]",
                f"the name {item.name!r} is taken by item {seen[item.name]}; names must differ",
            )
        seen[item.name] = index
        items.append(item)
    return items


def _item(manifest: Path, where: str, entry: object) -> StudyItem:
    if not isinstance(entry, dict):
        fields = ", ".join(_FIELDS)
        raise fail(manifest, where, f"expected an object with {fields}, got {brief(entry)}")
    files: dict[str, Path] = {}
    for field in _FIELDS:
        value = entry.get(field)
        if not isinstance(value, str) or not value:
            raise fail(manifest, f'{where}."{field}"', f"expected a file name, got {brief(value)}")
        files[field] = manifest.parent / value
    name = entry.get("name", files["image"].stem)
    if not isinstance(name, str) or not _NAME.match(name):
        rule = "letters, digits and _.+- (up to 64, not starting with a sign)"
        raise fail(manifest, f'{where}."name"', f"expected {rule}, got {brief(name)}")
    where = f"{where} ({name})"

    def problem(field: str, error: object) -> InputFileError:
        return fail(manifest, f'{where}."{field}"', str(error))

    if not files["image"].is_file():
        exists = files["image"].exists()  # a folder: not "no such file"
        raise problem("image", f"{files['image']}: {'not a file' if exists else 'no such file'}")
    try:
        shape = image_shape(files["image"])
    except (OSError, ValueError) as error:
        raise problem("image", f"{files['image']}: cannot read the image: {error}") from None
    try:
        three = handle_dimension(files["handles"]) == 3
        handles = None if three else read_handle_set(files["handles"])
    except (InputFileError, OSError) as error:
        raise problem("handles", error) from None
    if handles is None:  # said for a study, not as read_handle_set's advice to library callers
        raise problem(
            "handles",
            f"{files['handles']}: 3D handles (x, y, z), but a study deforms 2D images: it "
            "takes 2D handles (x, y), points, segments or polylines",
        )
    try:
        reference = read_points(files["reference"])
    except (InputFileError, OSError) as error:
        raise problem("reference", error) from None
    if len(reference) < MIN_REFERENCE_POINTS:
        raise problem(
            "reference",
            f"{files['reference']}: {len(reference)} reference points; the triangle errors "
            f"need at least {MIN_REFERENCE_POINTS}",
        )
    try:  # here, not after the tunes of the items before it
        reference = check_reference_points(reference)
    except ValueError as error:
        raise problem("reference", f"{files['reference']}: {error}") from None
    reference.flags.writeable = False
    return StudyItem(
        name, shape, handles, reference, files["image"], files["handles"], files["reference"]
    )
