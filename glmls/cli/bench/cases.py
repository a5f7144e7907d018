"""The timed cases of ``glmls bench``: glmls and the tools a user would pick instead.

Every case warps the same image with the same handles (:func:`workload_inputs`) and is run in
a process of its own (see :mod:`glmls.cli.bench.runner`), so that its peak memory is its own. A
case runs once untimed (imports, GL context, shader compilation) and then ``repeat`` times,
timed.

Workloads (:data:`WORKLOADS`):

- ``lattice`` (W1, W3): :func:`make_inputs`, handles on a jittered lattice moved by up to 4 %
  of the image; the mesh never folds.
- ``random`` (W2): :func:`random_inputs`, handles anywhere in the middle 90 % moved by up to
  3.4 % of the image in each axis, on a random RGB image: the mesh folds, as a user's edits
  often make it.

``error``: after the timed runs, the share of output pixels (in %) whose value differs from
the image built with f's exact inverse at every pixel (glmls ``backward`` at grid 1,
Newton's method on f per pixel): what a coarse mesh, an adaptive tolerance or another tool's
mathematics cost in fidelity to per-pixel MLS. ``tolerance`` (glmls only): the adaptive
mesh's bound on every pixel's source point instead of a fixed ``grid``.

Tools:

- ``glmls`` (mode ``e2e``): ``MLS(...)`` then ``m.warp(image, grid=...)``, numpy in, numpy out
  (quads, nearest).
- ``glmls`` (mode ``frame``): one interactive frame: new handles, a new ``MLS``, the deformed
  image drawn into an 8-bit framebuffer of the image's size with the context's
  :class:`~glmls.gl.WarpPipeline` and a kept source texture, ``ctx.finish()``; no read-back.
- ``reference``: glmls's float64 numpy MLS (:func:`glmls.reference.mls`), and ``molesq``
  (affine MLS, numpy): both map points, so they warp backward the way numpy MLS tools do, with
  the handles swapped (output pixel -> source point), evaluated on every ``grid``-th pixel and
  interpolated in between, then sampled with ``scipy.ndimage.map_coordinates`` (nearest).
  Points go through in blocks of 65,536 (all at once needs N x points float64 temporaries).
- ``skimage-pwa`` / ``skimage-tps``: scikit-image's ``PiecewiseAffineTransform`` and
  ``ThinPlateSplineTransform`` (>= 0.24) with ``skimage.transform.warp`` (order 0).
- ``opencv-tps``: ``cv2.createThinPlateSplineShapeTransformer`` where the installed OpenCV
  has it (the contrib ``shape`` module; ``opencv-python-headless`` 5 does not).
"""

from __future__ import annotations

import importlib.util
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

TOOLS = ("glmls", "reference", "molesq", "skimage-pwa", "skimage-tps", "opencv-tps")
MODES = ("e2e", "frame")
WORKLOADS = ("lattice", "random")
#: Tools that implement MLS (the others ignore ``transform``), and what molesq offers.
MLS_TOOLS = ("glmls", "reference", "molesq")
MOLESQ_TRANSFORMS = ("affine",)
#: Tools whose result does not depend on ``grid`` (they evaluate every pixel).
GRIDLESS_TOOLS = ("skimage-pwa", "skimage-tps", "opencv-tps")
_BLOCK = 1 << 16


@dataclass(frozen=True)
class Case:
    tool: str
    mode: str
    size: int
    handles: int
    grid: int
    transform: str
    workload: str = "lattice"
    tolerance: float | None = None

    def to_dict(self) -> dict:
        return asdict(self)

    def warp_options(self) -> dict:
        """glmls's mesh options: the adaptive tolerance, or the fixed grid."""
        return {"tolerance": self.tolerance} if self.tolerance else {"grid": self.grid}


