"""``python interrupted_jobs.py FOLDER SCHEDULER``: run_jobs over items that take long, on
two workers (``SCHEDULER``: ``none`` for worker processes, or ``local`` for a local Dask
cluster); each item leaves ``started_N`` in FOLDER as it starts. Ctrl-C exits 130; SIGTERM
raises an exception, as the command line does, and exits 143.
``SCHEDULER`` ``big``: worker processes, item 0 ends at once with a big result, which
leaves ``sending_PID`` (its worker's) in FOLDER as it is being sent back."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path


def slow(item: tuple[str, int]) -> int:
    folder, index = item
    (Path(folder) / f"started_{index}").touch()
    time.sleep(150)  # far longer than the test waits for the run to end
    return index


class Big:
    """A result of 64 MB, which says where it is being sent from as it is pickled."""

    def __reduce__(self):
        folder = Path(os.environ["INTERRUPTED_JOBS_FOLDER"])
        (folder / f"sending_{os.getpid()}").touch()
        return bytes, (b"x" * 64_000_000,)


def big_or_slow(item: tuple[str, int]) -> object:
    folder, index = item
    os.environ["INTERRUPTED_JOBS_FOLDER"] = folder
    return Big() if index == 0 else slow(item)


class Terminated(BaseException):
    """SIGTERM, raised in the main thread."""


def terminate(signum: int, frame: object) -> None:
    raise Terminated


if __name__ == "__main__":
    # as a terminal's foreground command: a shell's background job (a test run started with
    # `&`, under nohup) passes SIGINT on ignored, and Python then leaves it ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, terminate)
    from glmls.analysis.jobs import run_jobs

    folder, scheduler = sys.argv[1], sys.argv[2]
    items = [(folder, index) for index in range(2 if scheduler == "big" else 4)]
    function = big_or_slow if scheduler == "big" else slow
    try:
        run_jobs(
            function, items, jobs=2, scheduler=None if scheduler in ("none", "big") else scheduler
        )
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
    except Terminated:
        print("terminated", file=sys.stderr)
        sys.exit(143)
