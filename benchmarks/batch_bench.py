"""Images per second of batched warps: glmls's ``warp`` in a loop, ``warp_batch``, and the
augmentation libraries' random deformations, on the data of model training.

``python benchmarks/batch_bench.py [--quick] [--batches 64 256] [--repeat 3] [--keypoints 20]
[--method quads] [--json out.json]``

Workloads (uint8, a random handle move per image):

- ``224``: 224 x 224 RGB, 16 handles on a jittered 4 x 4 lattice moved by N(0, 4 px);
- ``text``: 32 x 128 RGB text crops, 14 fiducial points (7 on the top edge, 7 on the
  bottom) moved by N(0, 2 px), the thin-plate-spline rectification setting.

For each workload and batch size: ``glmls.warp`` per image, ``glmls.warp_batch`` (``quads``,
grid 4, nearest; ``--method`` another construction for both, ``paper-quads`` at grid 1)
without labels, and with ``--keypoints`` (20) keypoints and a uint8 mask per image, and
``glmls.augment.Augment`` with its defaults (``grid`` at 224 x 224, ``text-distort`` on text
crops: its own random handles, bilinear, the ``edge`` border) with the same labels; then,
where importable, the peers with keypoints and a mask per image (albumentations 2
``GridDistortion``, ``ElasticTransform``, ``ThinPlateSpline``, ``PiecewiseAffine``, each
``Compose``d with ``KeypointParams``), kornia's ``RandomThinPlateSpline`` on CPU tensors and
torchvision's v2 ``ElasticTransform`` on CPU (the peers, which work image by image, on
``--peer-images`` images of each workload). Each case: the median wall time of ``--repeat``
runs after one warm-up, as images per second, and the least CPU time of the process per
image (all its threads; steadier than wall time where other jobs share the machine).
Peak memory: ``warp_batch`` of the largest batch at 224 x 224 with labels, measured alone in a
fresh process (its ``VmHWM``, the whole footprint: Python, numpy, the GL driver, the batch's
input and output arrays). The threads: the CPU count, OpenCV's and torch's thread counts
and llvmpipe's ``LP_NUM_THREADS`` when set (``--peer-threads N`` caps OpenCV's and torch's
at N, as for a data loader's worker). ``--quick`` runs glmls alone at one batch of 64,
the median of three runs (``benchmarks/gpu_check.sh``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np

import glmls

KEYPOINTS = 20


def workload(
    name: str, count: int, seed: int = 0, keypoints: int = KEYPOINTS
) -> dict[str, np.ndarray]:
    """Images, handles, keypoints and masks of a workload (see the module docstring)."""
    rng = np.random.default_rng(seed)
    if name == "224":
        height, width = 224, 224
        axis = np.linspace(24, 200, 4)
        lattice = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
        src = lattice + rng.uniform(-8, 8, (count, 16, 2))
        dst = src + rng.normal(0, 4, src.shape)
    else:
        height, width = 32, 128
        xs = np.linspace(0, width - 1, 7)
        edge = np.r_[np.c_[xs, np.zeros(7)], np.c_[xs, np.full(7, height - 1.0)]]
        src = np.repeat(edge[None], count, 0)
        dst = src + rng.normal(0, 2, src.shape)
    images = rng.integers(0, 256, (count, height, width, 3), dtype=np.uint8)
    points = rng.uniform((0, 0), (width - 1, height - 1), (count, keypoints, 2))
    masks = rng.integers(0, 8, (count, height, width), dtype=np.uint8)
    return {"images": images, "src": src, "dst": dst, "keypoints": points, "masks": masks}


def glmls_cases(
    data: dict[str, np.ndarray], method: str = "quads"
) -> dict[str, Callable[[], object]]:
    from glmls.augment import Augment

    images, src, dst = data["images"], data["src"], data["dst"]
    # paper-quads fills squares of adjacent pixel centres: its only step is 1
    options = {"grid": 1 if method == "paper-quads" else 4, "method": method}
    # the augmentation users call: its own random handles, bilinear, the edge border
    augment = Augment("grid" if images.shape[1] == 224 else "text-distort", seed=0)
    return {
        "glmls warp (loop)": lambda: [
            glmls.warp(image, p, q, **options) for image, p, q in zip(images, src, dst, strict=True)
        ],
        "glmls warp_batch": lambda: glmls.warp_batch(images, src, dst, **options),
        "glmls warp_batch +kp +mask": lambda: glmls.warp_batch(
            images, src, dst, keypoints=data["keypoints"], masks=data["masks"], **options
        ),
        "glmls Augment +kp +mask": lambda: augment(
            images, keypoints=data["keypoints"], masks=data["masks"]
        ),
    }


def albumentations_cases(data: dict[str, np.ndarray]) -> dict[str, Callable[[], object]]:
    try:
        import albumentations as A
    except ImportError:
        return {}
    transforms = {
        "GridDistortion": A.GridDistortion(p=1.0),
        "ElasticTransform": A.ElasticTransform(p=1.0),
        "ThinPlateSpline": A.ThinPlateSpline(p=1.0),
        "PiecewiseAffine": A.PiecewiseAffine(p=1.0),
    }
    cases = {}
    for name, transform in transforms.items():
        pipeline = A.Compose(
            [transform], keypoint_params=A.KeypointParams(format="xy", remove_invisible=False)
        )

        def run(pipeline=pipeline):
            return [
                pipeline(image=image, mask=mask, keypoints=points)
                for image, mask, points in zip(
                    data["images"], data["masks"], data["keypoints"], strict=True
                )
            ]

        cases[f"albumentations {name} +kp +mask"] = run
    return cases


def torch_cases(data: dict[str, np.ndarray]) -> dict[str, Callable[[], object]]:
    cases: dict[str, Callable[[], object]] = {}
    try:
        import torch
    except ImportError:
        return cases
    batch = torch.from_numpy(data["images"]).permute(0, 3, 1, 2).float() / 255
    try:
        import kornia.augmentation as K

        tps = K.RandomThinPlateSpline(p=1.0)
        cases["kornia RandomThinPlateSpline (CPU)"] = lambda: tps(batch)
    except ImportError:
        pass
    try:
        from torchvision.transforms import v2

        elastic = v2.ElasticTransform()
        uint8 = torch.from_numpy(data["images"]).permute(0, 3, 1, 2).contiguous()
        cases["torchvision v2 ElasticTransform (CPU)"] = lambda: [elastic(x) for x in uint8]
    except ImportError:
        pass
    return cases


def torch_rates(name: str, count: int, repeat: int) -> list[tuple[str, float, float]]:
    """The torch peers' rates, measured in a fresh process: importing kornia or torchvision in
    a process that holds an llvmpipe GL context crashes it (their LLVM and Mesa's)."""
    code = (
        "import json, sys; sys.path.insert(0, sys.argv[1]); import batch_bench as b; "
        "d = b.workload(sys.argv[2], int(sys.argv[3])); "
        "print(json.dumps([(k, *b.measure(r, int(sys.argv[3]), int(sys.argv[4]))) "
        "for k, r in b.torch_cases(d).items()]))"
    )
    here = os.path.dirname(os.path.abspath(__file__))
    done = subprocess.run(
        [sys.executable, "-c", code, here, name, str(count), str(repeat)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        print(f"torch peers failed: {done.stderr[-500:]}", file=sys.stderr)
        return []
    return [tuple(row) for row in json.loads(done.stdout.splitlines()[-1])]


def rate(run: Callable[[], object], count: int, repeat: int) -> float:
    """Images per second: the median of ``repeat`` timed runs after one warm-up."""
    return measure(run, count, repeat)[0]


def measure(run: Callable[[], object], count: int, repeat: int) -> tuple[float, float]:
    """(images per second, CPU milliseconds per image) of ``repeat`` runs after one warm-up:
    the median wall time, and the least CPU time of this process (every thread: llvmpipe's
    and OpenCV's too), which other jobs on a shared machine disturb far less."""
    run()
    times, cpu = [], []
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        run()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return count / statistics.median(times), 1e3 * min(cpu) / count


def show(name: str, count: int, label: str, value: float, cpu: float) -> None:
    print(f"{name:>5} {count:>4}  {label:<40} {value:8.0f} images/s {cpu:7.2f} cpu ms/image")
    sys.stdout.flush()


def threads() -> dict[str, object]:
    found: dict[str, object] = {
        "cpus": os.cpu_count(),
        "LP_NUM_THREADS": os.environ.get("LP_NUM_THREADS"),
    }
    try:
        import cv2

        found["opencv"] = cv2.getNumThreads()
    except ImportError:
        pass
    if "torch" in sys.modules:
        found["torch"] = sys.modules["torch"].get_num_threads()
    return found


def limit_peer_threads(count: int) -> None:
    """Cap OpenCV's and torch's thread pools (albumentations runs on OpenCV) at ``count``;
    llvmpipe, which renders glmls's passes, keeps its own threads."""
    try:
        import cv2

        cv2.setNumThreads(count)
    except ImportError:
        pass
    try:
        import torch

        torch.set_num_threads(count)
    except ImportError:
        pass


def peak_memory(count: int) -> float:
    """MiB: the peak resident memory (``VmHWM``) of a fresh process that runs one labelled
    ``warp_batch`` of ``count`` (``ru_maxrss`` would count the parent's memory at the fork)."""
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); import batch_bench as b; "
        "import glmls; d = b.workload('224', int(sys.argv[2])); "
        "glmls.warp_batch(d['images'], d['src'], d['dst'], keypoints=d['keypoints'], "
        "masks=d['masks'], grid=4); "
        "print([l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1])"
    )
    here = os.path.dirname(os.path.abspath(__file__))
    done = subprocess.run(
        [sys.executable, "-c", code, here, str(count)], capture_output=True, text=True, check=True
    )
    return int(done.stdout.split()[-1]) / 1024  # KiB


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="glmls alone, a batch of 64, 3 runs")
    parser.add_argument("--no-peers", action="store_true", help="glmls alone (and its memory)")
    parser.add_argument("--batches", type=int, nargs="+", default=[64, 256])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workloads", nargs="+", default=["224", "text"], choices=["224", "text"])
    parser.add_argument(
        "--peer-images", type=int, default=32, help="images per timed run of each peer"
    )
    parser.add_argument(
        "--keypoints",
        type=int,
        default=KEYPOINTS,
        help="keypoints per image (the peers' time grows with them: compare at yours)",
    )
    parser.add_argument(
        "--peer-threads",
        type=int,
        help="threads OpenCV and torch may use for the peers (default: their own choice)",
    )
    parser.add_argument(
        "--method",
        default="quads",
        choices=glmls.METHODS,
        help="the construction of glmls's warp and warp_batch cases",
    )
    parser.add_argument("--json", help="also write the results to this file")
    args = parser.parse_args(argv)
    if args.peer_threads is not None:
        limit_peer_threads(args.peer_threads)
    # a GPU's single run varies with its clocks and queue: the median of three
    batches, repeat = ([64], 3) if args.quick else (args.batches, args.repeat)
    rows = []
    for name in args.workloads:
        for count in batches:
            data = workload(name, count, keypoints=args.keypoints)
            for label, run in glmls_cases(data, args.method).items():
                value, cpu = measure(run, count, repeat)
                rows.append(
                    {
                        "workload": name,
                        "batch": count,
                        "tool": label,
                        "images/s": value,
                        "cpu ms": cpu,
                    }
                )
                show(name, count, label, value, cpu)
        if args.quick or args.no_peers:
            continue
        # the peers work image by image: their rate does not depend on the batch
        count = args.peer_images
        data = workload(name, count, keypoints=args.keypoints)
        peers = [
            (label, *measure(run, count, repeat))
            for label, run in albumentations_cases(data).items()
        ]
        peers += torch_rates(name, count, repeat)
        for label, value, cpu in peers:
            row = {"workload": name, "batch": count, "tool": label}
            rows.append(row | {"images/s": value, "cpu ms": cpu})
            show(name, count, label, value, cpu)
    report = {
        "machine": platform.platform(),
        "renderer": glmls.gl.get_context().mgl.info["GL_RENDERER"],
        "threads": threads(),
        "keypoints": args.keypoints,
        "method": args.method,
        "results": rows,
    }
    if not args.quick:
        top = max(batches)
        report["peak_memory_mib"] = {f"warp_batch 224 x {top} +kp +mask": peak_memory(top)}
        print(
            f"peak memory, warp_batch of {top} at 224 x 224 with labels: "
            f"{report['peak_memory_mib'][f'warp_batch 224 x {top} +kp +mask']:.0f} MiB"
        )
    print("threads:", report["threads"], "| renderer:", report["renderer"])
    if args.json:
        with open(args.json, "w") as out:
            json.dump(report, out, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
