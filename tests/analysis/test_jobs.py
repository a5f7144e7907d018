"""Fanning work out: sequential, spawned worker processes (each with its own GL context) and a
local Dask cluster give the same results, in order; a worker's error reaches the caller."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from glmls.analysis.jobs import DistributedUnavailableError, check_scheduler, run_jobs

SRC = np.array([[10.0, 10.0], [90.0, 12.0], [50.0, 80.0], [20.0, 70.0]])
POINTS = np.array([[50.0, 50.0], [20.0, 30.0], [75.5, 60.25]])


def evaluate(shift: float) -> tuple[int, np.ndarray]:
    """f at POINTS for handles whose first target moved by ``shift``: GL work, so each worker
    process needs a GL context of its own (one inherited by fork would hang)."""
    import glmls

    dst = SRC.copy()
    dst[0] += [shift, -shift / 2]
    with glmls.MLS(SRC, dst, shape=(100, 100)) as m:
        return os.getpid(), m(POINTS)


def fail_on_two(item: int) -> int:
    if item == 2:
        raise ValueError(f"bad item {item}")
    return item * 10


class CodedError(Exception):
    """An exception that cannot be rebuilt from one message."""

    def __init__(self, code: int, text: str) -> None:
        super().__init__(code, text)


def raise_coded(item: int) -> int:
    raise CodedError(item, "coded")


def mark_or_fail(item: tuple[str, int]) -> int:
    """Item 0 fails; item 1 ends a second after it, however late either worker started;
    each other leaves a file saying it ran."""
    folder, index = item
    failing = Path(folder) / "failing"
    if index == 0:
        failing.touch()
        raise ValueError("bad item 0")
    if index == 1:
        deadline = time.monotonic() + 120
        while not failing.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(1.0)
    (Path(folder) / f"ran_{index}").touch()
    return index


def fail_soon(item: int) -> int:
    """Item 0 fails after a moment; item 1 is still running then, and ends well."""
    time.sleep(0.5 if item == 0 else 2.0)
    if item == 0:
        raise ValueError("bad item 0")
    return item


ITEMS = [0.0, 3.0, 6.0, 9.0]


def test_workers_compute_what_this_process_computes():
    sequential = run_jobs(evaluate, ITEMS)
    assert {pid for pid, _ in sequential} == {os.getpid()}
    seen = []
    parallel = run_jobs(evaluate, ITEMS, jobs=2, on_result=lambda i, r: seen.append(i))
    assert sorted(seen) == [0, 1, 2, 3]
    assert os.getpid() not in {pid for pid, _ in parallel}
    for (_, a), (_, b) in zip(sequential, parallel, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(sequential[0][1], sequential[3][1])  # in input order
    assert run_jobs(evaluate, [], jobs=2) == []


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_workers_error_names_the_item(jobs):
    with pytest.raises(ValueError, match=r"^item 2: bad item 2$"):
        run_jobs(fail_on_two, range(6), jobs=jobs)
    with pytest.raises(CodedError) as caught:  # kept as it was, with a note
        run_jobs(raise_coded, [5], jobs=jobs)
    assert "item 0: (5, 'coded')" in caught.value.__notes__


def test_bad_jobs_and_schedulers():
    for jobs in (0, -2):
        with pytest.raises(ValueError, match=f"jobs must be an integer >= 1, got {jobs}"):
            run_jobs(fail_on_two, [1], jobs=jobs)
    for jobs in (1.5, "2", True, None):
        with pytest.raises(TypeError, match=f"got {jobs!r}"):
            run_jobs(fail_on_two, [1], jobs=jobs)
    assert run_jobs(abs, [-1], jobs=np.int64(1)) == run_jobs(abs, [-1], jobs=np.array(1)) == [1]
    with pytest.raises(ValueError, match="scheduler must be 'local' or"):
        run_jobs(fail_on_two, [1], scheduler=" ")
    for scheduler in (3, b"local", ["local"]):
        with pytest.raises(
            TypeError, match=rf"scheduler must be a string, .*got {re.escape(repr(scheduler))}"
        ):
            run_jobs(fail_on_two, [1], scheduler=scheduler)
    with pytest.raises(TypeError, match="function must be callable"):
        run_jobs(None, [1])


def test_without_dask_the_error_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import fails
    with pytest.raises(DistributedUnavailableError, match=r"pip install 'glmls\[distributed\]'"):
        run_jobs(fail_on_two, [1], scheduler="local")
    assert issubclass(DistributedUnavailableError, ImportError)
    assert check_scheduler(None) is None


def test_from_a_worker_thread():
    out = {}
    thread = threading.Thread(target=lambda: out.update(r=run_jobs(fail_on_two, [1, 3], jobs=2)))
    thread.start()
    thread.join(timeout=120)
    assert out["r"] == [10, 30]


def test_a_local_dask_cluster_of_two_workers():
    pytest.importorskip("distributed")  # a guard only: scripts/setup.sh installs the extra
    sequential = run_jobs(evaluate, ITEMS)
    seen = []
    on_dask = run_jobs(
        evaluate, ITEMS, jobs=2, scheduler="local", on_result=lambda i, r: seen.append(i)
    )
    assert sorted(seen) == [0, 1, 2, 3]
    assert os.getpid() not in {pid for pid, _ in on_dask}
    for (_, a), (_, b) in zip(sequential, on_dask, strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match=r"^item 2: bad item 2$"):
        run_jobs(fail_on_two, range(4), jobs=2, scheduler="local")


def test_a_local_cluster_needs_no_particular_port():
    """Dask's dashboard port (8787) taken by another program: the local cluster starts on
    a free one without a warning (warnings are errors in the tests)."""
    pytest.importorskip("distributed")
    with socket.socket() as taken:
        try:
            taken.bind(("", 8787))
        except OSError:
            pass  # taken already: the case itself
        else:
            taken.listen()
        assert len(run_jobs(evaluate, ITEMS[:2], jobs=1, scheduler="local")) == 2


@pytest.mark.parametrize("scheduler", [None, "local"])
def test_after_a_failure_the_items_not_started_never_start(tmp_path, scheduler):
    """Only as many items as workers are handed out at a time: a worker free after its item
    failed takes no queued item (an interrupted batch would go on writing several more)."""
    items = [(str(tmp_path), index) for index in range(8)]
    with pytest.raises(ValueError, match="item 0: bad item 0"):
        run_jobs(mark_or_fail, items, jobs=2, scheduler=scheduler)
    assert sorted(p.name for p in tmp_path.iterdir()) in (["failing"], ["failing", "ran_1"])


@pytest.mark.parametrize("scheduler", [None, "local"])
def test_the_items_running_when_one_fails_are_reported(scheduler):
    """A worker's item that ends after another failed is done (its file written): the caller
    hears of it, as of the items before, so that it can say what was written."""
    seen = []
    with pytest.raises(ValueError, match="item 0: bad item 0"):
        run_jobs(
            fail_soon,
            [0, 1],
            jobs=2,
            scheduler=scheduler,
            on_result=lambda i, r: seen.append((i, r)),
        )
    assert seen == [(1, 1)]


@pytest.mark.parametrize("scheduler", ["none", "local"])
def test_ctrl_c_ends_the_run_and_its_workers(tmp_path, scheduler):
    """Ctrl-C in a terminal reaches the whole process group, the workers too: the run ends
    at once (it does not wait for items whose workers are gone) and leaves no process."""
    if scheduler == "local":
        pytest.importorskip("distributed")
    child = _interrupted_jobs(tmp_path, scheduler)
    try:
        _wait_until(child, lambda: len(list(tmp_path.glob("started_*"))) >= 2, "two items to start")
        os.killpg(child.pid, signal.SIGINT)
        err = _ended_alone(child, tmp_path)
    finally:
        _kill(child)
    assert child.returncode == 130, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["started_0", "started_1"]


@pytest.mark.parametrize("scheduler", ["none", "local"])
@pytest.mark.parametrize("whom", ["parent", "group"])
def test_sigterm_ends_the_run_and_its_workers(tmp_path, scheduler, whom):
    """SIGTERM to the caller alone (a container's stop, ``kill PID``), which turns it into an
    exception as the command line does, or to its whole process group: the running items end
    at once (they would run 150 s), the run ends with its one line, and no process is left."""
    if scheduler == "local":
        pytest.importorskip("distributed")
    child = _interrupted_jobs(tmp_path, scheduler)
    try:
        _wait_until(child, lambda: len(list(tmp_path.glob("started_*"))) >= 2, "two items to start")
        if whom == "parent":
            os.kill(child.pid, signal.SIGTERM)
        else:
            os.killpg(child.pid, signal.SIGTERM)
        err = _ended_alone(child, tmp_path)
    finally:
        _kill(child)
    assert (child.returncode, err) == (143, "terminated\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["started_0", "started_1"]


def test_ctrl_c_while_a_worker_sends_its_result(tmp_path):
    """Ctrl-C reaching a worker as it sends a big result back (its item done), and then
    waiting for the next item: it goes on quietly, and the run ends at once (a worker killed
    in the middle of its message would leave the run waiting for the rest of it, for ever,
    and one waiting for an item would print a traceback). The workers get it first here,
    many times, so that it lands in the sending whatever the machine's speed."""
    child = _interrupted_jobs(tmp_path, "big")
    try:
        _wait_until(
            child,
            lambda: list(tmp_path.glob("sending_*")),
            "a worker to send its result",
            pause=0.002,
        )
        sender = int(next(tmp_path.glob("sending_*")).name.split("_")[1])
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            with contextlib.suppress(ProcessLookupError):
                os.kill(sender, signal.SIGINT)
            time.sleep(0.005)
        os.killpg(child.pid, signal.SIGINT)
        err = _ended_alone(child, tmp_path)
    finally:
        _kill(child)
    assert (child.returncode, err) == (130, "interrupted\n")


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
@pytest.mark.parametrize("scheduler", ["none", "local"])
def test_ctrl_c_as_the_workers_start(tmp_path, scheduler):
    """Ctrl-C as the workers' interpreters start (a Dask cluster's start takes seconds):
    they do not hear it, so no traceback, and the run ends with its one line and no process
    left."""
    if scheduler == "local":
        pytest.importorskip("distributed")
    child = _interrupted_jobs(tmp_path, scheduler)
    try:
        _wait_until(child, lambda: _workers_of(child.pid), "a worker process to start", pause=0.002)
        os.killpg(child.pid, signal.SIGINT)
        err = _ended_alone(child, tmp_path)
    finally:
        _kill(child)
    assert (child.returncode, err) == (130, "interrupted\n")


@pytest.mark.parametrize("worker", [1, 2])
def test_ctrl_c_just_before_a_worker_starts(tmp_path, worker):
    """Ctrl-C to the whole process group as the first or second worker process is about to
    start, which is then born after it and does not hear it: the caller stops it all the
    same, so that the run ends at once (that worker would run its item, 150 s, to the end),
    with its one line and no process left."""
    child = _interrupted_jobs(tmp_path, f"before_worker_{worker}")
    try:
        err = _ended_alone(child, tmp_path)
    finally:
        _kill(child)
    assert (child.returncode, err) == (130, "interrupted\n")


def _workers_of(group: int) -> list[int]:
    """The worker processes (started by multiprocessing's ``spawn``) of process ``group``."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):
            fields = stat.read_text().rpartition(")")[2].split()
            command = stat.with_name("cmdline").read_bytes()
            if int(fields[2]) == group and b"spawn_main" in command:
                found.append(int(stat.parent.name))
    return found


def _interrupted_jobs(folder: Path, mode: str) -> subprocess.Popen:
    """``interrupted_jobs.py FOLDER MODE`` started in a process group of its own, as a
    terminal's command, its stderr piped."""
    script = Path(__file__).with_name("interrupted_jobs.py")
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(script.parent)]))
    return subprocess.Popen(
        [sys.executable, str(script), str(folder), mode],
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )


