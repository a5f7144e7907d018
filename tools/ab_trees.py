"""A/B of glmls checkouts: the same end-to-end cases timed on several source trees, alternated.

``python tools/ab_trees.py --trees old=/tmp/glmls-old,new=. --cases W1:grid=1,W1:tolerance=0.05``
``[--rounds 3] [--repeat 5] [--warmup 0.5] [--paired | --together]``
``[--ratios CASE|TREE/CASE|TREE,...]``

Each tree is a glmls source checkout (``git worktree add /tmp/glmls-old REV`` makes one from
any revision). By default every round runs every case on every tree in turn, each in a fresh
process (``--case``: one timing process), so that slow and fast spells of a shared machine
fall on all trees alike; the table gives each tree's median [min-max] over all rounds, in ms,
and the JSON of every time follows it.

``--paired``: every case on every tree set up once per round in a worker process of its own,
all alive at once, and then one call of each in turn, ``--repeat`` times (the order rotated
each time). Calls with the same index then ran within a fraction of a second of each other,
so their ratio (``--ratios``: the median and quartiles of the paired calls' ratios, e.g.
``W1:grid=1|old/W1:tolerance=0.05|new``) is what a shared machine's slow and fast spells,
which last longer than one process's timed calls, change least.

``--together``: every tree imported into this one process (as ``glmls_<NAME>``, its shaders
and data read from its own checkout) and every case on every tree called in turn, one call
each, ``--rounds`` x ``--repeat`` times (the order reversed every other time): both sides of
a ratio then share the process, its caches and the machine's spell of the moment, which on a
noisy shared host resolves a few per cent where separate processes do not. A tree whose
code imports ``glmls`` by its absolute name would mix with the other trees': glmls's own
modules import each other relatively.

A case is ``WORKLOAD:OPTION=VALUE``: ``MLS(p, q, shape=...)`` then ``m.warp(image, OPTION=VALUE)``,
end to end, with

- ``W1``: ``make_inputs(1024, 64)`` (handles on a jittered lattice, no folds);
- ``W2``: 64 random handles moved by +-35 px on a random 1024² RGB image (folds);
- ``W3``: ``make_inputs(512, 16)``;

rigid idw (the workloads of ``benchmarks/workloads.py``, built here without importing glmls);
or ``WORKLOAD:frame=GRID``, one interactive frame as ``glmls bench --mode frame`` times it
(new handles, a new ``MLS``, the image drawn into a kept 8-bit framebuffer, no read-back),
with the tree's own bench code. A tree that lacks a case's option (``tolerance`` where it has
no adaptive mesh) reports ``-`` for it.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.resources
import importlib.util
import json
import os
import pathlib
import statistics
import subprocess
import sys
import time
import types

import numpy as np


def make_inputs(size: int, handles: int, seed: int = 0):
    """``glmls.cli.bench.cases.make_inputs`` written out: a tree may lack the module."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) / size
    checker = ((xx * 16).astype(int) + (yy * 16).astype(int)) % 2
    image = np.dstack([xx * 200 + checker * 55, yy * 200 + checker * 55, (1 - xx) * 255])
    side = int(np.ceil(np.sqrt(handles)))
    lattice = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) + 0.5
    src = lattice[:handles] / side * size + rng.uniform(-0.2, 0.2, (handles, 2)) * size / side
    src = np.clip(src, 0, size - 1)
    dst = src + rng.uniform(-0.04, 0.04, src.shape) * size
    return image.astype(np.uint8), src, dst


def random_inputs(size: int):
    rng = np.random.default_rng(4)
    p = rng.uniform(0.05 * size, 0.95 * size, (64, 2))
    q = p + rng.uniform(-35, 35, (64, 2))
    image = np.random.default_rng(0).integers(0, 256, (size, size, 3), dtype=np.uint8)
    return image, p, q


WORKLOADS = {
    "W1": lambda: make_inputs(1024, 64),
    "W2": lambda: random_inputs(1024),
    "W3": lambda: make_inputs(512, 16),
}


def bad_case(case: str) -> str | None:
    """Why ``case`` is not ``WORKLOAD:OPTION=NUMBER`` with a known workload, or None."""
    workload, _, option = case.partition(":")
    key, _, value = option.partition("=")
    if workload not in WORKLOADS:
        return f"the workload is one of {', '.join(WORKLOADS)}"
    if not key or not value:
        return "expected WORKLOAD:OPTION=VALUE"
    try:
        float(value) if key == "tolerance" else int(value)
    except ValueError:
        return f"{key} takes {'a number' if key == 'tolerance' else 'an integer'}"
    return None


