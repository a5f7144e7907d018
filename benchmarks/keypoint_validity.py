"""Host time of the keypoint validity test of ``warp_batch`` (``keypoints_valid`` of the
methods whose keypoints move by f: ``backward``, ``splat``, ``paper-quads``), per image:
:func:`glmls.batch.labels.visible` called image by image against one
:func:`~glmls.batch.labels.visible_chunk` for the whole chunk, on a chunk of synthetic
canvases (each image's map affine, its canvas the inverse map's source points with noise,
5 % of the pixels uncovered).

``python benchmarks/keypoint_validity.py [--images 64] [--keypoints 20] [--size 224]
[--repeat 41]``: the median over ``--repeat`` chunks of each, in ms per image, the forms
alternated, and whether their flags agree.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from glmls.batch.labels import visible, visible_chunk


def chunk(images: int, keypoints: int, size: int, seed: int = 0) -> dict[str, np.ndarray]:
    """The chunk's concatenated keypoints and their images' canvases."""
    rng = np.random.default_rng(seed)
    maps = np.eye(2) + rng.normal(0.0, 0.05, (images, 2, 2))
    centre = (size - 1) / 2
    yy, xx = np.mgrid[0:size, 0:size]
    grid = np.stack([xx, yy], axis=-1).astype(np.float64) - centre
    coords = np.einsum("hwi,nij->nhwj", grid, np.linalg.inv(maps)) + centre
    coords += rng.normal(0.0, 0.3, coords.shape)
    points = rng.uniform(0.0, size - 1.0, (images * keypoints, 2))
    which = np.repeat(np.arange(images), keypoints)
    jacobian = maps[which]
    out = np.einsum("pi,pij->pj", points - centre, jacobian) + centre
    return {
        "points": points,
        "images": which,
        "out": out,
        "jacobian": jacobian,
        "coords": coords.astype(np.float32),
        "covered": rng.random((images, size, size)) > 0.05,
        "inside": np.ones(len(points), bool),
    }


def per_image(c: dict[str, np.ndarray]) -> np.ndarray:
    flags = []
    for k in range(len(c["coords"])):
        mine = c["images"] == k
        flags.append(
            visible(
                c["points"][mine],
                c["out"][mine],
                c["jacobian"][mine],
                c["coords"][k],
                c["covered"][k],
                c["inside"][mine],
            )
        )
    return np.concatenate(flags)


def whole_chunk(c: dict[str, np.ndarray]) -> np.ndarray:
    return visible_chunk(
        c["points"], c["images"], c["out"], c["jacobian"], c["coords"], c["covered"], c["inside"]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--images", type=int, default=64)
    parser.add_argument("--keypoints", type=int, default=20)
    parser.add_argument("--size", type=int, default=224)
    parser.add_argument("--repeat", type=int, default=41)
    args = parser.parse_args()
    c = chunk(args.images, args.keypoints, args.size)
    a, b = per_image(c), whole_chunk(c)
    print(f"flags agree: {bool(np.array_equal(a, b))} ({int(b.sum())} of {len(b)} valid)")
    forms = {"visible per image": per_image, "visible_chunk": whole_chunk}
    times: dict[str, list[float]] = {name: [] for name in forms}
    for _ in range(args.repeat):
        for name, form in forms.items():
            start = time.perf_counter()
            form(c)
            times[name].append(time.perf_counter() - start)
    for name, spent in times.items():
        each = statistics.median(spent) / args.images * 1e3
        print(f"{name:18s} {each:.4f} ms/image ({args.images} images x {args.keypoints} keypoints)")


if __name__ == "__main__":
    main()