def _wait_until(
    child: subprocess.Popen, ready: Callable[[], object], what: str, *, pause: float = 0.1
) -> None:
    """Until ``ready()`` is true, 120 s at most: the test fails, with what the run wrote, if
    the run ends before or still waits for ``what`` then."""
    deadline = time.monotonic() + 120
    while not ready():
        if child.poll() is not None:
            code = child.returncode
            pytest.fail(f"the run ended ({code}) as the test waited for {what}: {_kill(child)!r}")
        if time.monotonic() > deadline:
            pytest.fail(f"120 s waiting for {what}; the run wrote {_kill(child)!r}")
        time.sleep(pause)


def _ended(child: subprocess.Popen, folder: Path) -> str:
    """What the run wrote on stderr, once it has ended: 90 s at most, since the items would
    run 150 s (a run that waited for them fails the test, with room for a machine under load
    to start and end processes)."""
    try:
        return child.communicate(timeout=90)[1]
    except subprocess.TimeoutExpired:
        started = sorted(p.name for p in folder.iterdir())
        pytest.fail(f"the run went on 90 s after it was stopped ({started}): {_kill(child)!r}")


def _ended_alone(child: subprocess.Popen, folder: Path) -> str:
    """:func:`_ended`'s stderr, once no process of the run's group is left (30 s at most)."""
    err = _ended(child, folder)
    assert not _group_alive(child.pid, wait=30), "a worker process outlived the run"
    return err


