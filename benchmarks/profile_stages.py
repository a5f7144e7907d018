"""Where a frame's time goes: each GPU stage of the quads pipeline timed on its own.

``python benchmarks/profile_stages.py [--size 1024] [--handles 64] [--storage ubo]``

Every stage is followed by ``ctx.finish()`` (so the stages do not overlap as they do in a real
frame): mesh evaluation (mls/points.comp.glsl), a whole frame by compute scan conversion
(warp/cells.comp.glsl writing the colours of an 8-bit image, fold-overs fixed up by
warp/cells_fixup.comp.glsl; first without keys where the mesh is an embedding), the same
frame with the keyed scan only, the same frame with the GL rasterizer drawing two triangles per
cell, and ``m.warp`` (numpy in and out). Each path is a pipeline with its own
:class:`~glmls.imaging.options.PipelineOptions`. Median and min of ``--repeat`` runs, ms.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
from glmls.cli.bench.cases import make_inputs
from glmls.core.mesh import MeshLattice
from glmls.engine.passes import evaluate_lattice
from glmls.imaging.options import PipelineOptions
from glmls.imaging.source import prepare_image


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
    gl = m.ctx
    paths = {
        "frame, compute scan conversion": glmls.gl.WarpPipeline.of(gl),
        "frame, keyed scan only        ": glmls.gl.WarpPipeline(
            gl, options=PipelineOptions(fast_embedded=False)
        ),
        "frame, GL rasterizer          ": glmls.gl.WarpPipeline(
            gl, options=PipelineOptions(compute_quads=False)
        ),
    }
    with gl:
        run(args, m, gl, image, shape, paths)
    for name, pipe in paths.items():
        if not name.startswith("frame, compute"):
            pipe.release()
    m.release()


def run(args, m, gl, image, shape, paths) -> None:
    limit = paths["frame, compute scan conversion"].max_image_size
    prepared = prepare_image(image, limit, normalized=True)
    target = gl.mgl.texture((args.size, args.size), 4, dtype="f1")
    framebuffer = gl.mgl.framebuffer(color_attachments=[target])
    mesh = gl.mgl.buffer(reserve=MeshLattice.corners(shape, 1).count * 8)

    for grid in (1, 4, 8):
        lattice = MeshLattice.corners(shape, grid)
        print(f"grid {grid}:")
        print(
            "  mesh (MLS at every vertex)    ",
            timed(gl.mgl, lambda lat=lattice: evaluate_lattice(m.kernel, lat, mesh), args.repeat),
        )
        for name, pipe in paths.items():
            source = pipe.upload(prepared, "profile")

            def frame(pipe=pipe, source=source, grid=grid) -> None:
                framebuffer.use()
                framebuffer.viewport = (0, 0, args.size, args.size)
                pipe.clear(framebuffer)
                pipe.render(m, source, framebuffer, grid=grid)

            print(f"  {name}", timed(gl.mgl, frame, args.repeat))
        print(
            "  m.warp (numpy in and out)     ",
            timed(gl.mgl, lambda g=grid: m.warp(image, grid=g), args.repeat),
        )
    for obj in (mesh, framebuffer, target):
        obj.release()


if __name__ == "__main__":
    main()
