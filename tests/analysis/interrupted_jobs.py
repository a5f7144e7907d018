"""``python interrupted_jobs.py FOLDER SCHEDULER``: run_jobs over items that take long, on
two workers (``SCHEDULER``: ``none`` for worker processes, or ``local`` for a local Dask
cluster); each item leaves ``started_N`` in FOLDER as it starts. Ctrl-C exits 130."""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path


def slow(item: tuple[str, int]) -> int:
    folder, index = item
    (Path(folder) / f"started_{index}").touch()
    time.sleep(150)  # far longer than the test waits for the run to end
    return index


if __name__ == "__main__":
    # as a terminal's foreground command: a shell's background job (a test run started with
    # `&`, under nohup) passes SIGINT on ignored, and Python then leaves it ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from glmls.analysis.jobs import run_jobs

    folder, scheduler = sys.argv[1], sys.argv[2]
    items = [(folder, index) for index in range(4)]
    try:
        run_jobs(slow, items, jobs=2, scheduler=None if scheduler == "none" else scheduler)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
