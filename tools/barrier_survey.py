"""Every GPU path of glmls under the memory-hazard tracer (``tests/barrier_trace.py``): the
commands that read what an earlier shader stored, or store where an earlier command still
reads, with no ``glMemoryBarrier`` between them. llvmpipe runs each command to its end, so
none of these shows in a result here; on a GPU they race.

    python tools/barrier_survey.py              # every workload, its hazards
    python tools/barrier_survey.py warp volume  # the workloads whose names contain these
    python tools/barrier_survey.py --pieces     # with llvmpipe's pieces of large primitives
    python tools/barrier_survey.py --drop glmls/volume/bands.py:285   # without a barrier

``--drop FILE:LINE`` (repeatable) leaves the barriers issued at that line out of the
tracer's model (GL still gets them): the hazards then met are those it orders, none where
another barrier orders the same or the workloads do not reach it.

By default the context walks no primitive in pieces (``GLContext.piece_pixels`` 0), as on a
GPU: the commands are those a GPU driver gets (the pieces' dispatches, llvmpipe's only, come
with barriers of their own that would hide a missing one). The workloads are small enough
for llvmpipe's loop cap either way.

Exits 1 where a hazard was met. ``tests/gl/test_barriers.py`` runs a few of these in the
test suite.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from barrier_trace import tracing

import glmls
from glmls.imaging.options import PipelineOptions
from glmls.volume import SlabOptions


def _handles(rng, shape, count=7, spread=3.0):
    src = rng.uniform(2, np.array(shape[::-1]) - 2, (count, len(shape)))
    return src, src + rng.normal(0, spread, src.shape)


def _image(rng, shape=(40, 56), channels=3):
    return (rng.random((*shape, channels)) * 255).astype(np.uint8)


def warps(ctx, rng):
    image = _image(rng)
    for spread in (2.0, 12.0):  # gentle, and folding
        src, dst = _handles(rng, image.shape[:2], spread=spread)
        with glmls.MLS(src, dst, ctx=ctx) as m:
            for method in glmls.METHODS:
                for interpolation in glmls.INTERPOLATIONS:
                    for border in glmls.BORDERS:
                        m.warp(image, method=method, interpolation=interpolation, border=border)
            m.warp(image, tolerance=0.05)  # the adaptive mesh
            m.warp(image, grid=4, interpolation="linear")
            m.warp(image.astype(np.float32), method="backward", interpolation="linear")
            m.warp(image[..., 0], tolerance=0.05, interpolation="linear")


def banded_warps(ctx, rng):
    """Image warps whose mesh is evaluated in bands of a few rows (small ``band_bytes``), on
    the compute passes and on the GL rasterizer's."""
    image = _image(rng)
    src, dst = _handles(rng, image.shape[:2], spread=12.0)
    pipes = [
        glmls.gl.WarpPipeline(ctx, options=PipelineOptions(band_bytes=2048, **extra))
        for extra in ({}, {"compute_quads": False})
    ]
    try:
        with glmls.MLS(src, dst, ctx=ctx) as m:
            for pipe in pipes:
                for method in glmls.METHODS:
                    for interpolation in glmls.INTERPOLATIONS:
                        pipe.warp(m, image, method=method, interpolation=interpolation)
                pipe.warp(m, image, tolerance=0.05)
    finally:
        for pipe in pipes:
            pipe.release()


def mls_points(ctx, rng):
    src, dst = _handles(rng, (50, 60))
    with glmls.MLS(src, dst, ctx=ctx) as m:
        points = rng.uniform(0, 60, (300, 2))
        m(points)
        m.matrices(points)
        m.inverse(points)
        m.residuals(src, dst)
        m.error_field((24, 30))
        m.error_field((24, 30), tolerance=0.05)
        m.error_field((24, 30), grid=4)
        m.mesh((24, 30), tolerance=0.05)
        m.coordinate_map((24, 30))
        glmls.analysis.foldovers(m, (24, 30))


