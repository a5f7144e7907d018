"""``python interrupted_jobs.py FOLDER SCHEDULER``: run_jobs over items that take long, on
two workers (``SCHEDULER``: ``none`` for worker processes, or ``local`` for a local Dask
cluster); each item leaves ``started_N`` in FOLDER as it starts. Ctrl-C exits 130; SIGTERM
raises an exception, as the command line does, and exits 143.
``SCHEDULER`` ``big``: worker processes, item 0 ends at once with a big result, which
leaves ``sending_PID`` (its worker's) in FOLDER as it is being sent back.
``SCHEDULER`` ``before_worker_N``: worker processes, and Ctrl-C reaches the whole process
group (sent by this process, as a terminal sends it) just before worker N (1 or 2) starts."""

from __future__ import annotations

import itertools
import multiprocessing.context
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


def ctrl_c_before_worker(number: int) -> None:
    """Ctrl-C to this process group as the ``number``-th worker process is about to start: the
    processes born before hear it, that worker does not."""
    start = multiprocessing.context.SpawnProcess.start
    starts = itertools.count(1)

    def start_after_ctrl_c(process: multiprocessing.context.SpawnProcess) -> None:
        if next(starts) == number:
            os.killpg(0, signal.SIGINT)
        start(process)

    multiprocessing.context.SpawnProcess.start = start_after_ctrl_c


def terminate(signum: int, frame: object) -> None:
    raise Terminated


if __name__ == "__main__":
    # as a terminal's foreground command: a shell's background job (a test run started with
    # `&`, under nohup) passes SIGINT on ignored, and Python then leaves it ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, terminate)
    from glmls.analysis.jobs import run_jobs

    folder, scheduler = sys.argv[1], sys.argv[2]
    if scheduler.startswith("before_worker_"):
        ctrl_c_before_worker(int(scheduler.rpartition("_")[2]))
        scheduler = "none"
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
