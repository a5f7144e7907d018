"""Bundled examples: public-domain photographs (a portrait with handles and reference points;
a launch pad's straight towers for segment handles), and the study set: six photographs (faces,
objects, text), each with handles for a realistic edit and reference points
(:func:`study_set`, :func:`study_manifest`; README.md names the sources and licences); and in
3D, made by code: a 64^3 phantom volume (:func:`phantom`) and a sphere mesh (:func:`sphere`)
in the same frame, each with 3D handles."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image

from ..files.meshes import Mesh
from .manifest import StudyItem, read_manifest
from .synthetic import icosphere, phantom_volume

__all__ = [
    "StudyItem",
    "astronaut",
    "astronaut_handles",
    "astronaut_reference_points",
    "phantom",
    "phantom_handles",
    "read_manifest",
    "rocket",
    "sphere",
    "sphere_handles",
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
        ``study.json`` among the package's data (its format: ``glmls.data.manifest``).

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


def _handles_3d(name: str) -> tuple[np.ndarray, np.ndarray]:
    data = json.loads(_path(name).read_text(encoding="utf-8"))
    return np.asarray(data["src"], dtype=float), np.asarray(data["dst"], dtype=float)


def phantom() -> np.ndarray:
    """A 64^3 phantom volume, made by code (the same every time).

    An ellipsoid body (value 110) holding a flat ellipsoid (160), a large sphere (200,
    radius 7 about (x, y, z) = (24, 28, 32)) and a small one (255, radius 4.5 about
    (42, 30, 30)), and grid lines along x, y and z every 8 voxels (40) through all but the
    spheres, on a background of 0.

    Returns
    -------
    numpy.ndarray
        (D, H, W) = (64, 64, 64) uint8, indexed ``[z, y, x]``.

    See Also
    --------
    phantom_handles : 3D handles for an edit of it.
    sphere : a mesh in the same frame.

    Examples
    --------
    >>> volume = glmls.data.phantom()
    >>> volume.shape, volume.dtype.name, int(volume[32, 28, 24])  # the large sphere's centre
    ((64, 64, 64), 'uint8', 200)
    """
    return phantom_volume()


def phantom_handles() -> tuple[np.ndarray, np.ndarray]:
    """3D point handles for an edit of :func:`phantom`.

    The large sphere moved 4 voxels along x and 2 along -y, the small one 2 along -z; the
    eight corners of the body's box held.

    Returns
    -------
    src, dst : numpy.ndarray
        The handles p_i -> q_i, each (10, 3) float64 (x, y, z) rows.

    Examples
    --------
    >>> src, dst = glmls.data.phantom_handles()
    >>> src.shape, (dst - src)[0].tolist()
    ((10, 3), [4.0, -2.0, 0.0])
    """
    return _handles_3d("phantom_handles.json")


def sphere() -> Mesh:
    """A sphere mesh, made by code: an icosphere of radius 20 about (32, 32, 32).

    It lies inside :func:`phantom`'s frame; its triangles are wound outwards.

    Returns
    -------
    Mesh
        162 vertices (x, y, z) and 320 triangles.

    See Also
    --------
    sphere_handles : 3D handles for an edit of it.

    Examples
    --------
    >>> mesh = glmls.data.sphere()
    >>> mesh.vertices.shape, mesh.faces.shape
    ((162, 3), (320, 3))
    >>> float(np.linalg.norm(mesh.vertices - 32, axis=1).round(6).max())
    20.0
    """
    vertices, faces = icosphere(2)
    return Mesh(vertices * 20.0 + 32.0, faces)


def sphere_handles() -> tuple[np.ndarray, np.ndarray]:
    """3D point handles for an edit of :func:`sphere`.

    The +x pole pulled out 6 and the +z pole 3; the other poles and the centre held.

    Returns
    -------
    src, dst : numpy.ndarray
        The handles p_i -> q_i, each (7, 3) float64 (x, y, z) rows.

    Examples
    --------
    >>> src, dst = glmls.data.sphere_handles()
    >>> src.shape, (dst - src)[0].tolist()
    ((7, 3), [6.0, 0.0, 0.0])
    """
    return _handles_3d("sphere_handles.json")
