"""Does a process's GL context survive its forked children, by the way they end?

A process warps (its context made), forks a child, waits for it, warps again and exits. The
child ends in one of several ways; each case runs as a script of its own, and the probe
prints whether the parent's second warp equals its first and how the parent exited (a
negative status: killed by that signal, -11 a segmentation fault). A GPU driver whose
library destructors, run by a child's normal exit, free what the parent still uses shows
here as a difference or a crash in the cases where the child exits normally, and none where
it leaves by ``os._exit`` (no destructors).

    python tools/fork_probe.py            # every case
    python tools/fork_probe.py --timeout 60

Exits 1 where a case's parent crashed, hung or saw a different warp.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import textwrap
from pathlib import Path

#: case -> what the child does after the fork.
CASES = {
    "child exits normally": "sys.exit(0)",
    "child leaves by os._exit": "os._exit(0)",
    "child warps (its helper), exits normally": "glmls.warp(image, SRC, DST); sys.exit(0)",
}

SCRIPT = """
import os, sys
import numpy as np
sys.path.insert(0, {root!r})
import glmls
SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
DST = SRC + [[4.0, -2.0], [0, 0], [3, -4], [0, 0]]
image = np.random.default_rng(0).integers(0, 255, (48, 56, 3), dtype=np.uint8)
first = [glmls.warp(image, SRC, DST, method=m) for m in ("quads", "backward")]
pid = os.fork()
if pid == 0:
{child}
status = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
again = [glmls.warp(image, SRC, DST, method=m) for m in ("quads", "backward")]
same = all(np.array_equal(a, b) for a, b in zip(first, again))
print(f"child status {{status}}, parent's warps after it: {{'same' if same else 'DIFFERENT'}}")
sys.stdout.flush()
"""


def run(case: str, timeout: float) -> tuple[bool, str]:
    """(ok, what happened) of one case."""
    root = str(Path(__file__).resolve().parent.parent)
    code = SCRIPT.format(root=root, child=textwrap.indent(CASES[case], "    "))
    try:
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        return False, f"hung past {timeout:g} s"
    said = done.stdout.strip() or " ".join(done.stderr.strip().splitlines()[-1:])
    ok = done.returncode == 0 and "DIFFERENT" not in done.stdout
    return ok, f"parent exit status {done.returncode}; {said}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds per case")
    args = parser.parse_args(argv)
    failed = 0
    for case in CASES:
        ok, what = run(case, args.timeout)
        failed += not ok
        print(f"{'ok  ' if ok else 'FAIL'} {case}: {what}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
