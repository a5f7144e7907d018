"""Helpers shared by the tests (``pythonpath = ["tests"]`` in pyproject.toml); the handles of
the adaptive mesh's guarantee come from :mod:`glmls.analysis.guarantee`."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import moderngl
import numpy as np
import pytest

from glmls import reference
from glmls.analysis.guarantee import jittered_moves as jittered_moves  # the tests' handles
from glmls.analysis.guarantee import smooth_handles as smooth_handles
from glmls.analysis.guarantee import stretched_handles as stretched_handles
from glmls.core.mesh import MeshLattice
from glmls.errors import InputFileError
from glmls.files import read_handles

#: Background of the coordinate images: no pixel holds it.
SENTINEL = 65535
#: The checkout the tests run from (put on PYTHONPATH for the command-line runs).
ROOT = Path(__file__).resolve().parent.parent


def child_env(**extra: str) -> dict[str, str]:
    """The environment for a child Python: this checkout first on PYTHONPATH, the caller's
    PYTHONPATH kept after it (where dependencies may be installed, e.g. ``pip --target``)."""
    paths = [str(ROOT), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths), **extra}


def run_glmls(
    *args: str, cwd: Path, module: str = "glmls", umask: int | None = None
) -> subprocess.CompletedProcess:
    """``python -m <module> *args`` in ``cwd`` from this checkout, output captured (and the
    process's file-creation mask ``umask``)."""
    env = child_env()
    command = [sys.executable, "-m", module, *args]
    if umask is not None:
        command = ["sh", "-c", f'umask {umask:03o} && exec "$@"', "sh", *command]
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def run_demo(name: str, *args: str) -> subprocess.CompletedProcess:
    """``python demos/<name>.py *args`` from the checkout, output captured."""
    command = [sys.executable, f"demos/{name}.py", *args]
    return subprocess.run(
        command, cwd=ROOT, capture_output=True, text=True, timeout=300, env=child_env()
    )


def glmls_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``python -m glmls.cli *args`` in ``cwd`` (:func:`run_glmls`)."""
    return run_glmls(*args, cwd=cwd, module="glmls.cli")


#: The command-line tests' point handles and reference points, for images of about 32 x 40.
CLI_SRC = [[4, 4], [36, 6], [20, 30], [6, 26]]
CLI_DST = [[6, 5], [34, 8], [24, 28], [6, 26]]
CLI_REFERENCE = [[10, 10], [30, 10], [20, 25], [12, 22], [28, 22]]


def write_cli_handles(folder: Path) -> None:
    """``h.json`` (:data:`CLI_SRC` -> :data:`CLI_DST`) and ``r.json`` (:data:`CLI_REFERENCE`)
    in ``folder``."""
    (folder / "h.json").write_text(json.dumps({"src": CLI_SRC, "dst": CLI_DST}))
    (folder / "r.json").write_text(json.dumps({"points": CLI_REFERENCE}))


def write_elastix_points(path: Path, kind: str, points) -> str:
    """An elastix point file at ``path``: ``kind`` (``point`` or ``index``), the count, and
    each point's coordinates in full precision; the path as a string."""
    rows = "".join(" ".join(repr(float(v)) for v in p) + "\n" for p in points)
    path.write_text(f"{kind}\n{len(points)}\n{rows}")
    return str(path)


def write_text(folder: Path, name: str, text: str) -> Path:
    """``text`` written to ``folder / name`` in UTF-8; the path."""
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def assert_bad_handle_file(path: Path, message: str) -> None:
    """``read_handles(path)`` raises :class:`InputFileError` naming the file and saying
    ``message``."""
    with pytest.raises(InputFileError) as info:
        read_handles(path)
    assert str(info.value).startswith(str(path))
    assert message in str(info.value)


def folding_handles(shape):
    """A 3 x 3 lattice of handles with the centre dragged past its right neighbour and the
    top-left one past the one below it: the map folds in two places."""
    height, width = shape
    unit = np.stack(np.meshgrid([0.15, 0.5, 0.85], [0.15, 0.5, 0.85]), -1).reshape(-1, 2)
    p = unit * [width - 1, height - 1]
    q = p.copy()
    q[4] += [0.45 * width, 0.1 * height]
    q[0] += [0.05 * width, 0.4 * height]
    return p, q


def random_handles(rng, n, size=1024.0, displacement=60.0):
    """n source handles in a size x size image and targets moved by up to ``displacement``."""
    p = rng.uniform(0, size, (n, 2))
    q = p + rng.uniform(-displacement, displacement, (n, 2))
    return p, q


def coordinate_image(height, width):
    """uint16 (H, W, 3): each pixel holds its own x and y (and 0)."""
    yy, xx = np.mgrid[0:height, 0:width]
    return np.dstack([xx, yy, np.zeros_like(xx)]).astype(np.uint16)


def turned_handles(shape, factor, turn=0.0, inset=0.1):
    """Five handles (four ``inset`` from the corners, one at the centre) and their targets
    turned by ``turn`` radians and scaled by ``factor`` about the image centre: < 1 pulls
    the image border in, > 1 pushes the image out on every side."""
    height, width = shape
    c = np.array([(width - 1) / 2, (height - 1) / 2])
    lo, hi = inset, 1.0 - inset
    p = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi], [0.5, 0.5]]) * [width - 1, height - 1]
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    return p, (p - c) @ rot.T * factor + c


