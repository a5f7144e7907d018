"""Where a frame's time goes: each GPU stage of the quads pipeline timed on its own.

``python benchmarks/profile_stages.py [--size 1024] [--handles 64] [--storage ubo]``

Every stage is followed by ``ctx.finish()`` (so the stages do not overlap as they do in a real
frame): mesh evaluation (mls_points.comp.glsl), a whole frame by compute scan conversion
(warp_cells.comp.glsl writing the colours of an 8-bit image, fold-overs fixed up by
warp_cells_fixup.comp.glsl; first without keys where the mesh is an embedding), the same
frame with the keyed scan only, the same frame with the GL rasterizer drawing two triangles per
cell, and ``m.warp`` (numpy in and out). Median and min of ``--repeat`` runs, milliseconds.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
import glmls.pipeline as pipeline
from glmls.bench_cases import make_inputs


def timed(gl, step, repeat: int) -> str:
    step()
    gl.finish()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        step()
        gl.finish()
        times.append(time.perf_counter() - start)
    return f"{np.median(times) * 1e3:8.1f} ms (min {min(times) * 1e3:.1f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--handles", type=int, default=64)
    parser.add_argument("--storage", default="ubo", choices=("ssbo", "ubo", "texture"))
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    image, src, dst = make_inputs(args.size, args.handles)
    shape = image.shape[:2]
    m = glmls.MLS(src, dst, shape=shape, storage=args.storage)
    gl = m.ctx.mgl
    pipe = m._warp_pipeline()
    source = pipe.upload(pipeline.prepare_image(image, pipe.max_image_size, normalized=True))
    framebuffer = pipe._framebuffer("profile", (args.size, args.size), "f1")

    n = args.repeat
    for grid in (1, 4, 8):

        def frame(grid: int = grid) -> None:
            framebuffer.use()
            framebuffer.viewport = (0, 0, args.size, args.size)
            framebuffer.clear()
            pipe.render(m, source, framebuffer, grid=grid)

        print(f"grid {grid}:")
        print(
            "  mesh (MLS at every vertex)",
            timed(gl, lambda g=grid: list(pipe._mesh_bands(m, shape, g, centres=False)), n),
        )
        print("  frame, compute scan conversion", timed(gl, frame, args.repeat))
        pipeline.FAST_EMBEDDED = False
        print("  frame, keyed scan only       ", timed(gl, frame, args.repeat))
        pipeline.FAST_EMBEDDED = True
        pipeline.COMPUTE_QUADS = False
        print("  frame, GL rasterizer        ", timed(gl, frame, args.repeat))
        pipeline.COMPUTE_QUADS = True
        print(
            "  m.warp (numpy in and out)   ",
            timed(gl, lambda g=grid: m.warp(image, grid=g), args.repeat),
        )
    m.release()


if __name__ == "__main__":
    main()
