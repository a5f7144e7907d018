"""Bundled examples: public-domain photographs (a portrait with handles and reference points;
a launch pad's straight towers for segment handles)."""

from __future__ import annotations

import json
from importlib import resources

import numpy as np
from PIL import Image


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
