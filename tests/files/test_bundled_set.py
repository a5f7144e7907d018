"""The bundled study set: six small public-domain photographs, each with handles for a
realistic edit and reference points spread over the subject."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay

from glmls import data

NAMES = ["astronaut", "chelsea", "coffee", "camera", "text", "rocket"]
FOLDER = Path(data.__file__).parent


def test_the_set_and_its_manifest():
    items = data.study_set()
    assert [item.name for item in items] == NAMES
    assert data.study_manifest().is_file()
    total = 0
    for item in items:
        image = item.image()
        assert image.shape[:2] == item.shape and image.dtype == np.uint8
        assert 256 <= max(item.shape) <= 640, item.name
        total += item.image_path.stat().st_size
    assert total < 600_000


def test_handles_and_reference_points_make_sense():
    for item in data.study_set():
        handles = item.handles
        assert 6 <= len(handles) <= 16, item.name
        p, q = handles.source_points(), handles.target_points()
        height, width = item.shape
        assert ((p >= 0) & (p <= [width, height])).all(), item.name
        pinned = np.all(p == q, axis=1)
        assert pinned.any() and not pinned.all(), item.name  # some held, some moved
        moves = np.hypot(*(q - p).T)
        assert moves.max() < 0.1 * np.hypot(height, width), item.name  # a moderate edit
        reference = item.reference
        assert 10 <= len(reference) <= 30, item.name
        assert ((reference >= 0) & (reference < [width, height])).all(), item.name
        # not on a handle, and triangulable into real triangles
        gaps = np.hypot(*(reference[:, None] - p[None]).transpose(2, 0, 1))
        assert gaps.min() >= 5, item.name
        assert len(Delaunay(reference).simplices) >= len(reference) - 2, item.name


def test_every_file_has_its_source_and_licence_in_the_readme():
    readme = (FOLDER / "README.md").read_text(encoding="utf-8")
    manifest = json.loads(data.study_manifest().read_text(encoding="utf-8"))
    for entry in manifest["items"]:
        for field in ("image", "handles", "reference"):
            assert f"`{entry[field]}`" in readme, entry[field]
    for licence in ("public domain", "CC0"):
        assert licence in readme
