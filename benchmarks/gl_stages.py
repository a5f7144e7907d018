"""Where the time of a volume warp, a batch or a mesh deformation goes: GPU time per shader,
transfers, and the host's own time.

``python benchmarks/gl_stages.py volume [--size 256] [--method quads|backward] [--grid 1]``
``python benchmarks/gl_stages.py batch [--n 256] [--size 224] [--keypoints] [--move 5.6]
[--one-scan] [--interpolation nearest|linear] [--border constant|edge|reflect|...]``
``python benchmarks/gl_stages.py augment [--preset grid|text-distort|...] [--n 256] [--keypoints]``
``python benchmarks/gl_stages.py mesh [--vertices 1000000] [--surface random|torus]``

Each compute dispatch is followed by ``ctx.finish()`` and timed, and so is each buffer and
texture read and write, so the GPU stages do not overlap as they do in a normal run: the sum
is at least the normal run's time (also printed, measured first without the finishes). Each
stage's CPU time (the process's, all its threads: on llvmpipe the GPU's work) is printed
beside its wall time: on a shared host it changes less with the other processes' load. The
rest is the host's (Python, numpy, driver calls): the top host functions by own time follow
(cProfile). Workloads: 64 handles (16 for a batch), rigid idw (seed 0); the volume as in
``volume_bench.py``, the batch as in ``batch_bench.py`` (224 x 224 RGB, grid 4; the handles
moved by N(0, ``--move`` px), size / 40 by default), the augmentation ``Augment(preset,
seed=0)`` with its defaults on the batch's images (32 x 128 text crops for the ``text-``
presets; ``--keypoints``: 20 keypoints and a mask per image, which ``landmarks`` moves), the mesh
points uniform in a 256^3 box with twice as many faces joining random vertices (``--surface
random``: every face's corners far apart in memory, the worst case for the passes over faces)
or a torus in the same box whose vertices and faces follow its n x n lattice (``--surface
torus``, n^2 about ``--vertices``: a surface as a modeller or a scanner writes it).
"""

from __future__ import annotations

import argparse
import collections
import cProfile
import io
import pstats
import sys
import time
from pathlib import Path

import moderngl
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
from glmls.gl.context import GLContext

_names: dict[int, str] = {}
_totals: collections.Counter = collections.Counter()
_counts: collections.Counter = collections.Counter()
#: The process's CPU time (all its threads: llvmpipe's too) per stage.
_cpu: collections.Counter = collections.Counter()


def _instrument() -> None:
    compute = GLContext.compute

    def tagged(self, entry, defines=None):
        program = compute(self, entry, defines)
        _names[id(program)] = entry
        return program

    GLContext.compute = tagged

    def timing(label, method):
        def run(self, *args, **kwargs):
            ctx = self.ctx
            ctx.finish()
            start, cpu = time.perf_counter(), time.process_time()
            result = method(self, *args, **kwargs)
            ctx.finish()
            name = label(self, args)
            _totals[name] += time.perf_counter() - start
            _cpu[name] += time.process_time() - cpu
            _counts[name] += 1
            return result

        return run

    for method in ("run", "run_indirect"):  # indirect: dispatches sized on the GPU
        setattr(
            moderngl.ComputeShader,
            method,
            timing(
                lambda p, _: "gpu " + _names.get(id(p), "?"),
                getattr(moderngl.ComputeShader, method),
            ),
        )

    def transfer(cls, method):
        # a write from a buffer is a copy on the GPU side; from host memory, an upload
        def label(_, args):
            given = args[0] if args else None
            return f"{method} {cls.__name__}" + (
                " from a buffer" if isinstance(given, moderngl.Buffer) else ""
            )

        return label

    for cls in (moderngl.Buffer, moderngl.Texture, moderngl.Texture3D, moderngl.TextureArray):
        for method in ("read", "write", "read_into"):
            if hasattr(cls, method):
                setattr(cls, method, timing(transfer(cls, method), getattr(cls, method)))
    for method in ("read", "read_into"):
        original = getattr(moderngl.Framebuffer, method)
        setattr(
            moderngl.Framebuffer, method, timing(transfer(moderngl.Framebuffer, method), original)
        )
    # draws (the fill from the keys, splats): the GPU's time of the rasterizer's passes
    render = moderngl.VertexArray.render
    moderngl.VertexArray.render = timing(lambda _, __: "draw VertexArray", render)


