"""The fixed cost of a call, stage by stage: what ``glmls.warp`` does besides the pixels.

``python benchmarks/fixed_cost.py [--size 512] [--handles 16] [--grid 4] [--repeat 200]``
``python benchmarks/fixed_cost.py --lattice 256 --size 1024 --weight cressman --radius 24``

Each stage of ``glmls.warp(image, src, dst, transform=..., grid=...)`` is run on its own, in
order, ``--repeat`` times; the GPU stages end with ``ctx.finish()`` so that their time is
theirs (in a real call they overlap and only the read-back waits). Median and minimum, ms:

- ``config``: :class:`glmls.MLSConfig`; ``validation``: :meth:`HandleSet.validate`;
  ``scaling``: :meth:`Scaling.fit`; ``kernel``: a new :class:`MLSKernel` (its options);
- ``upload``: :meth:`MLSKernel.upload` (storage choice, packing, bins, buffer writes);
- ``program lookup``: the compiled mesh pass from the context's cache, and ``bind`` (its
  uniforms, the handles and bins bound);
- ``image check``: :func:`prepare_image`; ``texture upload``: the source texture written;
- ``target``: the cached target framebuffer, bound and cleared;
- ``mesh pass``: f at the vertices (``mls/points.comp.glsl``), alone;
- ``render``: the whole quads construction (:meth:`WarpPipeline.render`, the mesh included);
- ``read-back``: the target read into numpy; ``restore``: back to the caller's layout;
- ``release``: the MLS's GPU objects freed;

then the whole ``glmls.warp``, ``MLS(...)`` alone, ``m.warp`` alone, and an interactive frame
(a new MLS, the image drawn into a kept 8-bit framebuffer, ``finish``; no read-back, as
``glmls bench --mode frame`` times it). With ``--lattice K`` the handles are K x K points on
a lattice over the image moved by up to 2 px (the many-handles case of docs/performance.md).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
from glmls.cli.bench.cases import make_inputs
from glmls.core.config import MLSConfig
from glmls.core.handles import Scaling
from glmls.core.handleset import HandleSet
from glmls.core.mesh import MeshLattice
from glmls.engine.kernel import MLSKernel
from glmls.engine.passes import evaluate_lattice, points_program
from glmls.gl.context import get_context
from glmls.gl.resources import Resources
from glmls.imaging.pipeline import WarpPipeline
from glmls.imaging.source import prepare_image


def lattice_inputs(size: int, side: int, seed: int = 0) -> tuple[np.ndarray, ...]:
    """A random RGB size x size image and side x side handles on a lattice over it, each
    moved by up to 2 px."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 256, (size, size, 3), dtype=np.uint8)
    axis = (np.arange(side) + 0.5) * size / side - 0.5
    src = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
    dst = src + rng.uniform(-2, 2, src.shape)
    return image, src, dst