def reference_mesh(m, shape, grid=1):
    """Float64 f at the mesh of pixel-square corners, (rows, columns, 2)."""
    v = MeshLattice.corners(shape, grid).points()
    f, _, _ = reference.mls(m.src, m.dst, v.reshape(-1, 2), m.config, shape=shape)
    return f.reshape(v.shape)


def folded_case():
    """A small image whose mesh folds (the centre handle dragged past its neighbours)."""
    shape = (40, 48)
    p = np.array([[10, 10], [38, 8], [24, 20], [12, 32], [36, 30.0]])
    q = p.copy()
    q[2] = [44, 21]
    return shape, p, q


class ReferenceCells:
    """The adaptive build's ``evaluate`` and ``test`` in float64 for a numpy map ``f``: f at
    the points it is given, in order (their vertex ids), the cells' test and, with
    ``predict``, the prediction of every cell's children from it (:func:`glmls.imaging.
    adaptive.patch.predict_cells`, trusted everywhere: ``f`` is taken to be smooth); the
    test checks that each cell's grid is made of points evaluated, at their places."""

    def __init__(self, f, *, predict: bool = False):
        self.f = f
        self.predicts = predict
        self.points: list[np.ndarray] = []
        self.values: list[np.ndarray] = []
        self.predicted = 0  # children predicted

    def evaluate(self, points):
        value = self.f(points)
        self.points.append(points)
        self.values.append(value)
        return value

    def check_grids(self, nodes, tests):
        """Every id of the cells' grids is a point evaluated, at its place: the quarters of
        the cell between its first and last node (its corners)."""
        from glmls.imaging.adaptive.patch import NODES, TESTS

        ids = np.concatenate([nodes, tests], axis=1)
        assert (ids >= 0).all() and (ids < self.count).all()
        points = np.concatenate(self.points)[ids]  # (K, 25, 2)
        first, last = points[:, :1], points[:, 8:9]
        quarters = np.array([[c, r] for r, c in NODES + TESTS]) / 4.0
        np.testing.assert_allclose(points, first + (last - first) * quarters, atol=1e-9)

    def test(self, nodes, tests, width, height, centres, whole):
        from glmls.imaging.adaptive.patch import estimate_cells, predict_cells

        self.check_grids(nodes, tests)
        np.testing.assert_allclose(
            centres, np.concatenate(self.points)[nodes[:, 4]], rtol=0, atol=1e-9
        )
        f = np.concatenate(self.values)
        error, stretch = estimate_cells(f[:, 0], f[:, 1], nodes, tests, width, height)
        if not self.predicts:
            return error, stretch, np.full((len(nodes), 4), np.inf), np.zeros((len(nodes), 4))
        self.predicted += 4 * len(nodes)
        return error, stretch, *predict_cells(f[:, 0], f[:, 1], nodes, tests, width, height)

    @property
    def count(self) -> int:
        return sum(len(v) for v in self.values)