def make_step(tree: str, case: str, warmup: float = 0.5, package: types.ModuleType | None = None):
    """In this process: ``case``'s step (one call: one warp, or one frame) on the glmls of
    ``tree`` (``package``: that tree already imported, see :func:`load_tree`), after untimed
    runs for ``warmup`` seconds (two at least: the first compiles, and small cases stay slow
    for several more on llvmpipe, up to ~40 ms in all for W3). ``TypeError`` where the tree
    lacks the case's option."""
    if package is None:
        sys.path.insert(0, tree)
        import glmls as package
    glmls = package

    workload, _, option = case.partition(":")
    key, value = option.split("=")
    image, p, q = WORKLOADS[workload]()
    if key == "frame":
        step = _frame(image, p, q, int(value), glmls.__name__)
    else:
        options = {key: float(value) if key == "tolerance" else int(value)}

        def step(k: int) -> None:
            with glmls.MLS(p, q, shape=image.shape, transform="rigid") as m:
                m.warp(image, **options)

    warm, untimed = time.perf_counter() + warmup, 0
    while untimed < 2 or time.perf_counter() < warm:
        step(untimed)
        untimed += 1
    return step


def time_case(tree: str, case: str, repeat: int, warmup: float = 0.5) -> list[float]:
    """In this process: ``case`` on the glmls of ``tree``, ``repeat`` times after the warm-up
    of :func:`make_step`; milliseconds."""
    step = make_step(tree, case, warmup)
    times = []
    for k in range(repeat):
        start = time.perf_counter()
        step(k)
        times.append((time.perf_counter() - start) * 1000)
    return times


def serve(tree: str, case: str, warmup: float) -> None:
    """A paired run's worker: ``case`` on ``tree`` set up and warmed up ("ready", or "null"
    where the tree lacks the option), then one timed call (ms, a line) per "run" line read."""
    try:
        step = make_step(tree, case, warmup)
    except TypeError:
        print("null", flush=True)
        return
    print("ready", flush=True)
    for k, line in enumerate(sys.stdin):
        if line.strip() != "run":
            break
        start = time.perf_counter()
        step(k)
        print(f"{(time.perf_counter() - start) * 1000:.6f}", flush=True)


def paired(trees: dict[str, str], cases: list[str], rounds: int, repeat: int, warmup: float):
    """Every (case, tree) in a worker process of its own, all alive at once, and one call of
    each in turn, ``repeat`` times per round (the order rotated every time): calls with the
    same index ran within a fraction of a second of each other, so their ratio is what a
    shared machine's slow and fast spells change least. Times (ms) per (case, tree), in
    call order, None where a tree lacks the case's option."""
    times: dict[tuple[str, str], list[float] | None] = {}
    for _ in range(rounds):
        workers = {}
        for case in cases:
            for name, path in trees.items():
                workers[case, name] = subprocess.Popen(
                    [sys.executable, __file__, "--serve", os.path.abspath(path), case]
                    + ["--warmup", str(warmup)],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    text=True,
                )
        live = []
        for key, worker in workers.items():
            line = _reply(worker, ("ready", "null"))
            if line == "ready" and times.setdefault(key, []) is not None:  # None: died before
                live.append(key)
            else:
                if line != "null":
                    print(f"failed: {key[1]} {key[0]}", file=sys.stderr)
                times.setdefault(key, None)
        for k in range(repeat):
            for key in live[k % len(live) :] + live[: k % len(live)] if live else []:
                worker = workers[key]
                try:
                    worker.stdin.write("run\n")  # type: ignore[union-attr]
                    worker.stdin.flush()  # type: ignore[union-attr]
                    reply = _reply(worker, None)
                except BrokenPipeError:
                    reply = ""
                if not reply:  # the worker died: its calls no longer pair with the others'
                    print(f"failed: {key[1]} {key[0]} (call {k})", file=sys.stderr)
                    live.remove(key)
                    times[key] = None
                    continue
                times[key].append(float(reply))  # type: ignore[union-attr]
        for worker in workers.values():
            try:
                worker.stdin.close()  # type: ignore[union-attr]
            except BrokenPipeError:
                pass
            worker.wait(timeout=120)
    return times


