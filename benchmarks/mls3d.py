"""The 3D MLS on the GPU: the points pass (f, and f with the Jacobian) and ``m.deform`` of a
mesh, with N random handles in a 256^3 volume.

``python benchmarks/mls3d.py [--handles 64] [--points 1000000] [--transform rigid] [--repeat 3]
[--targets moved|plane] [--deform-only]``

Prints the best of ``--repeat`` calls after an untimed one: seconds and millions of points per
second for ``m(points)`` (one dispatch, one read-back), ``m.jacobian(points)`` (f and J, the
solve's derivative: f, then one pass over the handles per axis) and ``m.deform`` of a mesh
with that many vertices (f, J, the normals and the folds, all on the GPU), and for
comparison the float64 numpy reference of the normals and folds from the same f and J
(``glmls.core.mesh3.deform_mesh``). The targets are the handles moved by N(0, 8) voxels
(``--targets moved``) or projected onto a plane turned off the axes through the volume's
centre (``--targets plane``: with ``--transform affine`` f flattens the mesh, and the exact
flat rule of ``m.deform`` applies). ``--deform-only`` times ``m.deform`` alone and prints
each call's time and their median (for A/B runs against another checkout: ``PYTHONPATH``),
with, where the kernel's targets are coplanar and the transform affine, the host time of
the exact flat rule on the same arrays (the flags read back and det J set to 0 there).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import glmls
from glmls.core.mesh3 import deform_mesh


def best(call, repeat: int) -> float:
    call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return min(times)


def grid_mesh(count: int) -> tuple[np.ndarray, np.ndarray]:
    """A wavy sheet of about ``count`` vertices across the volume, two triangles per cell."""
    side = int(np.sqrt(count))
    y, x = np.mgrid[0:side, 0:side] * (250.0 / side) + 3.0
    z = 128.0 + 40.0 * np.sin(x / 30.0) * np.cos(y / 40.0)
    vertices = np.stack([x, y, z], -1).reshape(-1, 3)
    index = np.arange(side * side).reshape(side, side)
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]
    faces = np.concatenate([np.stack([a, b, d], -1), np.stack([a, d, c], -1)]).reshape(-1, 3)
    return vertices, faces


def flat_rule(m, count: int, repeat: int) -> list[float]:
    """The host time of the exact flat rule after ``m.deform`` of ``count`` vertices: the
    flags' read-back from their buffer and det J set to 0 where they are set."""
    flags = m.kernel.scratch.cached("flat3")
    det = np.ones(count)
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        with m.kernel.gl.use():
            plain = np.frombuffer(flags.read(size=count * 4), np.uint32) != 0
        det[plain] = 0.0
        times.append(time.perf_counter() - start)
    return times


def deform_only(m, vertices, faces, repeat: int) -> None:
    """Each ``m.deform`` call's time after an untimed one, and their median."""
    m.deform((vertices, faces))
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        m.deform((vertices, faces))
        times.append(time.perf_counter() - start)
    shown = " ".join(f"{t:.3f}" for t in times)
    print(f"  deform median {np.median(times):.3f} s ({shown})")
    if getattr(m.kernel, "flat", False):
        rule = flat_rule(m, len(vertices), repeat)
        shown = " ".join(f"{t * 1e3:.2f}" for t in rule)
        print(f"  exact flat rule median {np.median(rule) * 1e3:.2f} ms ({shown})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--handles", type=int, default=64)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--transform", default="rigid", choices=glmls.TRANSFORMS)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--targets", default="moved", choices=("moved", "plane"))
    parser.add_argument("--deform-only", action="store_true")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    src = rng.uniform(0, 256, (args.handles, 3))
    dst = src + rng.normal(0, 8, src.shape)
    if args.targets == "plane":
        normal = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
        dst = src - np.outer(src @ normal - 128.0, normal)
    points = rng.uniform(0, 256, (args.points, 3))
    vertices, faces = grid_mesh(args.points)
    with glmls.MLS(src, dst, transform=args.transform, shape=(256, 256, 256)) as m:
        if args.deform_only:
            print(
                f"{args.handles} handles, {args.transform}, targets {args.targets}, mesh of "
                f"{len(vertices):,} vertices and {len(faces):,} faces"
            )
            deform_only(m, vertices, faces, args.repeat)
            return
        rows = {
            "f": best(lambda: m(points), args.repeat),
            "f and J": best(lambda: m.jacobian(points), args.repeat),
            "deform": best(lambda: m.deform((vertices, faces)), args.repeat),
        }
        _, jacobian = m.jacobian(vertices)
    deformed = vertices.copy()

    def reference() -> None:
        deform_mesh(vertices, faces, None, deformed, jacobian)

    rows["numpy reference"] = best(reference, args.repeat)
    print(
        f"{args.handles} handles, {args.transform}, {len(points):,} points, mesh of "
        f"{len(vertices):,} vertices and {len(faces):,} faces"
    )
    for name, seconds in rows.items():
        print(f"  {name:18s} {seconds:7.3f} s  {len(points) / seconds / 1e6:6.2f} M points/s")


if __name__ == "__main__":
    main()