def _kill(child: subprocess.Popen) -> str:
    """What the run wrote on stderr, its whole process group killed: its workers too, which
    hold the pipe open (reading to its end would wait for them)."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(child.pid, signal.SIGKILL)
    try:
        return child.communicate(timeout=30)[1]
    except subprocess.TimeoutExpired:
        return "(stderr still open 30 s after the process group was killed)"


def _group_alive(group: int, wait: float) -> bool:
    """Whether a process of ``group`` is still running after ``wait`` seconds at most."""
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return False
        time.sleep(0.1)
    return True


def test_a_closing_local_cluster_logs_nothing_below_error():
    """Closing a local cluster whose workers are stopping makes Dask log their closed
    connections (INFO, with tracebacks) on stderr, under the run's own last line; those
    records are dropped while it closes, whatever levels Dask sets meanwhile."""
    import logging

    from glmls.analysis import jobs

    seen: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            seen.append(record.getMessage())

    logger = logging.getLogger("distributed")
    handler = Collect()
    logger.addHandler(handler)
    level = logger.level
    logger.setLevel(logging.INFO)
    try:
        with jobs._dask_logs_below_error_dropped():
            logging.getLogger("distributed.batched").info("Batched Comm Closed")
            logging.getLogger("distributed.batched").error("a real failure")
        logging.getLogger("distributed.batched").info("after")
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
    assert seen == ["a real failure", "after"]
