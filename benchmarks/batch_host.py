"""The host's share of :func:`glmls.warp_batch` per image: tiny images in large batches, where
the GPU's per-pixel work is negligible and the time is Python's and numpy's.

``python benchmarks/batch_host.py [--n 2048] [--size 16] [--repeat 5] [--cases all]
[--move PX] [--profile CASE] [--top 15]``

Each case warps N images of size x size (uint8 RGB) with 16 handles on a 4 x 4 grid moved
by N(0, ``--move`` px) (size / 40 by default, as ``batch_bench.py``; seed 0), with 20
keypoints and a uint8 mask per image where its name says ``kp-mask`` (``kp``: keypoints
alone); it prints the median (and the spread) over ``--repeat`` calls of the wall time per
image in ms, after one untimed call (programs compiled, buffers made), and of the host's
time: the wall time less the time spent inside moderngl's calls (dispatches, transfers,
the waits for the GPU; on llvmpipe its passes run there too). At 20,000 images a second the
host may spend 0.05 ms an image. ``--profile CASE``: that case's top host functions
(cProfile) too. ``quads-gG-INTERPOLATION``: ``method="quads"`` at grid G with that
interpolation; ``backward``: ``method="backward"`` with warp's other defaults (grid 1,
nearest); ``augment-*`` is ``glmls.augment.Augment("grid")`` (its draws included, its own
defaults: bilinear, the ``edge`` border, grid 4).
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import statistics
import sys
import time
from pathlib import Path

import moderngl
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
from glmls.augment import Augment

#: name -> (warp options, keypoints, masks); "augment" is Augment("grid") instead
CASES: dict[str, tuple[dict, bool, bool]] = {
    "quads-g4-linear": ({"grid": 4, "interpolation": "linear"}, False, False),
    "quads-g4-linear-kp-mask": ({"grid": 4, "interpolation": "linear"}, True, True),
    "quads-g4-nearest": ({"grid": 4, "interpolation": "nearest"}, False, False),
    "quads-g4-nearest-kp-mask": ({"grid": 4, "interpolation": "nearest"}, True, True),
    "quads-g1-linear-kp-mask": ({"grid": 1, "interpolation": "linear"}, True, True),
    "quads-g1-nearest-kp": ({"grid": 1, "interpolation": "nearest"}, True, False),
    "backward": ({"method": "backward"}, False, False),
    "backward-kp-mask": ({"method": "backward"}, True, True),
    "augment-grid": ({}, False, False),
    "augment-grid-kp-mask": ({}, True, True),
}


def _inputs(n: int, size: int, move: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    images = rng.integers(0, 256, (n, size, size, 3), dtype=np.uint8)
    masks = rng.integers(0, 4, (n, size, size), dtype=np.uint8)
    side = np.linspace(1, size - 2, 4)
    grid = np.stack(np.meshgrid(side, side), axis=-1).reshape(-1, 2)
    src = np.broadcast_to(grid, (n, *grid.shape)).copy()
    dst = src + rng.normal(0.0, move, src.shape)
    keypoints = rng.uniform(0, size - 1, (n, 20, 2))
    return images, src, dst, keypoints, masks


def _call(name: str, data) -> object:
    images, src, dst, keypoints, masks = data
    options, with_points, with_masks = CASES[name]
    points = keypoints if with_points else None
    labels = masks if with_masks else None
    if name.startswith("augment"):
        return Augment("grid", seed=0, warp_options=options)(images, keypoints=points, masks=labels)
    return glmls.warp_batch(images, src, dst, keypoints=points, masks=labels, **options)


#: Seconds spent inside moderngl's calls (dispatches, transfers, waits), outermost calls only.
_in_gl = [0.0, 0]


def _time_gl() -> None:
    """Every public method of moderngl's objects timed into :data:`_in_gl`."""
    classes = (
        moderngl.Context,
        moderngl.Buffer,
        moderngl.Texture,
        moderngl.TextureArray,
        moderngl.Texture3D,
        moderngl.ComputeShader,
        moderngl.Program,
        moderngl.Framebuffer,
        moderngl.VertexArray,
        moderngl.Query,
    )

    def timed(method):
        def run(*args, **kwargs):
            _in_gl[1] += 1
            start = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                _in_gl[1] -= 1
                if not _in_gl[1]:
                    _in_gl[0] += time.perf_counter() - start

        return run

    for cls in classes:
        for name, value in list(vars(cls).items()):
            if not name.startswith("_") and callable(value) and not isinstance(value, type):
                setattr(cls, name, timed(value))


def measure(name: str, data, repeat: int) -> tuple[list[float], list[float]]:
    """Per call, the wall time per image in ms, and that time less the time in GL calls."""
    _call(name, data)
    n = len(data[0])
    walls, hosts = [], []
    for _ in range(repeat):
        _in_gl[0] = 0.0
        start = time.perf_counter()
        _call(name, data)
        wall = time.perf_counter() - start
        walls.append(wall / n * 1e3)
        hosts.append((wall - _in_gl[0]) / n * 1e3)
    return walls, hosts


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2048, help="images per batch")
    parser.add_argument("--size", type=int, default=16, help="image side in pixels")
    parser.add_argument(
        "--move", type=float, default=None, help="handles' displacement, px (size / 40)"
    )
    parser.add_argument("--repeat", type=int, default=5, help="timed calls per case")
    parser.add_argument(
        "--cases", default="all", help=f"comma-separated among {', '.join(CASES)}, or all"
    )
    parser.add_argument(
        "--profile", default=None, choices=list(CASES), help="a case to profile (cProfile)"
    )
    parser.add_argument("--top", type=int, default=15, help="profiled functions shown")
    args = parser.parse_args(argv)
    names = list(CASES) if args.cases == "all" else args.cases.split(",")
    unknown = sorted(set(names) - set(CASES))
    if unknown:
        parser.error(f"unknown cases {', '.join(unknown)}")
    move = args.size / 40 if args.move is None else args.move
    data = _inputs(args.n, args.size, move)
    print(f"{args.n} images of {args.size} x {args.size} RGB uint8, {args.repeat} calls per case")
    print(f"{'case':28s} {'wall ms':>8s} {'spread':>15s} {'host ms':>8s} {'spread':>15s}")
    _time_gl()
    for name in names:
        walls, hosts = measure(name, data, args.repeat)
        row = [f"{name:28s}"]
        for times in (walls, hosts):
            spread = f"{min(times):.4f}-{max(times):.4f}"
            row.append(f"{statistics.median(times):8.4f} {spread:>15s}")
        print(" ".join(row), flush=True)
    if args.profile:
        _call(args.profile, data)
        profile = cProfile.Profile()
        profile.enable()
        _call(args.profile, data)
        profile.disable()
        text = io.StringIO()
        pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(args.top)
        print(text.getvalue())


if __name__ == "__main__":
    main()