def handles_and_storages(ctx, rng):
    image = _image(rng, (32, 40))
    src, dst = _handles(rng, image.shape[:2], count=40, spread=2.0)
    for storage in ("ssbo", "ubo", "texture"):
        with glmls.MLS(src, dst, storage=storage, ctx=ctx) as m:
            m.warp(image)
            m.warp(image, method="backward", interpolation="linear")
    many_src, many_dst = _handles(rng, image.shape[:2], count=600, spread=1.0)
    with glmls.MLS(many_src, many_dst, bins=True, weight="gaussian", radius=8.0, ctx=ctx) as m:
        m.warp(image, tolerance=0.05)
        m.warp(image, method="backward")
    segments = rng.uniform(2, 30, (3, 2, 2))
    with glmls.MLS(
        src[:3], dst[:3], src_segments=segments, dst_segments=segments + 1.0, ctx=ctx
    ) as m:
        m.warp(image)
        m.warp(image, method="paper-quads", interpolation="linear")
    with glmls.MLS(src, dst, ctx=ctx) as m:
        inverse = m.inverse
        inverse(rng.uniform(0, 30, (40, 2)))


def batch(ctx, rng):
    images = np.stack([_image(rng) for _ in range(3)])
    src, dst = _handles(rng, images.shape[1:3])
    src, dst = np.stack([src] * 3), np.stack([dst] * 3)
    keypoints = rng.uniform(0, 40, (3, 5, 2))
    masks = (rng.random(images.shape[:3]) > 0.5).astype(np.uint8)
    for method in ("quads", "backward"):
        for interpolation in glmls.INTERPOLATIONS:
            glmls.warp_batch(images, src, dst, method=method, interpolation=interpolation, ctx=ctx)
            glmls.warp_batch(
                images,
                src,
                dst,
                keypoints=keypoints,
                masks=masks,
                method=method,
                interpolation=interpolation,
                ctx=ctx,
            )
    srcs = np.stack([_handles(rng, images.shape[1:3], spread=10.0)[0] for _ in range(3)])
    glmls.warp_batch(images, srcs, srcs + rng.normal(0, 10, srcs.shape), ctx=ctx)
    glmls.warp_batch(images, src, dst, max_batch_bytes=images[0].nbytes * 2, ctx=ctx)
    glmls.warp_batch(images, src, dst, method="backward", border="edge", ctx=ctx)


def mls3(ctx, rng):
    src, dst = _handles(rng, (30, 30, 30), count=9, spread=2.0)
    with glmls.MLS(src, dst, ctx=ctx) as m:
        points = rng.uniform(0, 30, (200, 3))
        m(points)
        m.jacobian(points)
        m.inverse(points)
        vertices = rng.uniform(0, 30, (300, 3))
        faces = rng.integers(0, 300, (500, 3))
        m.deform((vertices, faces))
        m.deform(vertices)


def volume(ctx, rng):
    shape = (11, 9, 13)
    src, dst = _handles(rng, shape, count=7, spread=1.5)
    volume = (rng.random(shape) * 255).astype(np.uint8)
    colour = rng.random((*shape, 3)).astype(np.float32)
    small = SlabOptions(slab_bytes=3000, band_bytes=40000)
    narrow = SlabOptions(slab_bytes=2000, band_bytes=12000, texture_bytes=16000)
    with glmls.MLS(src, dst, shape=shape, ctx=ctx) as m:
        for method in ("quads", "backward"):
            for interpolation in glmls.INTERPOLATIONS:
                for border in ("constant", "edge", "wrap"):
                    options = dict(method=method, interpolation=interpolation, border=border)
                    m.warp(volume, **options)
                    m.warp(volume, **options, slabs=small)
                m.warp(colour, method=method, interpolation=interpolation, slabs=narrow)
        m.warp(volume, grid=2, interpolation="linear", slabs=small)
        m.warp(volume, method="backward", output_shape=(8, 12, 10), slabs=small)
        m.coordinate_map(shape)