def volume_workload(args):
    rng = np.random.default_rng(0)
    size = args.size
    volume = rng.integers(0, 255, (size,) * 3, dtype=np.uint8)
    src = rng.uniform(0, size - 1, (64, 3))
    dst = src + rng.normal(0, size / 40, src.shape)
    m = glmls.MLS(src, dst, transform="rigid", weight="idw")
    interpolation = "linear" if args.method == "backward" else "nearest"
    grid = 1 if args.grid is None else args.grid
    options = {"method": args.method, "grid": grid, "interpolation": interpolation}
    m.warp(volume[:16, :16, :16], **options)
    settings = {"volume": (size,) * 3, "handles": 64, "transform": "rigid", **options}
    return (lambda: m.warp(volume, **options)), settings


def batch_workload(args):
    if args.one_scan:
        from glmls.batch import texels

        texels.FAST_PASS = False
    rng = np.random.default_rng(0)
    n, size = args.n, args.size
    images = rng.integers(0, 255, (n, size, size, 3), dtype=np.uint8)
    src = rng.uniform(0, size - 1, (n, 16, 2))
    dst = src + rng.normal(0, size / 40 if args.move is None else args.move, src.shape)
    labels = {}
    if args.keypoints:
        labels["keypoints"] = rng.uniform(0, size - 1, (n, 3, 2))
        labels["masks"] = rng.integers(0, 4, (n, size, size), dtype=np.uint8)
    grid = 4 if args.grid is None else args.grid
    options = {"grid": grid, "interpolation": args.interpolation, "border": args.border}
    glmls.warp_batch(
        images[:2], src[:2], dst[:2], **options, **{k: v[:2] for k, v in labels.items()}
    )
    settings = {"n": n, "size": (size, size), "handles": 16, **options}
    settings["labels"] = "3 keypoints and a mask" if args.keypoints else "none"
    return (lambda: glmls.warp_batch(images, src, dst, **options, **labels)), settings


def augment_workload(args):
    from glmls.augment import Augment

    rng = np.random.default_rng(0)
    height, width = (32, 128) if args.preset.startswith("text") else (args.size, args.size)
    images = rng.integers(0, 255, (args.n, height, width, 3), dtype=np.uint8)
    labels = {}
    if args.keypoints or args.preset == "landmarks":
        labels["keypoints"] = rng.uniform(0, 1, (args.n, 20, 2)) * (width - 1, height - 1)
        labels["masks"] = rng.integers(0, 4, (args.n, height, width), dtype=np.uint8)
    augment = Augment(args.preset, seed=0)
    augment(images[:2], **{k: v[:2] for k, v in labels.items()})
    settings = {"preset": args.preset, "n": args.n, "size": (height, width)}
    settings["warp"] = augment.warp_options  # the preset's own: grid, sampling, border
    settings["labels"] = "20 keypoints and a mask" if labels else "none"
    return (lambda: augment(images, **labels)), settings


def torus(n: int) -> tuple[np.ndarray, np.ndarray]:
    """An n x n lattice on a torus in the 256^3 box: vertices in lattice order, two faces per
    cell, outward."""
    angle = np.arange(n) * (2 * np.pi / n)
    u, v = np.meshgrid(angle, angle, indexing="ij")
    ring = 80 + 40 * np.cos(v)
    vertices = np.stack([128 + ring * np.cos(u), 128 + ring * np.sin(u), 128 + 40 * np.sin(v)])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a, b = i * n + j, i * n + (j + 1) % n
    c, d = ((i + 1) % n) * n + j, ((i + 1) % n) * n + (j + 1) % n
    faces = np.concatenate([np.stack([a, c, d], -1), np.stack([a, d, b], -1)], axis=1)
    return vertices.reshape(3, -1).T, faces.reshape(-1, 3)