def make_inputs(size: int, handles: int, *, seed: int = 0) -> tuple[np.ndarray, ...]:
    """A size x size RGB uint8 image (smooth colours and a checkerboard, so that a warp is
    visible) and ``handles`` source points on a jittered lattice with targets moved by up to
    4 % of the image: (image, src, dst)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) / size
    checker = ((xx * 16).astype(int) + (yy * 16).astype(int)) % 2
    image = np.dstack([xx * 200 + checker * 55, yy * 200 + checker * 55, (1 - xx) * 255])
    image = image.astype(np.uint8)
    side = int(np.ceil(np.sqrt(handles)))
    lattice = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) + 0.5
    src = lattice[:handles] / side * size + rng.uniform(-0.2, 0.2, (handles, 2)) * size / side
    src = np.clip(src, 0, size - 1)
    dst = src + rng.uniform(-0.04, 0.04, src.shape) * size
    return image, src, dst


def random_inputs(size: int, handles: int, *, seed: int = 4) -> tuple[np.ndarray, ...]:
    """W2: a size x size random RGB uint8 image and ``handles`` random source points in the
    middle 90 % of the image, each moved by up to 3.4 % of the image per axis (35 px at 1024):
    the mesh folds. (image, src, dst)."""
    rng = np.random.default_rng(seed)
    src = rng.uniform(0.05 * size, 0.95 * size, (handles, 2))
    dst = src + rng.uniform(-35 / 1024 * size, 35 / 1024 * size, (handles, 2))
    image = np.random.default_rng(0).integers(0, 256, (size, size, 3), dtype=np.uint8)
    return image, src, dst


def workload_inputs(case: Case) -> tuple[np.ndarray, ...]:
    """(image, src, dst) of ``case``'s workload."""
    if case.workload == "random":
        return random_inputs(case.size, case.handles)
    return make_inputs(case.size, case.handles)


def available(tool: str) -> str | None:
    """None if ``tool`` can run here, else why not (one line)."""
    modules = {
        "molesq": "molesq",
        "skimage-pwa": "skimage",
        "skimage-tps": "skimage",
        "opencv-tps": "cv2",
        "reference": "scipy",
    }
    module = modules.get(tool)
    if module is not None and importlib.util.find_spec(module) is None:
        return f"{module} is not installed (pip install 'glmls[bench]')"
    if tool == "skimage-tps":
        import skimage.transform

        if not hasattr(skimage.transform, "ThinPlateSplineTransform"):
            return "scikit-image < 0.24 has no ThinPlateSplineTransform"
    if tool == "opencv-tps":
        import cv2

        if not hasattr(cv2, "createThinPlateSplineShapeTransformer"):
            return f"OpenCV {cv2.__version__} here has no thin-plate-spline shape transformer"
    return None