#: The window's frames under the tracer (run by :func:`window` under xvfb-run).
WINDOW = """
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from barrier_trace import tracing
from glmls.app.controller import BINDINGS
from glmls.app.events import Key, Wait
from glmls.app.volume_controller import VOLUME_BINDINGS
from glmls.app.volume_window import VolumeApp
from glmls.app.window import App
from glmls.gl.context import GLContext

GLContext.piece_pixels = property(lambda self: 0)  # a GPU's commands

image = np.zeros((40, 60, 3), np.uint8)
image[10:30, 20:40] = 255
src = np.array([[15.0, 12.0], [45.0, 12.0], [30.0, 30.0]])
volume = np.zeros((12, 16, 20), np.float32)
volume[3:9, 4:12, 5:15] = 1.0
src3 = np.array([[5.0, 5.0, 4.0], [14.0, 10.0, 6.0], [10.0, 8.0, 8.0]])
with tracing() as tracer:
    for which in ("image", "volume"):
        out = sys.argv[2]
        if which == "image":
            app = App(image, src, src + [2.0, 1.0], name="image", out_dir=out)
            bindings = BINDINGS
        else:
            app = VolumeApp(volume, src3, src3 + 1.0, name="volume", out_dir=out)
            bindings = VOLUME_BINDINGS
        keys = [key for keys, _, _ in bindings for key in keys if key not in ("q", "Escape", "S")]
        events = [e for key in keys for e in (Key(key), Wait(2))]
        app.run(events=events, frames=2 * len(events) + 2)
print("commands", tracer.commands, "hazards", len(tracer.hazards))
print(tracer.report())
"""


def window(ctx, rng) -> int:
    """Both windows through every key, in a child process under xvfb-run (the window's own
    context); returns the hazards it met."""
    import shutil
    import subprocess
    import tempfile

    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        print("window: xvfb-run is not installed, not run")
        return
    tests = str(Path(__file__).resolve().parent.parent / "tests")
    with tempfile.TemporaryDirectory() as folder:
        done = subprocess.run(
            [xvfb, "-a", sys.executable, "-c", WINDOW, tests, folder],
            capture_output=True, text=True, timeout=900,
        )  # fmt: skip
    print(done.stdout.strip() or done.stderr[-2000:])
    found = [line for line in done.stdout.splitlines() if line.startswith("commands ")]
    return int(found[-1].split()[-1]) if found else 1


WORKLOADS = {
    "warp": warps,
    "banded": banded_warps,
    "mls_points": mls_points,
    "handles": handles_and_storages,
    "batch": batch,
    "mls3": mls3,
    "volume": volume,
    "window": window,
}


def main(argv: list[str]) -> int:
    pieces = "--pieces" in argv
    argv = [a for a in argv if a != "--pieces"]
    dropped = tuple(argv[k + 1] for k, a in enumerate(argv) if a == "--drop")
    argv = [a for k, a in enumerate(argv) if a != "--drop" and (k == 0 or argv[k - 1] != "--drop")]
    chosen = [name for name in WORKLOADS if not argv or any(a in name for a in argv)]
    ctx = glmls.gl.create_headless()
    if not pieces:
        ctx.piece_pixels = 0
    met = 0
    try:
        for name in chosen:
            rng = np.random.default_rng(7)
            started = time.perf_counter()
            with tracing(dropped) as tracer:
                try:
                    met += WORKLOADS[name](ctx, rng) or 0
                except Exception as error:  # the survey goes on: say what failed
                    print(f"{name}: failed: {error!r}")
                    met += 1
            seconds = time.perf_counter() - started
            count = len(tracer.hazards)
            print(f"== {name}: {tracer.commands} commands, {count} hazards, {seconds:.1f} s")
            if tracer.hazards:
                print(tracer.report())
            met += len(tracer.hazards)
    finally:
        ctx.release()
    return 1 if met else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