def mesh_workload(args):
    rng = np.random.default_rng(0)
    if args.surface == "torus":
        vertices, faces = torus(round(args.vertices**0.5))
    else:
        vertices = rng.uniform(0, 255, (args.vertices, 3))
        faces = rng.integers(0, args.vertices, (2 * args.vertices, 3))
    src = rng.uniform(0, 255, (64, 3))
    dst = src + rng.normal(0, 6, src.shape)
    m = glmls.MLS(src, dst, transform="rigid", weight="idw")
    m.deform(glmls.Mesh(vertices[:100], faces[:100] % 100))
    mesh = glmls.Mesh(vertices, faces)
    settings = {"surface": args.surface, "vertices": len(vertices), "faces": len(faces)}
    settings.update(handles=64, transform="rigid")
    return (lambda: m.deform(mesh)), settings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("workload", choices=("volume", "batch", "augment", "mesh"))
    parser.add_argument("--size", type=int, default=None)
    parser.add_argument("--method", default="quads", choices=("quads", "backward"))
    parser.add_argument(
        "--grid",
        type=int,
        default=None,
        help="volume: 1, batch: 4 unless given (augment: its preset's)",
    )
    parser.add_argument("--n", type=int, default=256)
    parser.add_argument(
        "--keypoints",
        action="store_true",
        help="batch: three keypoints and a mask per image; augment: 20 and a mask",
    )
    parser.add_argument(
        "--move", type=float, default=None, help="batch: the handles' move, px (size / 40)"
    )
    parser.add_argument(
        "--one-scan",
        action="store_true",
        help="batch: one scan program for every image (glmls.batch.texels.FAST_PASS off)",
    )
    parser.add_argument("--interpolation", default="nearest", choices=glmls.INTERPOLATIONS)
    parser.add_argument("--border", default="constant", choices=glmls.BORDERS)
    parser.add_argument(
        "--preset",
        default="grid",
        choices=sorted(glmls.augment.PRESETS),
        help="augment: the Augment preset (text-*: text crops)",
    )
    parser.add_argument("--vertices", type=int, default=1_000_000)
    parser.add_argument("--surface", default="random", choices=("random", "torus"))
    parser.add_argument("--top", type=int, default=12)
    args = parser.parse_args()
    if args.size is None:
        args.size = 224 if args.workload in ("batch", "augment") else 256
    workloads = {
        "volume": volume_workload,
        "batch": batch_workload,
        "augment": augment_workload,
        "mesh": mesh_workload,
    }
    step, settings = workloads[args.workload](args)
    step()
    start = time.perf_counter()
    step()
    normal = time.perf_counter() - start
    _instrument()
    step()  # compiles nothing new; warms the wrappers
    _totals.clear()
    _counts.clear()
    _cpu.clear()
    profile = cProfile.Profile()
    start, cpu = time.perf_counter(), time.process_time()
    profile.enable()
    step()
    profile.disable()
    staged, staged_cpu = time.perf_counter() - start, time.process_time() - cpu
    print(f"{args.workload}: {settings}")
    print(
        f"normal run {normal * 1e3:9.1f} ms; a finish after each stage {staged * 1e3:9.1f} ms "
        f"({staged_cpu * 1e3:.1f} ms CPU)"
    )
    print("       wall        CPU  calls  stage")
    for name, total in _totals.most_common():
        print(f"  {total * 1e3:9.1f} {_cpu[name] * 1e3:9.1f} ms  {_counts[name]:5d}x  {name}")
    rest, rest_cpu = staged - sum(_totals.values()), staged_cpu - sum(_cpu.values())
    print(f"  {rest * 1e3:9.1f} {rest_cpu * 1e3:9.1f} ms         host (the rest)")
    text = io.StringIO()
    pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(args.top)
    print("\n".join(line for line in text.getvalue().splitlines() if line.strip())[-4000:])


if __name__ == "__main__":
    main()
