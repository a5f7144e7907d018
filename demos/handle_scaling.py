"""
Time per frame against the number of handles
============================================

One interactive frame is a new ``MLS`` (handles uploaded, and sorted into spatial bins where
used), the deformed image drawn by ``WarpPipeline.render`` into an 8-bit framebuffer, and
``finish()``. The curves show how the time grows with the number of handles for each handle
storage and weight; docs/handles.md explains them. The gallery runs it on a 256 x 256 image
up to 16,384 handles; the defaults below measure a 1024 x 1024 image up to 65,536.

From the command line::

    python demos/handle_scaling.py [--size 1024] [--grid 4] [--out demos/out]

Handles sit on a jittered lattice over the image, targets moved by up to a quarter of the
lattice step. Curves:

- ``idw``, every handle per point, in each storage (``ssbo``, ``ubo`` up to its capacity,
  ``texture``);
- the weights with a radius (``cressman``, ``shepard``, ``linear``, ``gaussian``) at
  R = ``--radius`` px with spatial bins (``bins=True``), and ``cressman`` without them;
- the gaussian with the compact weights' reach: cut at most ``--radius`` px beyond the nearest
  handle, R = radius / sqrt(ln(N / 2^-24)) (3.0 px for 65,536 handles and a radius of 16 px),
  where the R = 16 px gaussian looks about 5 R = 80 px far.

A curve stops once a frame takes longer than ``--max-seconds``, or where this driver refuses
that many handles (llvmpipe caps the loop iterations of one shader invocation, and bins that
thousands of handles crowd would go past it; docs/handles.md). Also measured: the most
handles each storage takes here and what the GL limits guarantee. Writes
``handle_scaling.png`` and ``handle_scaling.csv``.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
from glmls.core.weights import gaussian_cut
from glmls.engine.loops import plain_handles_most
from glmls.engine.storage import STORAGES, make_storage
from glmls.imaging.source import prepare_image

COUNTS = [4**k for k in range(1, 9)]  # 4 .. 65,536


def lattice_handles(n: int, size: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    side = math.ceil(math.sqrt(n))
    step = size / side
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) + 0.5
    p = grid[:n] * step + rng.uniform(-0.25, 0.25, (n, 2)) * step
    return p, p + rng.uniform(-0.25, 0.25, (n, 2)) * step


def frame_time(series: dict, n: int, args, gl, pipe, source, framebuffer) -> float:
    """Median seconds of a frame (3 runs after one untimed)."""
    p, q = lattice_handles(n, args.size)
    series = dict(series)
    if "reach" in series:  # the gaussian whose cut is that far: R = reach / sqrt(ln(N / tau))
        series["radius"] = series.pop("reach") / math.sqrt(gaussian_cut(n))
    times = []
    for k in range(4):
        start = time.perf_counter()
        with glmls.MLS(p, q + 0.01 * k, shape=(args.size, args.size), ctx=gl, **series) as m:
            gl.make_current()
            framebuffer.use()
            pipe.clear(framebuffer)
            pipe.render(m, source, framebuffer, grid=args.grid)
            gl.mgl.finish()
        if k:
            times.append(time.perf_counter() - start)
    return float(np.median(times))


def capacities(gl) -> dict[str, dict]:
    """The most handles each storage takes here, whether that many evaluate, and what every
    GL 4.3 driver must take: uniform block >= 16 KB, storage block >= 16 MB; for textures we
    count 1,024 texels per side, the conservative minimum (newer tables list 16,384). Tried:
    up to 1M handles (16 MB, enough to show it works), on a driver that caps a shader's loop
    iterations (llvmpipe) as many as one evaluation visiting them all may take. It works
    where the last handle counts: f at its source is its target."""
    guaranteed = {"ubo": 16384 // 16, "ssbo": (16 << 20) // 16, "texture": 1024**2}
    most = plain_handles_most(gl.loop_limit)
    out = {}
    for name in STORAGES:
        storage = make_storage(name, gl.mgl)
        capacity = storage.capacity
        storage.release()
        tried = min(capacity, 1 << 20, most or capacity)
        p = np.random.default_rng(0).uniform(0, 1000, (tried, 2))
        q = p.copy()
        q[-1] += 1.0
        with glmls.MLS(p, q, ctx=gl, storage=name) as m:
            works = bool(np.abs(m(p[-1:]) - q[-1:]).max() < 1e-3)
        out[name] = {"capacity": capacity, "tried": tried, "works": works}
        out[name]["guaranteed"] = guaranteed[name]
    return out


def make_capacity(gl, name: str) -> int:
    storage = make_storage(name, gl.mgl)
    capacity = storage.capacity
    storage.release()
    return capacity


def plot(results: dict[str, list[tuple[int, float]]], path: Path, title: str) -> None:
    colours = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (23, 190, 207),
        (188, 189, 34),
    ]
    width, height, left, top, right, bottom = 900, 560, 70, 40, 260, 50
    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    times = [t for points in results.values() for _, t in points]
    lo = math.floor(math.log10(min(times)))
    hi = max(math.ceil(math.log10(max(times))), lo + 1)
    x0, x1 = math.log2(COUNTS[0]), math.log2(COUNTS[-1])

    def xy(n: int, seconds: float) -> tuple[float, float]:
        x = left + (width - left - right) * (math.log2(n) - x0) / (x1 - x0)
        y = height - bottom - (height - top - bottom) * (math.log10(seconds) - lo) / (hi - lo)
        return x, y

    draw.text((left, 10), title, fill="black")
    for decade in range(lo, hi + 1):
        _, y = xy(COUNTS[0], 10.0**decade)
        draw.line([(left, y), (width - right, y)], fill=(225, 225, 225))
        draw.text((5, y - 6), f"{10.0**decade * 1e3:g} ms", fill="black")
    for n in COUNTS:
        x, _ = xy(n, 10.0**lo)
        draw.line([(x, top), (x, height - bottom)], fill=(235, 235, 235))
        draw.text((x - 12, height - bottom + 8), f"{n:,}", fill="black")
    draw.text((left + 250, height - 18), "handles (log scale)", fill="black")
    for i, (name, points) in enumerate(results.items()):
        colour = colours[i % len(colours)]
        line = [xy(n, t) for n, t in points]
        if len(line) > 1:
            draw.line(line, fill=colour, width=2)
        for x, y in line:
            draw.ellipse([x - 3, y - 3, x + 3, y + 3], fill=colour)
        ly = top + 18 * i
        key = [(width - right + 15, ly + 6), (width - right + 40, ly + 6)]
        draw.line(key, fill=colour, width=3)
        draw.text((width - right + 48, ly), name, fill="black")
    image.save(path)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--grid", type=int, default=4)
    parser.add_argument("--radius", type=float, default=16.0, help="R of the radius weights, px")
    parser.add_argument("--max-seconds", type=float, default=5.0)
    parser.add_argument(
        "--out", type=Path, default=Path(os.path.relpath(Path(__file__).parent / "out"))
    )
    parser.add_argument(
        "--counts", help="handle counts to time, comma-separated (default 4, 16, ..., 65536)"
    )
    parser.add_argument("--series", help="only the series whose name contains this text")
    parser.add_argument(
        "--no-capacities", action="store_true", help="skip evaluating each storage's capacity"
    )
    args = parser.parse_args()
    counts = [int(n) for n in args.counts.split(",")] if args.counts else COUNTS
    args.out.mkdir(parents=True, exist_ok=True)

    gl = glmls.gl.get_context()
    pipe = glmls.gl.WarpPipeline.of(gl)
    image = np.random.default_rng(1).integers(0, 255, (args.size, args.size, 3), np.uint8)
    source = pipe.upload(prepare_image(image, pipe.max_image_size, normalized=True), "demo")
    gl.make_current()
    target = gl.mgl.texture((args.size, args.size), 4, dtype="f1")
    framebuffer = gl.mgl.framebuffer(color_attachments=[target])

    series: dict[str, dict] = {f"idw, {s}": {"storage": s, "bins": False} for s in STORAGES}
    for weight in ("cressman", "shepard", "linear", "gaussian"):
        series[f"{weight}, R {args.radius:g}, bins"] = {
            "weight": weight,
            "radius": args.radius,
            "bins": True,
        }
    series[f"gaussian, reach {args.radius:g}, bins"] = {
        "weight": "gaussian",
        "reach": args.radius,
        "bins": True,
    }
    series[f"cressman, R {args.radius:g}, no bins"] = {
        "weight": "cressman",
        "radius": args.radius,
        "bins": False,
    }
    if args.series:
        series = {name: options for name, options in series.items() if args.series in name}
    limits = {} if args.no_capacities else capacities(gl)
    results: dict[str, list[tuple[int, float]]] = {}
    rows = []
    for name, options in series.items():
        results[name] = []
        storage = options.get("storage", "ssbo")
        cap = limits[storage]["capacity"] if limits else make_capacity(gl, storage)
        for n in counts:
            if n > cap:
                break
            try:
                seconds = frame_time(options, n, args, gl, pipe, source, framebuffer)
            except ValueError as error:
                if gl.loop_limit is None:  # only a capped driver (llvmpipe) refuses a count
                    raise
                print(f"{name:<28} {n:>6} handles  refused here: {error}", flush=True)
                break
            results[name].append((n, seconds))
            rows.append({"series": name, "handles": n, "ms_per_frame": round(seconds * 1e3, 2)})
            print(f"{name:<28} {n:>6} handles  {seconds * 1e3:9.1f} ms/frame", flush=True)
            if seconds > args.max_seconds:
                break
    with open(args.out / "handle_scaling.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=["series", "handles", "ms_per_frame"])
        writer.writeheader()
        writer.writerows(rows)
    title = f"time per frame, {args.size}^2 RGB, grid {args.grid}, {gl.mgl.info['GL_RENDERER']}"
    plot(results, args.out / "handle_scaling.png", title)
    for name, info in limits.items():
        print(
            f"{name:<8} capacity here {info['capacity']:>12,} handles, guaranteed by GL 4.3 "
            f"{info['guaranteed']:>12,}; {info['tried']:,} evaluated: {info['works']}"
        )
    print(f"wrote {args.out / 'handle_scaling.png'} and .csv")


if __name__ == "__main__":
    main()