def _reply(worker: subprocess.Popen, words: tuple[str, ...] | None) -> str:
    """The worker's next protocol line: one of ``words``, or (None) a number; other lines
    (a library's output) skipped; "" at its end."""
    for line in worker.stdout:  # type: ignore[union-attr]
        line = line.strip()
        if words is not None and line in words:
            return line
        if words is None:
            try:
                float(line)
            except ValueError:
                continue
            return line
    return ""


def ratio(times: dict, spec: str) -> str:
    """``CASE|TREE/CASE|TREE``: the median [quartiles] of the paired calls' ratios."""
    top, bottom = (tuple(part.split("|")) for part in spec.split("/"))
    a, b = times.get(top), times.get(bottom)
    if not a or not b or len(a) != len(b):
        return f"{spec}: -"
    r = sorted(x / y for x, y in zip(a, b, strict=True))
    quartiles = statistics.quantiles(r, n=4) if len(r) > 1 else [r[0], r[0], r[0]]
    return f"{spec}: {statistics.median(r):.2f}x [{quartiles[0]:.2f}-{quartiles[2]:.2f}]"


def _frame(image, p, q, grid: int, package: str = "glmls"):
    """The tree's own ``glmls bench --mode frame`` step at ``grid`` (the tree imported as
    ``package``): ``case_step`` where the tree has it, else the private runner that the
    tree's own bench ran."""
    size, handles = image.shape[0], len(p)
    try:
        cases = importlib.import_module(f"{package}.cli.bench.cases")
    except ImportError:  # a tree whose bench code is glmls/bench_cases.py
        cases = importlib.import_module(f"{package}.bench_cases")
    case = cases.Case("glmls", "frame", size, handles, grid, "rigid")
    if hasattr(cases, "case_step"):
        return cases.case_step(case, image, p, q)
    return cases._glmls_frame(case, image, p, q)


