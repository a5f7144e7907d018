"""Volume warping: glmls's two methods end to end, beside scipy's thin-plate spline and
molesq's N-D affine MLS, with the peak memory of each.

``python benchmarks/volume_bench.py [--size 256] [--handles 64] [--grid G] [--memory 512]
[--skip-peers]``

The workload: a ``--size``^3 uint8 volume of noise, ``--handles`` handles at uniform random
points, each moved by a normal displacement of size / 40 voxels (seed 0), MLS rigid with idw
weights (alpha 1). Each measurement runs in a child process of its own, so that its peak
resident memory (``ru_maxrss``, the volume included) is its own:

- ``glmls quads``: ``warp_volume`` with the cells method (nearest, lattice step ``--grid``,
  else the method's default, 1);
- ``glmls backward``: ``warp_volume`` with the backward method (trilinear, first guess from
  the cells at step ``--grid``, else the method's default, 2);
  both timed end to end (numpy in, numpy out) after a warm-up call on a 16^3 volume that
  compiles the programs; the median of ``--repeat`` calls;
- ``scipy tps``: ``scipy.interpolate.RBFInterpolator`` (thin-plate spline, every handle,
  ``neighbors=None``) fitted to the handles' backward displacements and evaluated at every
  voxel centre, 16 slices at a time (the fit and the evaluation; no resampling);
- ``molesq affine``: ``molesq.Transformer(dst, src).transform`` at 2^16 random voxels, the
  time scaled by voxels / 2^16 (evaluation only);
- ``--memory N``: the peak memory of ``glmls quads`` on an N^3 uint16 volume at lattice step
  8 (the memory is that of the volume, the output and the slabs; the step keeps the run
  short on a CPU renderer).

Prints one line per measurement: tool, seconds, peak MiB; a peer that is not installed is
skipped with a line that says so. Exits 1 when a measurement fails.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def workload(size: int, handles: int, dtype=np.uint8):
    rng = np.random.default_rng(0)
    shape = (size, size, size)
    top = np.iinfo(dtype).max
    volume = rng.integers(0, top, shape, dtype=dtype)
    src = rng.uniform(0, size - 1, (handles, 3))
    dst = src + rng.normal(0, size / 40, src.shape)
    return volume, src, dst


def peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run_glmls(args) -> dict:
    import glmls
    from glmls.core.handles3 import fit_scaling3
    from glmls.engine.kernel3 import MLSKernel3
    from glmls.volume import warp_volume

    dtype = np.uint16 if args.dtype == "uint16" else np.uint8
    volume, src, dst = workload(args.size, args.handles, dtype)
    shape = volume.shape
    config = glmls.MLSConfig(transform="rigid", weight="idw")
    kernel = MLSKernel3(glmls.gl.get_context(), config, shape=shape)
    kernel.upload(src, dst, fit_scaling3(src, dst, shape))
    options = {"method": args.method, "grid": args.grid}
    options["interpolation"] = "linear" if args.method == "backward" else "nearest"
    warp_volume(kernel, volume[:16, :16, :16], **options)  # compiles the programs
    times = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        warp_volume(kernel, volume, **options)
        times.append(time.perf_counter() - start)
    return {"seconds": statistics.median(times), "peak_mib": peak_mib()}


def run_scipy(args) -> dict:
    from scipy.interpolate import RBFInterpolator

    volume, src, dst = workload(args.size, args.handles)
    del volume
    n = args.size
    rows, columns = np.mgrid[0:n, 0:n].astype(np.float64)
    start = time.perf_counter()
    tps = RBFInterpolator(dst, src - dst, kernel="thin_plate_spline", neighbors=None)
    for first in range(0, n, 16):
        depth = min(16, n - first)
        slices = np.arange(first, first + depth, dtype=np.float64)
        points = np.empty((depth, n, n, 3))
        points[..., 0], points[..., 1] = columns, rows
        points[..., 2] = slices[:, None, None]
        tps(points.reshape(-1, 3))
    return {"seconds": time.perf_counter() - start, "peak_mib": peak_mib()}


def run_molesq(args) -> dict:
    import molesq

    volume, src, dst = workload(args.size, args.handles)
    rng = np.random.default_rng(1)
    sample = 1 << 16
    points = rng.uniform(0, args.size - 1, (sample, 3))
    start = time.perf_counter()
    molesq.Transformer(dst, src).transform(points)
    elapsed = time.perf_counter() - start
    return {"seconds": elapsed * volume.size / sample, "peak_mib": peak_mib()}


def child(tool: str, args, **override) -> dict:
    command = [sys.executable, __file__, "--child", tool]
    settings = vars(args) | override
    for name in ("size", "handles", "grid", "repeat", "method", "dtype"):
        if settings[name] is not None:
            command += [f"--{name}", str(settings[name])]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode:
        return {"error": (result.stderr.strip().splitlines() or ["no output"])[-1]}
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--handles", type=int, default=64)
    parser.add_argument(
        "--grid", type=int, default=None, help="lattice step (default: each method's own)"
    )
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--memory", type=int, default=0, help="N: peak memory at N^3 uint16")
    parser.add_argument("--skip-peers", action="store_true")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--method", default="quads", help=argparse.SUPPRESS)
    parser.add_argument("--dtype", default="uint8", help=argparse.SUPPRESS)
    args = parser.parse_args()
    for name in ("size", "repeat"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be at least 1, got {getattr(args, name)}")
    if args.child:
        run = {"glmls": run_glmls, "scipy": run_scipy, "molesq": run_molesq}[args.child]
        print(json.dumps(run(args)))
        return 0
    steps = "each method's default" if args.grid is None else args.grid
    print(f"{args.size}^3 uint8, {args.handles} handles, rigid idw, grid {steps}")
    rows = [
        ("glmls quads", child("glmls", args, method="quads")),
        ("glmls backward", child("glmls", args, method="backward")),
    ]
    if not args.skip_peers:
        peers = (("scipy tps (every voxel)", "scipy"), ("molesq affine (scaled)", "molesq"))
        for name, tool in peers:
            if importlib.util.find_spec(tool) is None:
                rows += [(name, {"skipped": f"{tool} is not installed"})]
            else:
                rows += [(name, child(tool, args))]
    if args.memory:
        big = {"size": args.memory, "grid": 8, "dtype": "uint16", "repeat": 1}
        rows += [(f"glmls quads {args.memory}^3 uint16", child("glmls", args, **big))]
    failed = 0
    for name, result in rows:
        if "skipped" in result:
            print(f"{name:32s} skipped: {result['skipped']}")
        elif "error" in result:
            print(f"{name:32s} failed: {result['error']}")
            failed += 1
        else:
            print(f"{name:32s} {result['seconds']:9.3f} s {result['peak_mib']:9.0f} MiB peak")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
