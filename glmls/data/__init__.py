"""Bundled examples: public-domain photographs (a portrait with handles and reference points;
a launch pad's straight towers for segment handles), and the study set: six photographs (faces,
objects, text), each with handles for a realistic edit and reference points
(:func:`study_set`, :func:`study_manifest`; README.md names the sources and licences)."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image

from .manifest import StudyItem, read_manifest

__all__ = [
    "StudyItem",
    "astronaut",
    "astronaut_handles",
    "astronaut_reference_points",
    "read_manifest",
    "rocket",
    "study_manifest",
    "study_set",
]


def _path(name: str):
    return resources.files(__name__).joinpath(name)


def astronaut() -> np.ndarray:
    """The portrait of astronaut Eileen Collins (NASA, public domain).

    Returns
    -------
    numpy.ndarray
        512 x 512 x 3 RGB uint8.

    See Also
    --------
    astronaut_handles : handles for an edit of it.
    astronaut_reference_points : reference points for its triangle errors.

    Examples
    --------
    >>> image = glmls.data.astronaut()
    >>> image.shape, image.dtype.name
    ((512, 512, 3), 'uint8')
    """
    with _path("astronaut.jpg").open("rb") as handle, Image.open(handle) as image:
        return np.asarray(image.convert("RGB"))


def rocket() -> np.ndarray:
    """The launch photo of DSCOVR on a Falcon 9 (SpaceX, public domain).

    Straight towers and a rocket body, for segment handles.

    Returns
    -------
    numpy.ndarray
        427 x 640 x 3 RGB uint8 (640 wide).

    Examples
    --------
    >>> glmls.data.rocket().shape
    (427, 640, 3)
    """
    with _path("rocket.jpg").open("rb") as handle, Image.open(handle) as image:
        return np.asarray(image.convert("RGB"))


def astronaut_handles() -> tuple[np.ndarray, np.ndarray]:
    """Point handles for an edit of :func:`astronaut`'s face.

    Returns
    -------
    src, dst : numpy.ndarray
        The handles p_i -> q_i, each (10, 2) float64 (x, y) rows.

    Examples
    --------
    >>> src, dst = glmls.data.astronaut_handles()
    >>> src.shape, dst.shape, src.dtype.name
    ((10, 2), (10, 2), 'float64')
    """
    data = json.loads(_path("astronaut_handles.json").read_text(encoding="utf-8"))
    return np.asarray(data["src"], dtype=float), np.asarray(data["dst"], dtype=float)


def astronaut_reference_points() -> np.ndarray:
    """Reference points on :func:`astronaut` for the triangle errors.

    Returns
    -------
    numpy.ndarray
        (13, 2) float64 (x, y) rows.

    See Also
    --------
    glmls.analysis.triangle_errors : the errors of their Delaunay triangles.

    Examples
    --------
    >>> glmls.data.astronaut_reference_points().shape
    (13, 2)
    """
    data = json.loads(_path("astronaut_reference.json").read_text(encoding="utf-8"))
    return np.asarray(data["points"], dtype=float)


def study_manifest() -> Path:
    """The bundled study set's manifest.

    Returns
    -------
    pathlib.Path
        ``study.json`` among the package's data (its format: :mod:`glmls.data.manifest`).

    See Also
    --------
    read_manifest : reads it.

    Examples
    --------
    >>> glmls.data.study_manifest().name
    'study.json'
    """
    return Path(str(_path("study.json")))


def study_set() -> list[StudyItem]:
    """The bundled study set of six photographs with handles and reference points.

    astronaut (a face), chelsea (a cat's face), coffee (a cup), camera (a tripod), text
    (handwriting on ruled lines) and rocket (segment handles).

    Returns
    -------
    list of StudyItem
        One per photograph, with its handles and reference points; ``item.image()`` reads
        the photograph.

    See Also
    --------
    glmls.analysis.study : a study over such a set.

    Examples
    --------
    >>> items = glmls.data.study_set()
    >>> [item.name for item in items]
    ['astronaut', 'chelsea', 'coffee', 'camera', 'text', 'rocket']
    >>> items[-1].shape, items[-1].handles.points, items[-1].handles.segments
    ((427, 640), 1, 5)
    """
    return read_manifest(study_manifest())