def median_ms(step: Callable[[], object], repeat: int, finish: Callable[[], None]) -> tuple:
    step()
    finish()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        step()
        finish()
        times.append(time.perf_counter() - start)
    return float(np.median(times)) * 1e3, float(np.min(times)) * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--handles", type=int, default=16)
    parser.add_argument("--lattice", type=int, default=0, help="K x K lattice handles")
    parser.add_argument("--grid", type=int, default=4)
    parser.add_argument("--transform", default="rigid")
    parser.add_argument("--weight", default="idw")
    parser.add_argument("--radius", type=float, default=None)
    parser.add_argument("--repeat", type=int, default=200)
    args = parser.parse_args()
    if args.lattice:
        image, src, dst = lattice_inputs(args.size, args.lattice)
    else:
        image, src, dst = make_inputs(args.size, args.handles)
    shape = image.shape[:2]
    options = {"transform": args.transform, "weight": args.weight, "radius": args.radius}
    gl = get_context()
    pipe = WarpPipeline.of(gl)
    mgl = gl.mgl
    resources = Resources(gl, "fixed_cost.py")

    def finish() -> None:
        with gl:
            mgl.finish()

    print(
        f"{args.size}^2 image, {len(src)} handles, {args.transform} {args.weight}"
        f"{'' if args.radius is None else f' R={args.radius:g}'}, grid {args.grid}, "
        f"median (min) of {args.repeat}, ms"
    )
    # -- stage by stage ------------------------------------------------------------------
    state: dict[str, object] = {}
    lattice = MeshLattice.corners(shape, args.grid)

    def config() -> None:
        state["config"] = MLSConfig(**options)
        state["config"].resolve_radius(shape)  # type: ignore[attr-defined]

    def validation() -> None:
        state["handles"] = HandleSet.validate(src, dst)

    def scaling() -> None:
        h = state["handles"]
        state["scaling"] = Scaling.fit(h.source_points(), h.target_points(), shape)  # type: ignore[attr-defined]

    def kernel() -> None:
        state["kernel"] = MLSKernel(gl, state["config"], shape=shape)  # type: ignore[arg-type]

    def upload() -> None:
        state["kernel"].upload(state["handles"], state["scaling"])  # type: ignore[attr-defined]

    def program() -> None:
        k = state["kernel"]
        with gl:
            p = points_program(k, lattice=True, with_matrix=False)  # type: ignore[arg-type]
            k.bind(p, shape)  # type: ignore[attr-defined]

    def image_check() -> None:
        state["source"] = prepare_image(image, pipe.max_image_size, normalized=True)

    def texture() -> None:
        state["texture"] = pipe.upload(state["source"], "fixed cost")  # type: ignore[arg-type]

    def target() -> None:
        with gl:
            fb = resources.framebuffer("fixed cost target", image.shape[1::-1], "f1")
            fb.use()
            fb.viewport = (0, 0, *image.shape[1::-1])
            fb.clear()
            state["fb"] = fb

    with gl:
        mesh = resources.buffer("fixed cost mesh", lattice.count * 8)

    def mesh_pass() -> None:
        evaluate_lattice(state["kernel"], lattice, mesh)  # type: ignore[arg-type]

    deformation = glmls.MLS(src, dst, shape=shape, **options)  # type: ignore[arg-type]

    def render() -> None:
        deformation._kernel = state["kernel"]  # type: ignore[assignment]
        fb = state["fb"]
        pipe.render(deformation, state["texture"], fb, grid=args.grid)  # type: ignore[arg-type]

    def read_back() -> None:
        with gl:
            fb = state["fb"]
            state["raw"] = fb.read(components=3, dtype="f1")  # type: ignore[attr-defined]

    def restore() -> None:
        values = np.frombuffer(state["raw"], np.uint8).reshape(*shape, 3)  # type: ignore[call-overload]
        state["out"] = state["source"].restore(values)  # type: ignore[attr-defined]

    def release() -> None:
        k = MLSKernel(gl, state["config"], shape=shape)  # type: ignore[arg-type]
        k.upload(state["handles"], state["scaling"])  # type: ignore[arg-type]
        start = time.perf_counter()
        k.release()
        state["release"] = time.perf_counter() - start

    stages = {
        "config": config,
        "validation": validation,
        "scaling": scaling,
        "kernel": kernel,
        "upload (storage, bins)": upload,
        "program lookup + bind": program,
        "image check": image_check,
        "texture upload": texture,
        "target (cached) + clear": target,
        "mesh pass": mesh_pass,
        "render (mesh + quads)": render,
        "read-back": read_back,
        "restore (numpy)": restore,
    }
    for step in stages.values():
        step()
    finish()
    total = 0.0
    for name, step in stages.items():
        med, low = median_ms(step, args.repeat, finish)
        total += med if name != "mesh pass" else 0.0
        print(f"  {name:26s} {med:8.3f} ({low:.3f})")
    releases = []
    for _ in range(max(args.repeat // 4, 5)):
        release()
        releases.append(state["release"])
    rel = float(np.median(releases)) * 1e3  # type: ignore[arg-type]
    total += rel
    print(f"  {'release':26s} {rel:8.3f}")
    print(f"  {'sum (mesh pass in render)':26s} {total:8.3f}")
    state["kernel"].release()  # type: ignore[attr-defined]
    deformation._kernel = MLSKernel(gl, deformation.config, shape=shape)
    deformation.release()

    # -- whole calls ----------------------------------------------------------------------
    def e2e() -> None:
        glmls.warp(image, src, dst, grid=args.grid, **options)  # type: ignore[arg-type]

    def construct() -> None:
        glmls.MLS(src, dst, shape=shape, **options).release()  # type: ignore[arg-type]

    kept = glmls.MLS(src, dst, shape=shape, **options)  # type: ignore[arg-type]
    with gl:
        frame_target = mgl.texture(image.shape[1::-1], 4, dtype="f1")
        frame_fb = mgl.framebuffer(color_attachments=[frame_target])
    moves = np.random.default_rng(1).uniform(-2, 2, (64, *dst.shape))
    count = [0]

    def frame() -> None:
        count[0] += 1
        moved = dst + moves[count[0] % 64]
        with glmls.MLS(src, moved, ctx=gl, **options) as m, gl:  # type: ignore[arg-type]
            frame_fb.use()
            frame_fb.clear()
            pipe.render(m, state["texture"], frame_fb, grid=args.grid)  # type: ignore[arg-type]
            mgl.finish()

    for name, step in (
        ("glmls.warp (end to end)", e2e),
        ("MLS(...) + release", construct),
        ("m.warp", lambda: kept.warp(image, grid=args.grid)),
        ("frame (no read-back)", frame),
    ):
        med, low = median_ms(step, args.repeat, lambda: None)
        print(f"{name:28s} {med:8.3f} ({low:.3f})")
    kept.release()
    resources.release()
    with gl:
        frame_fb.release()
        frame_target.release()


if __name__ == "__main__":
    main()
