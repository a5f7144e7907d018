"""Fanning work out over processes: ``run_jobs(function, items, jobs=N, scheduler=...)``.

- ``jobs=1`` and no scheduler: one item after another, in this process.
- ``jobs=N > 1``: N worker processes on this machine (:class:`ProcessPoolExecutor`), started
  with ``spawn``: a GL driver does not survive ``fork()`` (see :mod:`glmls.gl.context`), so
  each worker is a fresh interpreter that makes its own GL context on its first GL call.
- ``scheduler="local"``: a Dask cluster of ``jobs`` worker processes on this machine, made
  for the call and closed after it; ``scheduler="tcp://host:8786"``: the workers of an
  existing Dask cluster (``jobs`` is then ignored: the cluster has its own workers), so that
  thousands of items spread over many machines. Dask is the optional ``distributed`` extra:
  ``pip install 'glmls[distributed]'``; its workers too start with ``spawn`` (Dask's
  default), and they must have glmls installed.

``function`` must be picklable (a module-level function) and so must the items and the
results. Results come back in the order of ``items``; ``on_result(index, result)`` is called
in the calling thread as each item finishes (in the order they finish), e.g. for a progress
bar, also for the items that were running when another failed and ended well, before the
failure is raised. Each worker (each thread of a Dask worker) is handed one item at a time,
so that a failed or interrupted run starts no more items. An exception raised by
``function`` reaches the caller with the failing item's index in its message (``item 3:
...``), of the same type where it can be rebuilt from a message; the items not yet started
are cancelled and the workers shut down. A stop that reaches the caller alone (Ctrl-C, or an
exception that is no ``Exception``, as a SIGTERM handler raises) stops the workers' running
items too, at once.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import itertools
import logging
import multiprocessing
import os
import signal
from collections.abc import Callable, Iterable, Iterator
from multiprocessing import resource_tracker
from typing import Any

from ..core.config import check_integer
from ..errors import DistributedUnavailableError
from ..gl.signals import signals_held

__all__ = ["DistributedUnavailableError", "check_jobs", "check_scheduler", "run_jobs"]

INSTALL = "pip install 'glmls[distributed]'"


def check_jobs(jobs: object) -> int:
    """``jobs`` as an int >= 1 (:func:`~glmls.core.config.check_integer`: numpy's integers
    too); ``TypeError``/``ValueError`` naming the value otherwise."""
    return check_integer("jobs", jobs, 1)


def check_scheduler(scheduler: object) -> str | None:
    """``None``, ``"local"`` or a scheduler's address; for the two last, Dask must be
    installed (:class:`DistributedUnavailableError` saying how otherwise); ``TypeError``
    for a value that is no string, ``ValueError`` for a blank one, both naming it."""
    if scheduler is None:
        return None
    if not isinstance(scheduler, str):
        raise TypeError(
            f"scheduler must be a string, 'local' or a Dask scheduler's address, got {scheduler!r}"
        )
    if not scheduler.strip():
        raise ValueError(
            f"scheduler must be 'local' or a Dask scheduler's address, got {scheduler!r}"
        )
    try:
        import distributed  # noqa: F401  (only checks that it is there)
    except ImportError as error:
        raise DistributedUnavailableError(
            f"scheduler {scheduler!r} needs Dask's distributed package: {INSTALL}"
        ) from error
    return scheduler.strip()


def run_jobs(
    function: Callable[[Any], Any],
    items: Iterable[Any],
    *,
    jobs: int = 1,
    scheduler: str | None = None,
    on_result: Callable[[int, Any], None] | None = None,
) -> list:
    """``[function(item) for item in items]``, in this process, worker processes or on Dask.

    ``jobs=1`` and no scheduler: one item after another, in this process; ``jobs`` > 1:
    worker processes started with ``spawn`` (a GL driver does not survive ``fork()``), each
    making its own GL context; a ``scheduler``: a Dask cluster (the optional ``distributed``
    extra). ``function``, the items and the results must be picklable (a module-level
    function) outside this process. See ``glmls.analysis.jobs``.

    Parameters
    ----------
    function : callable
        Called with each item.
    items : iterable
        The items.
    jobs : int, optional
        Worker processes (>= 1); with ``scheduler="local"``, the local cluster's workers.
    scheduler : str, optional
        ``"local"`` for a Dask cluster on this machine made for the call, or an existing
        cluster's address (``"tcp://host:8786"``; ``jobs`` is then ignored).
    on_result : callable, optional
        ``on_result(index, result)``, called in the calling thread as each item finishes (in
        the order they finish), e.g. for a progress bar.

    Returns
    -------
    list
        The results, in the order of ``items``.

    Raises
    ------
    TypeError
        For ``jobs`` that is not an integer, a scheduler that is no string, or a
        ``function`` that is not callable.
    ValueError
        For ``jobs`` < 1 or a blank scheduler.
    glmls.DistributedUnavailableError
        An ``ImportError``: a scheduler was asked for without Dask's ``distributed``.
    Exception
        What ``function`` raised, with the failing item's index in its message
        (``item 3: ...``), of the same type where it can be rebuilt from a message; the
        items not yet started are cancelled.

    Examples
    --------
    >>> glmls.analysis.run_jobs(abs, [-1, 2, -3])
    [1, 2, 3]
    >>> finished = []
    >>> _ = glmls.analysis.run_jobs(abs, [-1, -2], on_result=lambda i, r: finished.append(i))
    >>> finished
    [0, 1]
    >>> import math
    >>> glmls.analysis.run_jobs(math.sqrt, [4.0, -1.0])
    Traceback (most recent call last):
        ...
    ValueError: item 1: math domain error

    In four worker processes (each starts a fresh interpreter, which takes seconds):

    >>> glmls.analysis.run_jobs(abs, range(-100, 0), jobs=4)[:3]  # doctest: +SKIP
    [100, 99, 98]
    """
    jobs = check_jobs(jobs)
    scheduler = check_scheduler(scheduler)
    if not callable(function):
        raise TypeError(f"function must be callable, got {function!r}")
    items = list(items)
    results: list = [None] * len(items)

    def finished(index: int, result: Any) -> None:
        results[index] = result
        if on_result is not None:
            on_result(index, result)

    if not items:
        return results
    if scheduler is not None:
        _run_dask(function, items, jobs, scheduler, finished)
    elif jobs == 1:
        for index, item in enumerate(items):
            try:
                result = function(item)
            except Exception as error:
                raise _indexed(error, index) from error
            finished(index, result)
    else:
        _run_processes(function, items, jobs, finished)
    return results


def _indexed(error: BaseException, index: int) -> BaseException:
    """``error`` with ``item {index}: `` before its message: a new exception of the same type
    where the type can be rebuilt from one message, else ``error`` itself with a note (a type
    whose constructor takes other arguments, e.g. OSError's errno, stays as it was)."""
    message = f"item {index}: {error}"
    try:
        rebuilt = type(error)(message)
    except Exception:
        rebuilt = None
    if rebuilt is not None and str(rebuilt) == message:
        return rebuilt
    error.add_note(message)
    return error


def _run_processes(function, items: list, jobs: int, finished) -> None:
    context = multiprocessing.get_context("spawn")  # fork would inherit a dead GL driver
    workers = min(jobs, len(items))
    pending = iter(enumerate(items))
    pool = concurrent.futures.ProcessPoolExecutor(
        workers, mp_context=context, initializer=_ignore_interrupts
    )
    started: set = set()  # the pool's worker processes (a submission may start one)
    futures: dict = {}  # future: its item's index

    def submit(index: int, item: Any) -> None:
        # the worker a submission may start is born with Ctrl-C blocked, until it ignores it;
        # a Ctrl-C meanwhile is raised at the block's end, once the worker and the item are
        # known here: else the stop could not reach a worker started after the terminal's
        # Ctrl-C, which would run its whole item
        with _interrupts_blocked():
            before = set(multiprocessing.active_children())
            futures[pool.submit(_interruptible, function, item)] = index
            started.update(set(multiprocessing.active_children()) - before)

    with pool:
        try:
            # One item per worker at a time: the pool hands the items submitted to its
            # workers ahead of time, beyond cancelling, so a stopped run would go on with them.
            for index, item in itertools.islice(pending, workers):
                submit(index, item)
            while futures:
                done, _ = concurrent.futures.wait(
                    futures, return_when=concurrent.futures.FIRST_COMPLETED
                )
                for future in done:
                    index = futures.pop(future)
                    error = future.exception()
                    if error is not None:
                        raise _indexed(error, index) from error
                    finished(index, future.result())
                    for next_index, item in itertools.islice(pending, 1):
                        submit(next_index, item)
        except BaseException as error:
            # the items not started yet never start; the running ones end (on Ctrl-C, at
            # once: their KeyboardInterrupt comes back as their result), then the workers
            # exit (leaving the with block waits for them: no process is left)
            if not isinstance(error, Exception):
                _interrupt(started)
            pool.shutdown(wait=True, cancel_futures=True)
            _report_the_rest(futures, finished)
            raise


def _interrupt(processes: set) -> None:
    """Ctrl-C sent to the worker ``processes`` still running, so that their items end now: a
    stop that reached this process alone (SIGTERM from a job scheduler or a container, which
    the command line turns into an exception, or a signal sent to its process only) would
    else wait for the running items to end. One that reached the workers too (a terminal's
    Ctrl-C) makes this a second Ctrl-C, which a worker out of an item notes and no more."""
    if not hasattr(signal, "pthread_sigmask"):  # no POSIX signals: os.kill would kill
        return
    for process in processes:
        if process.is_alive():
            with contextlib.suppress(OSError):
                os.kill(process.pid, signal.SIGINT)


#: In a worker: whether Ctrl-C came while no item ran (:func:`_ignore_interrupts`).
_interrupted = False


def _ignore_interrupts() -> None:
    """A worker's initializer: Ctrl-C (which a terminal sends to every process of the
    command) raises nothing but while an item runs (:func:`_interruptible`); out of one it is
    noted, and the next item is interrupted as it starts (a Ctrl-C that came as the worker
    started would else let it run its whole item). A worker killed by it while it sends a
    result back would leave a part of the message in the pool's queue, which the pool would
    then wait to read to the end, for ever; and a worker interrupted while it waits for an
    item prints a traceback."""
    signal.signal(signal.SIGINT, _note_interrupt)
    if hasattr(signal, "pthread_sigmask"):  # blocked since its start (_interrupts_blocked)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _note_interrupt(signum: int, frame: object) -> None:
    global _interrupted
    _interrupted = True


def _interruptible(function: Callable[[Any], Any], item: Any) -> Any:
    """``function(item)`` in a worker, Ctrl-C raising ``KeyboardInterrupt`` in it (or before
    it, for a Ctrl-C noted since the worker started): the pool sends it back as the item's
    result, and the worker goes on to wait, quietly, for the next item or the end."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        if _interrupted:
            raise KeyboardInterrupt
        return function(item)
    finally:
        signal.signal(signal.SIGINT, _note_interrupt)


@contextlib.contextmanager
def _interrupts_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread in the block (where the OS has that), so that a worker
    process started in it inherits it blocked and no Ctrl-C can stop it before its
    initializer ignores it (a traceback on the terminal). This process still hears of a
    Ctrl-C: the OS hands it to another thread, or it waits for the end of the block."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # the first process started starts multiprocessing's resource tracker, which unblocks
    # SIGINT in the thread that starts it: started beforehand, it leaves the mask alone
    resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        # Python's handlers wait for the block's end: a Ctrl-C that another thread receives
        # still runs its handler in this (main) thread, and raised while a worker process
        # starts it cut the start short (the worker, left without what it was to read,
        # printed a traceback)
        with signals_held():
            yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _report_the_rest(futures: dict, finished) -> None:
    """After a failure: ``finished`` for the items that ended well all the same (their work
    is done: a file written), before the failure is raised; what ``finished`` raises for them
    gives way to that failure."""
    for future, index in futures.items():
        if future.cancelled() or not future.done() or future.exception() is not None:
            continue
        with contextlib.suppress(Exception):
            finished(index, future.result())


def _run_dask(function, items: list, jobs: int, scheduler: str, finished) -> None:
    from distributed import Client, LocalCluster

    cluster = client = None
    try:
        if scheduler == "local":
            # its threads and worker processes are born with Ctrl-C blocked, for good: a
            # terminal's Ctrl-C reaches the whole process group, and a worker interrupted as
            # it starts prints tracebacks and holds up the end; this process stops them
            with _interrupts_blocked():
                cluster = LocalCluster(
                    n_workers=jobs,
                    threads_per_worker=1,  # one GL context, one item at a time per worker
                    processes=True,
                    # any free port: the default 8787 may be taken (another cluster, another
                    # program), and Dask then warns that it moved
                    dashboard_address=":0",
                    # a failing item is raised here, with its index: the workers' log of it
                    # is noise
                    silence_logs=logging.CRITICAL,
                )
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler)
            except OSError as error:
                raise OSError(f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
        _run_on(client, function, items, finished, local=cluster is not None)
    finally:
        # closing a local cluster whose workers are stopping logs their closed connections
        # (INFO, with tracebacks) as it puts its loggers' levels back: not this run's news
        with _dask_logs_below_error_dropped() if cluster is not None else contextlib.nullcontext():
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()


class _BelowError(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return record.levelno >= logging.ERROR


@contextlib.contextmanager
def _dask_logs_below_error_dropped() -> Iterator[None]:
    """Dask's log records below ERROR dropped by the handlers of its ``distributed`` logger
    (where its records go) in the block, whatever levels Dask sets meanwhile."""
    handlers = list(logging.getLogger("distributed").handlers)
    quiet = _BelowError()
    for handler in handlers:
        handler.addFilter(quiet)
    try:
        yield
    finally:
        for handler in handlers:
            handler.removeFilter(quiet)


def _run_on(client, function, items: list, finished, *, local: bool) -> None:
    """The items on ``client``'s cluster, as many at a time as its workers have threads (at
    least one; counted again as items end, workers may join): like the worker processes, a
    failed or interrupted run starts none of the rest, lets the running ones end and reports
    those that ended well. A ``local`` cluster interrupted (Ctrl-C, SIGTERM) is closed at
    once instead: its workers do not hear Ctrl-C, and closing it ends their items."""
    from distributed import as_completed

    pending = iter(enumerate(items))
    running: dict = {}  # future key: (index, future)
    completed = as_completed()

    def submit() -> None:
        slots = max(1, sum(client.nthreads().values())) - len(running)
        for index, item in itertools.islice(pending, max(slots, 0)):
            # pure=False: two equal items are two tasks (their functions may write files)
            future = client.submit(function, item, pure=False)
            running[future.key] = (index, future)
            completed.add(future)

    submit()
    try:
        for future in completed:
            index, _ = running.pop(future.key)
            if future.status == "error":
                error = future.exception()
                raise _indexed(error, index) from error
            finished(index, future.result())
            submit()
    except BaseException as error:
        futures = {future: index for index, future in running.values()}
        if isinstance(error, Exception) or not local:
            _let_end(client, list(futures))
        _report_the_rest(futures, finished)
        raise


def _let_end(client, futures: list) -> None:
    """Wait for ``futures`` to end while the cluster has a worker to run them: a future whose
    worker is gone would never end."""
    from distributed import wait

    while futures:
        try:
            wait(futures, timeout=1.0)
            return
        except TimeoutError:
            pass
        except Exception:  # a cluster that went away: nothing left to wait for
            return
        try:
            if not client.nthreads():
                return
        except Exception:
            return