def load_tree(name: str, path: str) -> types.ModuleType:
    """The glmls of the checkout ``path`` imported as ``glmls_<name>``, beside any other: its
    modules import each other relatively, its lookups of its shaders and data (by the package
    name "glmls" or its own) read its own checkout, and :func:`activate` makes it the
    ``glmls`` of absolute imports (some trees' bench code has them)."""
    package = f"glmls_{name}"
    root = pathlib.Path(path).resolve() / "glmls"
    spec = importlib.util.spec_from_file_location(
        package, root / "__init__.py", submodule_search_locations=[str(root)]
    )
    if spec is None or spec.loader is None:
        raise ValueError(f"no glmls package in {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[package] = module
    spec.loader.exec_module(module)

    def files(anchor):
        name_ = anchor if isinstance(anchor, str) else anchor.__name__
        if name_ in ("glmls", package) or name_.startswith(package + "."):
            parts = name_.split(".")[1:] if name_ != "glmls" else []
            return root.joinpath(*parts)
        return importlib.resources.files(anchor)

    redirected = types.SimpleNamespace(files=files)
    for module_name, loaded in list(sys.modules.items()):
        ours = module_name == package or module_name.startswith(package + ".")
        if ours and getattr(loaded, "resources", None) is (importlib.resources):
            loaded.resources = redirected
    return module


def activate(package: types.ModuleType) -> None:
    """Make ``package`` (:func:`load_tree`) and its modules those that ``import glmls...``
    finds, instead of another tree's."""
    for name in [n for n in sys.modules if n == "glmls" or n.startswith("glmls.")]:
        del sys.modules[name]
    prefix = package.__name__
    for name, module in list(sys.modules.items()):
        if name == prefix or name.startswith(prefix + "."):
            sys.modules["glmls" + name[len(prefix) :]] = module


def together(trees: dict[str, str], cases: list[str], rounds: int, repeat: int, warmup: float):
    """Every tree imported into this process (:func:`load_tree`) and one call of every
    (case, tree) in turn, ``rounds`` x ``repeat`` times, the order reversed every other
    time; times (ms) per (case, tree), None where a tree lacks the case's option."""
    packages = {name: load_tree(name, path) for name, path in trees.items()}
    steps: dict[tuple[str, str], object] = {}
    times: dict[tuple[str, str], list[float] | None] = {}
    for case in cases:
        for name, path in trees.items():
            activate(packages[name])
            try:
                steps[case, name] = make_step(path, case, warmup, packages[name])
                times[case, name] = []
            except TypeError:
                times[case, name] = None
    order = list(steps)
    for k in range(rounds * repeat):
        for key in order if k % 2 == 0 else order[::-1]:
            activate(packages[key[1]])
            start = time.perf_counter()
            steps[key](k)  # type: ignore[operator]
            times[key].append((time.perf_counter() - start) * 1000)  # type: ignore[union-attr]
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trees", help="NAME=PATH,... glmls source checkouts, in turn")
    parser.add_argument("--cases", help="WORKLOAD:OPTION=VALUE,...")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument(
        "--warmup", type=float, default=0.5, help="untimed runs for this long first (s)"
    )
    parser.add_argument(
        "--paired",
        action="store_true",
        help="every case on every tree in a process of its own, one call of each in turn",
    )
    parser.add_argument(
        "--together",
        action="store_true",
        help="every tree imported into this process, one call of each case and tree in turn",
    )
    parser.add_argument(
        "--ratios",
        help="with --paired or --together: CASE|TREE/CASE|TREE,... the paired calls' ratios",
    )
    parser.add_argument("--case", nargs=2, metavar=("TREE", "CASE"), help=argparse.SUPPRESS)
    parser.add_argument("--serve", nargs=2, metavar=("TREE", "CASE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case is not None:  # one timing process
        tree, case = args.case
        try:
            print(json.dumps(time_case(tree, case, args.repeat, args.warmup)))
        except TypeError:  # the tree lacks the option
            print(json.dumps(None))
        return
    if args.serve is not None:  # one worker of a paired run
        serve(*args.serve, args.warmup)
        return
    if not args.trees or not args.cases:
        parser.error("--trees and --cases are required")
    if args.rounds < 1 or args.repeat < 1:
        parser.error(f"--rounds and --repeat must be >= 1, got {args.rounds}, {args.repeat}")
    if any("=" not in item for item in args.trees.split(",")):
        parser.error(f"--trees is NAME=PATH,..., got {args.trees!r}")
    trees = dict(item.split("=", 1) for item in args.trees.split(","))
    cases = args.cases.split(",")
    for case in cases:
        why = bad_case(case)
        if why:
            parser.error(f"--cases: {case!r}: {why}")
    if args.ratios and not (args.paired or args.together):
        parser.error("--ratios pairs calls: it needs --paired or --together")
    if args.paired and args.together:
        parser.error("--paired and --together are two ways of pairing calls: choose one")
    if args.together:
        times = together(trees, cases, args.rounds, args.repeat, args.warmup)
    elif args.paired:
        times = paired(trees, cases, args.rounds, args.repeat, args.warmup)
    else:
        times = alternated(trees, cases, args)

    def cell(values: list[float] | None) -> str:
        if not values:
            return "-"
        return f"{statistics.median(values):.1f} [{min(values):.0f}-{max(values):.0f}]"

    print("case | " + " | ".join(trees))
    for case in cases:
        print(f"{case} | " + " | ".join(cell(times.get((case, name))) for name in trees))
    for spec in args.ratios.split(",") if args.ratios else []:
        print(ratio(times, spec))
    print(json.dumps({f"{case}|{name}": v for (case, name), v in times.items() if v}))


def alternated(trees: dict[str, str], cases: list[str], args) -> dict:
    """Every round: every case on every tree in turn, each in a fresh process timing
    ``args.repeat`` calls; times (ms) per (case, tree)."""
    times: dict[tuple[str, str], list[float]] = {}
    for _ in range(args.rounds):
        for case in cases:
            for name, path in trees.items():
                out = subprocess.run(
                    [sys.executable, __file__, "--case", os.path.abspath(path), case]
                    + ["--repeat", str(args.repeat), "--warmup", str(args.warmup)],
                    capture_output=True,
                    text=True,
                    timeout=900,
                    check=False,
                )
                lines = [line for line in out.stdout.splitlines() if line.startswith(("[", "n"))]
                result = json.loads(lines[-1]) if lines else None
                if result is None and out.returncode != 0:
                    print(f"failed: {name} {case}: {out.stderr[-300:]}", file=sys.stderr)
                if result:
                    times.setdefault((case, name), []).extend(result)
    return times


if __name__ == "__main__":
    main()