def _grid_points(size: int, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel centres every ``grid`` pixels, the last row/column included."""
    axis = np.unique(np.append(np.arange(0, size, grid), size - 1)).astype(np.float64)
    return axis, axis


def _backward_sample(image: np.ndarray, mapper: Callable, grid: int) -> np.ndarray:
    """Warp backward: source point = mapper(output pixel centres (K, 2) x, y), evaluated on
    the grid and bilinearly interpolated between, then nearest sampling."""
    from scipy import ndimage

    size = image.shape[0]
    xs, ys = _grid_points(size, grid)
    v = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    s = np.concatenate([mapper(v[i : i + _BLOCK]) for i in range(0, len(v), _BLOCK)])
    s = s.reshape(len(ys), len(xs), 2)
    if grid > 1:  # the coarse map's index of every pixel, then bilinear in between
        coarse = np.interp(np.arange(size), xs, np.arange(len(xs)))
        rows, cols = np.meshgrid(coarse, coarse, indexing="ij")
        s = np.stack(
            [ndimage.map_coordinates(s[..., k], [rows, cols], order=1) for k in range(2)], -1
        )
    coords = [s[..., 1], s[..., 0]]
    return np.dstack(
        [
            ndimage.map_coordinates(image[..., c], coords, order=0, cval=0)
            for c in range(image.shape[2])
        ]
    )


Step = Callable[[int], "np.ndarray | None"]


def _glmls_e2e(case: Case, image, src, dst) -> Step:
    from ...mls import MLS

    def step(k: int) -> np.ndarray:
        with MLS(src, dst, transform=case.transform, shape=image.shape) as m:
            return m.warp(image, **case.warp_options())

    return step


def _glmls_frame(case: Case, image, src, dst) -> Step:
    from ...gl.context import get_context
    from ...imaging.pipeline import WarpPipeline
    from ...imaging.source import prepare_image
    from ...mls import MLS

    gl = get_context()
    pipe = WarpPipeline.of(gl)
    source = pipe.upload(prepare_image(image, pipe.max_image_size, normalized=True), "bench")
    with gl:
        target = gl.mgl.texture(source.size, 4, dtype="f1")
        framebuffer = gl.mgl.framebuffer(color_attachments=[target])
    rng = np.random.default_rng(1)
    moves = rng.uniform(-2, 2, (64, *dst.shape))  # the handles move every frame

    def step(k: int) -> None:
        with MLS(src, dst + moves[k % 64], transform=case.transform, ctx=gl) as m, gl:
            framebuffer.use()
            pipe.clear(framebuffer)  # as the window clears its picture
            pipe.render(m, source, framebuffer, **case.warp_options())
            gl.mgl.finish()

    return step  # no image: a frame is never read back (no error column)


def _reference(case: Case, image, src, dst) -> Step:
    from ... import reference

    shape = image.shape[:2]

    def mapper(v: np.ndarray) -> np.ndarray:
        return reference.mls(dst, src, v, transform=case.transform, shape=shape)[0]

    return lambda k: _backward_sample(image, mapper, case.grid)


def _molesq(case: Case, image, src, dst) -> Step:
    import molesq

    def step(k: int) -> np.ndarray:
        transformer = molesq.Transformer(src, dst)
        mapper = lambda v: transformer.transform(v, reverse=True)  # noqa: E731
        return _backward_sample(image, mapper, case.grid)

    return step


def _skimage(case: Case, image, src, dst) -> Step:
    from skimage import transform

    kind = {
        "skimage-pwa": "PiecewiseAffineTransform",
        "skimage-tps": "ThinPlateSplineTransform",
    }[case.tool]

    def step(k: int) -> np.ndarray:
        tform = getattr(transform, kind)()
        tform.estimate(dst, src)  # warp() wants the backward map: output -> source
        return transform.warp(image, tform, order=0, preserve_range=True).astype(np.uint8)

    return step


def _opencv(case: Case, image, src, dst) -> Step:
    import cv2

    def step(k: int) -> np.ndarray:
        tps = cv2.createThinPlateSplineShapeTransformer()
        matches = [cv2.DMatch(i, i, 0) for i in range(len(src))]
        # warpImage maps backward: estimate from the target shape to the source shape
        tps.estimateTransformation(
            dst.reshape(1, -1, 2).astype(np.float32),
            src.reshape(1, -1, 2).astype(np.float32),
            matches,
        )
        return tps.warpImage(image, flags=cv2.INTER_NEAREST)

    return step


_RUNNERS = {
    ("glmls", "e2e"): _glmls_e2e,
    ("glmls", "frame"): _glmls_frame,
    ("reference", "e2e"): _reference,
    ("molesq", "e2e"): _molesq,
    ("skimage-pwa", "e2e"): _skimage,
    ("skimage-tps", "e2e"): _skimage,
    ("opencv-tps", "e2e"): _opencv,
}


def peak_memory_mb() -> float:
    """This process's peak resident memory (VmHWM; ru_maxrss where /proc is missing), MiB."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def mismatch_percent(image: np.ndarray, src, dst, transform: str, output) -> float | None:
    """The share (%) of ``output``'s pixels that differ from the image built with f's exact
    inverse at every pixel (glmls ``backward``, grid 1, nearest); None without an output."""
    if output is None:
        return None
    from ...mls import MLS

    with MLS(src, dst, transform=transform, shape=image.shape) as m:
        exact = m.warp(image, method="backward", grid=1)
    output = np.asarray(output)
    if output.shape != exact.shape:
        return 100.0
    return float(np.any(output != exact, axis=-1).mean() * 100)


def case_step(case: Case, image: np.ndarray, src: np.ndarray, dst: np.ndarray):
    """``case``'s timed step for ``image`` and handles ``src`` -> ``dst``: a function of the
    run's number (0: the untimed first run) that warps once and returns the output image
    (None for the ``frame`` mode, which reads nothing back)."""
    return _RUNNERS[case.tool, case.mode](case, image, src, dst)


def run_case(case: Case, repeat: int) -> dict:
    """Time ``case``: one untimed run, then ``repeat`` timed ones (seconds); then the error of
    its output against per-pixel f (:func:`mismatch_percent`), untimed."""
    image, src, dst = workload_inputs(case)
    step = case_step(case, image, src, dst)
    output = step(0)
    times = []
    for k in range(1, repeat + 1):
        start = time.perf_counter()
        step(k)
        times.append(time.perf_counter() - start)
    peak = peak_memory_mb()  # before the reference image adds its own
    transform = case.transform if case.transform in ("affine", "similarity") else "rigid"
    error = mismatch_percent(image, src, dst, transform, output)
    return {"times": times, "peak_mb": peak, "error_percent": error}