def cross(a, b):
    """z of the cross product of 2-vectors (last axis)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


_GL_TYPES = (
    moderngl.Buffer,
    moderngl.Texture,
    moderngl.Framebuffer,
    moderngl.Renderbuffer,
    moderngl.VertexArray,
    moderngl.Program,
    moderngl.ComputeShader,
)


def live_gl_objects(*types: type) -> int:
    """moderngl objects (of ``types``, default all) not yet released (a released one's mglo
    is an InvalidObject)."""
    gc.collect()
    # isinstance reads each object's __class__, which some libraries' deprecated aliases
    # (torch.distributed.reduce_op) answer with a warning: none of them is a GL object
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sum(
            1
            for obj in gc.get_objects()
            if isinstance(obj, types or _GL_TYPES)
            and obj.glo not in (0, None)
            and type(obj.mglo).__name__ != "InvalidObject"
        )


def random_rotation(rng) -> np.ndarray:
    """A random proper 3D rotation (row vectors), from the QR of a Gaussian matrix."""
    qr, r = np.linalg.qr(rng.normal(size=(3, 3)))
    qr = qr * np.sign(np.diag(r))
    return qr if np.linalg.det(qr) > 0 else -qr


def degenerate_sets3(rng) -> dict[str, np.ndarray]:
    """3D handle sets that 2D never had, in a 256^3 box: two, three, coplanar, collinear,
    one and coincident handles."""
    general = rng.uniform(0, 256, (12, 3))
    axes = random_rotation(rng)[:2]
    line = 128.0 + np.linspace(-100, 100, 5)[:, None] * np.array([[1.0, 2.0, -0.5]]) / 2.3
    return {
        "two": general[:2],
        "three": general[:3],
        "coplanar": 128.0 + rng.uniform(-100, 100, (6, 2)) @ axes,
        "collinear": line,
        "one": general[:1],
        "coincident": np.repeat(general[:1], 4, axis=0),
    }


def context_with_shaders(root: Path, shaders: dict[str, str], *, package: tuple[str, ...] = ()):
    """A headless GL context whose shader library is ``root``, holding the package's shader
    files ``package`` (paths under glmls/shaders, as they are) and ``shaders`` (path: source):
    a test's own entry file that includes the package's pieces it checks."""
    from importlib import resources

    from glmls.gl.context import create_headless
    from glmls.gl.shaders import ShaderLibrary

    files = {
        name: resources.files("glmls").joinpath("shaders", name).read_text() for name in package
    }
    for name, source in {**files, **shaders}.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(source)
    return create_headless(shaders=ShaderLibrary(root))


def moved_handles(rng, count, sizes=None, *, shape):
    """Per image of ``shape`` (H, W), handles over the image moved a few pixels: ``count``
    lists of 6 (or ``sizes``: ragged counts) source and target points."""
    height, width = shape
    sizes = sizes or [6] * count
    src = [rng.uniform((1, 1), (width - 2, height - 2), (k, 2)) for k in sizes]
    dst = [p + rng.normal(0, 2.5, p.shape) for p in src]
    return src, dst


def random_images(rng, count, dtype, channels, *, shape):
    """``count`` random images of ``shape`` (H, W) and ``channels`` (1: H x W): float32 in
    [-1, 2), integers over their dtype's range."""
    size = (count, *shape) if channels == 1 else (count, *shape, channels)
    if dtype == np.float32:
        return rng.uniform(-1, 2, size).astype(np.float32)
    return rng.integers(0, np.iinfo(dtype).max, size, dtype=dtype)


def single_warps(images, src, dst, **options):
    """One :func:`glmls.warp` per image, as a list."""
    import glmls

    return [
        glmls.warp(image, p, q, **options) for image, p, q in zip(images, src, dst, strict=True)
    ]


BATCH_FIELDS = ("images", "keypoints", "keypoints_valid", "masks", "maps", "valid")


def assert_batch_equals_single_path(monkeypatch, got, images, src, dst, masks, points, **options):
    """Every field of ``got`` (a :class:`glmls.BatchResult` with masks, keypoints and maps)
    equal to what ``warp_batch`` gives each image alone through the single path (the forward
    methods' batched path refused; each image's ``warp_one`` called once)."""
    import glmls
    from glmls.batch.single import SingleWarper

    calls = []
    warp_one = SingleWarper.warp_one
    monkeypatch.setattr(
        SingleWarper,
        "warp_one",
        lambda self, *a, **k: calls.append(k["index"]) or warp_one(self, *a, **k),
    )
    monkeypatch.setattr("glmls.batch.run.forward_batchable", lambda options: False)
    for k in range(len(images)):
        one = glmls.warp_batch(
            images[k : k + 1], src[k : k + 1], dst[k : k + 1], masks=masks[k : k + 1],
            keypoints=[points[k]], return_maps=True, max_batch_bytes=1, **options,
        )  # fmt: skip
        for field in BATCH_FIELDS:
            a, b = getattr(got, field)[k], getattr(one, field)[0]
            np.testing.assert_array_equal(a, b, err_msg=f"image {k}: {field}")
    assert calls == [0] * len(images)


def tilted_plane(rng, size, count=10):
    """``count`` random handles in a box of side 64 size, their targets projected onto a
    random plane through (30, 30, 30) size, and its unit normal."""
    src = rng.uniform(0, 64, (count, 3)) * size
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    return src, src - np.outer(src @ normal - 30.0 * size, normal), normal


def probes_plain_affine(src, dst, vertices, h, **options):
    """Where the float64 solve is affine's plain A^-1 B at each of J's six central-difference
    probes (vertices +- h along each axis)."""
    plain = np.ones(len(vertices), bool)
    for e in np.eye(3):
        for sign in (1.0, -1.0):
            plain &= reference.plain_affine(src, dst, vertices + sign * h * e, **options)
    return plain
