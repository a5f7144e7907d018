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
    """The 512 x 512 RGB uint8 portrait of astronaut Eileen Collins (NASA, public domain)."""
    with _path("astronaut.jpg").open("rb") as handle, Image.open(handle) as image:
        return np.asarray(image.convert("RGB"))


def rocket() -> np.ndarray:
    """The 640 x 427 RGB uint8 launch photo of DSCOVR on a Falcon 9 (SpaceX, public domain):
    straight towers and a rocket body, for segment handles. ``shape`` (427, 640, 3)."""
    with _path("rocket.jpg").open("rb") as handle, Image.open(handle) as image:
        return np.asarray(image.convert("RGB"))


def astronaut_handles() -> tuple[np.ndarray, np.ndarray]:
    """(src, dst) handles, each (N, 2) float64 (x, y) rows."""
    data = json.loads(_path("astronaut_handles.json").read_text(encoding="utf-8"))
    return np.asarray(data["src"], dtype=float), np.asarray(data["dst"], dtype=float)


def astronaut_reference_points() -> np.ndarray:
    """Reference points for the triangle errors, (K, 2) float64."""
    data = json.loads(_path("astronaut_reference.json").read_text(encoding="utf-8"))
    return np.asarray(data["points"], dtype=float)


def study_manifest() -> Path:
    """The bundled study set's manifest (``study.json``, see :mod:`glmls.data.manifest`)."""
    return Path(str(_path("study.json")))


def study_set() -> list[StudyItem]:
    """The bundled study set: astronaut (a face), chelsea (a cat's face), coffee (a cup),
    camera (a tripod), text (handwriting on ruled lines) and rocket (segment handles), each a
    :class:`StudyItem` with its handles and reference points; ``item.image()`` reads the
    photograph."""
    return read_manifest(study_manifest())
