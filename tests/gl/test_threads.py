"""glmls from threads and processes: any thread may use glmls's contexts (one call at a time),
released contexts raise ReleasedError (forked and spawned processes: test_fork.py). Process
cases run in a fresh interpreter with a timeout, so that a hang fails the test."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import moderngl
import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.gl.context import create_headless, get_context
from glmls.gl.locks import ContextLock

SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
DST = np.array([[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]])
COMMON = """
import multiprocessing, os, sys
import numpy as np
import glmls
SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
DST = np.array([[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]])

def image(seed):
    return np.random.default_rng(seed).integers(0, 255, (48, 56, 3), dtype=np.uint8)

def warp(seed):
    return glmls.warp(image(seed), SRC, DST, weight="gaussian", radius=30.0)
"""


def run_script(body: str, tmp_path, timeout: float = 120) -> subprocess.CompletedProcess:
    """``body`` after COMMON, as a script file (spawned workers import its functions)."""
    script = tmp_path / "script.py"
    script.write_text(COMMON + "\n" + textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=timeout
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done


def assert_quiet_run(script, stdout: str) -> None:
    """Run ``script`` under ``-X dev -W error``: exit status 0, ``stdout`` as given, nothing on
    stderr (no segfault, ResourceWarning or traceback)."""
    done = subprocess.run(
        [sys.executable, "-X", "dev", "-W", "error", str(script)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and done.stdout == stdout, done.stderr[-3000:]
    assert done.stderr == ""


def image(seed):
    return np.random.default_rng(seed).integers(0, 255, (48, 56, 3), dtype=np.uint8)


# -- processes ---------------------------------------------------------------------------------


def test_releasing_the_default_context_leaves_clear_errors(tmp_path):
    out = run_script(
        """
        m = glmls.MLS(SRC, DST)
        expected = m(SRC)
        glmls.gl.get_context().release()
        for call in (lambda: m(SRC), lambda: m.warp(image(0)), lambda: m.error_field((8, 8))):
            try:
                call()
            except glmls.ReleasedError as error:
                print("ReleasedError:", error)
        m.release()  # harmless
        with glmls.MLS(SRC, DST) as fresh:  # a new default context
            assert np.allclose(fresh(SRC), expected, atol=1e-6)
        """,
        tmp_path,
    ).stdout
    assert out.count("ReleasedError:") == 3 and "context" in out


def test_exit_with_live_objects_threads_and_forked_children_is_quiet(tmp_path):
    """Exit with GL objects alive (MLS, own contexts, a volume MLS, an augmenter), daemon
    threads warping, and a forked child that warps through its helper from daemon threads:
    exit status 0 everywhere, nothing on stderr under -X dev -W error (no segfault, no
    ResourceWarning, no traceback)."""
    script = tmp_path / "script.py"
    script.write_text(
        COMMON
        + textwrap.dedent(
            """
            import threading
            from glmls.gl.context import create_headless

            m = glmls.MLS(SRC, DST)
            own = create_headless()
            mine = glmls.MLS(SRC, DST, ctx=own)
            mine.warp(image(0))
            src3 = np.array([[1.0, 1, 1], [12, 2, 1], [2, 10, 3], [3, 4, 8]])
            m3 = glmls.MLS(src3, src3 + [0, 0, 1])
            m3.warp(np.zeros((8, 8, 8), np.uint8))
            augment = glmls.augment.Augment("grid", seed=0)
            augment(image(0)[None])

            def busy():
                while True:
                    warp(0)

            pid = os.fork()
            if pid == 0:
                for _ in range(2):
                    threading.Thread(target=busy, daemon=True).start()
                m.warp(image(1))
                sys.exit(0)
            for _ in range(2):
                threading.Thread(target=busy, daemon=True).start()
            assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
            print("done")
            """
        )
    )
    assert_quiet_run(script, "done\n")


@pytest.mark.parametrize("forked", [False, True], ids=["process", "forked-child"])
def test_a_daemon_thread_calling_glmls_after_its_exit_functions_waits_quietly(tmp_path, forked):
    """A daemon thread that calls glmls once glmls's exit functions have released its
    contexts (or ended a forked child's helper) waits for the end of the process: no
    ReleasedError or GLUnavailableError traceback, no new context or helper at exit. The
    program's own exit function runs after glmls's (registered before the import) and lets
    the thread go."""
    script = tmp_path / "script.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import atexit, os, sys, threading
            go = threading.Event()
            called = threading.Event()
            returned = []

            def late():
                go.set()
                called.wait(5)
                called.clear()
                called.wait(2)  # a traceback would be printed meanwhile
                print("returned" if returned else "waiting", flush=True)

            atexit.register(late)  # before glmls's: runs after them
            import numpy as np
            import glmls
            SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
            DST = SRC + [[4.0, -2.0], [0, 0], [3, -4], [0, 0]]
            image = np.zeros((48, 56, 3), np.uint8)

            def busy():
                go.wait()
                called.set()
                glmls.warp(image, SRC, DST)
                returned.append(True)

            glmls.warp(image, SRC, DST)
            if {forked!r}:
                pid = os.fork()
                if pid:
                    atexit.unregister(late)  # the child's threads are the case
                    assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
                    sys.exit(0)
                glmls.warp(image, SRC, DST)  # the child's helper
            threading.Thread(target=busy, daemon=True).start()
            """
        )
    )
    assert_quiet_run(script, "waiting\n")


def test_a_daemon_thread_rendering_in_its_own_block_at_exit_lets_the_process_end(tmp_path):
    """A daemon thread that holds the shared context (``with context:``) and warps in it
    while the interpreter exits: glmls's exit function waited for that context's lock
    while holding the registry's, and the thread's next warp (get_context) for the
    registry's: the process never ended. It ends now, quietly."""
    script = tmp_path / "script.py"
    script.write_text(
        textwrap.dedent(
            """
            import threading, time
            import numpy as np
            import glmls
            rng = np.random.default_rng(0)
            image = rng.integers(0, 256, (120, 120, 3), dtype=np.uint8)
            src = rng.uniform(10, 110, (10, 2))
            dst = src + rng.normal(0, 3, (10, 2))
            context = glmls.gl.get_context()
            started = threading.Event()

            def render():
                while True:
                    with context:
                        started.set()
                        glmls.warp(image, src, dst, method="backward")
                        glmls.warp(image, src, dst, method="backward")

            threading.Thread(target=render, daemon=True).start()
            started.wait(60)
            time.sleep(0.2)
            print("done", flush=True)
            """
        )
    )
    for _ in range(3):  # the thread was inside its block at exit in most runs
        assert_quiet_run(script, "done\n")


# -- threads -----------------------------------------------------------------------------------


def test_warp_from_other_threads_and_from_several_at_once(gl):
    expected = {seed: glmls.warp(image(seed), SRC, DST, ctx=gl) for seed in range(6)}
    result = {}
    thread = threading.Thread(target=lambda: result.update(one=glmls.warp(image(0), SRC, DST)))
    thread.start()
    thread.join(60)
    assert_array_equal(result["one"], expected[0])
    with ThreadPoolExecutor(3) as pool:  # a web server's pool: they take turns
        outputs = list(pool.map(lambda seed: glmls.warp(image(seed), SRC, DST), range(6)))
    for seed, out in enumerate(outputs):
        assert_array_equal(out, expected[seed])


def test_a_thread_calling_back_to_back_lets_the_others_take_their_turn(gl):
    """One thread warps in a tight loop: another thread's single call, and the context's
    release(), are served within a few of its calls. The lock, taken again by its holder
    before the woken waiter ran, kept them waiting for as long as the loop went on."""
    context = create_headless()
    stop, calls = threading.Event(), []
    with glmls.MLS(SRC, DST, shape=(48, 56), ctx=context) as m:

        def loop():
            started = time.monotonic()
            while not stop.is_set() and time.monotonic() - started < 60:
                m.warp(image(0))
                calls.append(time.monotonic())

        worker = threading.Thread(target=loop, daemon=True)
        worker.start()
        while len(calls) < 5:
            time.sleep(0.01)
        out = glmls.warp(image(1), SRC, DST, ctx=context)  # waits its turn behind the loop
        served = len(calls)
        stop.set()
        worker.join(60)
    assert not worker.is_alive() and len(calls) - served <= 2
    assert_array_equal(out, glmls.warp(image(1), SRC, DST, ctx=gl))
    context.release()


def test_the_context_lock_serves_its_waiters_in_turn():
    """A release hands the lock to the longest waiting thread: the holder that takes it
    again comes after them; its own calls nest."""
    lock = ContextLock()
    order = []

    def take(name):
        with lock:
            order.append(name)

    def wait_for(count):
        deadline = time.monotonic() + 30
        while lock.waiting < count and time.monotonic() < deadline:
            time.sleep(0.001)

    lock.acquire()
    lock.acquire()
    assert lock.count() == 2
    threads = [threading.Thread(target=take, args=(name,)) for name in "ab"]
    for n, thread in enumerate(threads, 1):
        thread.start()
        wait_for(n)  # a in line first, then b
    lock.release()
    assert lock.count() == 1 and lock.waiting == 2  # nested: still held
    lock.release()  # to a
    lock.acquire()  # after b
    order.append("holder")
    lock.release()
    for thread in threads:
        thread.join(10)
    assert order == ["a", "b", "holder"] and lock.count() == 0 and lock.waiting == 0


def test_an_mls_made_on_one_thread_works_on_another(gl):
    holder = {}

    def make():
        holder["m"] = glmls.MLS(SRC, DST, ctx=gl)

    thread = threading.Thread(target=make)
    thread.start()
    thread.join(60)
    m = holder["m"]
    try:
        with ThreadPoolExecutor(2) as pool:
            points = list(pool.map(lambda _: m(SRC), range(4)))
        for f in points:
            np.testing.assert_allclose(f, DST, atol=1e-3)
        np.testing.assert_allclose(m(SRC), DST, atol=1e-3)  # and here
    finally:
        m.release()


def test_a_context_kept_current_elsewhere_names_the_rule(gl):
    own = create_headless()
    try:
        own.make_current()  # kept current in this thread
        errors = []

        def use():
            try:
                glmls.MLS(SRC, DST, ctx=own)
            except glmls.ContextError as error:
                errors.append(str(error))

        thread = threading.Thread(target=use)
        thread.start()
        thread.join(60)
        assert errors and "current in another thread" in errors[0] and "unbind()" in errors[0]
        own.unbind()
        thread = threading.Thread(target=use)
        thread.start()
        thread.join(60)
        assert len(errors) == 1  # now it works from the other thread
    finally:
        own.release()


def test_a_context_kept_current_by_a_thread_that_ended_works_elsewhere(gl):
    """A thread that bound a context with make_current() and ended without unbind(): EGL
    would keep the context current in the ended thread, where no other thread could bind it
    (every GL call failing with moderngl's "cannot create buffer"); the thread's end unbinds
    it."""
    own = create_headless()
    try:
        expected = glmls.warp(image(0), SRC, DST, ctx=own)
        thread = threading.Thread(target=own.make_current)
        thread.start()
        thread.join(60)
        results = []
        thread = threading.Thread(
            target=lambda: results.append(glmls.warp(image(0), SRC, DST, ctx=own))
        )
        thread.start()
        thread.join(60)
        assert len(results) == 1 and np.array_equal(results[0], expected)
        assert np.array_equal(glmls.warp(image(0), SRC, DST, ctx=own), expected)
    finally:
        own.release()


def test_an_adopted_context_belongs_to_its_thread():
    mgl = moderngl.create_context(standalone=True, backend="egl", require=430)
    try:
        wrapper = get_context(mgl)  # adopted here, where it is current
        with glmls.MLS(SRC, DST, ctx=wrapper) as m:
            np.testing.assert_allclose(m(SRC), DST, atol=1e-3)
            errors = []

            def use():
                try:
                    m(SRC)
                except glmls.ContextError as error:
                    errors.append(str(error))

            thread = threading.Thread(target=use)
            thread.start()
            thread.join(60)
        assert errors and "a window's, adopted" in errors[0]
        wrapper.release()
    finally:
        mgl.release()


def test_a_released_own_context_raises_released_error():
    own = create_headless()
    m = glmls.MLS(SRC, DST, ctx=own)
    own.release()
    with pytest.raises(glmls.ReleasedError, match="context"):
        m(SRC)
    with pytest.raises(glmls.ReleasedError):
        m.warp(image(0))
    m.release()  # harmless


# -- the program cache -------------------------------------------------------------------------


def test_the_program_cache_stays_bounded():
    """Every configuration compiles its own programs: the cache keeps the most recently used
    ``max_programs`` and releases the others; evicted ones are compiled again on demand."""
    own = create_headless(max_programs=16)
    points = np.array([[20.0, 20.0], [40.0, 30.0]])
    try:
        first = None
        for interpolating in (False, True):
            for transform in glmls.TRANSFORMS:
                for weight in glmls.WEIGHTS:
                    options = {"weight": weight, "radius": 80.0, "interpolating": interpolating}
                    with glmls.MLS(SRC, DST, transform=transform, ctx=own, **options) as m:
                        f = m(points)
                        first = f if first is None else first
                    assert own.compiled <= 16
        with glmls.MLS(SRC, DST, transform="affine", ctx=own, radius=80.0) as m:
            np.testing.assert_allclose(m(points), first, rtol=0, atol=0)  # compiled again
    finally:
        own.release()
    with pytest.raises(ValueError, match="max_programs must be >= 16"):
        create_headless(max_programs=4)


def _wait_for_the_lock(context, seconds=20.0) -> bool:
    """Whether another thread takes ``context`` within ``seconds``."""
    taken = threading.Event()

    def take():
        with context.use():
            taken.set()

    threading.Thread(target=take, daemon=True).start()
    return taken.wait(seconds)


def test_ctrl_c_while_waiting_for_the_context_lets_it_go():
    """Ctrl-C while the main thread waits for a context another thread holds: Python runs
    the handler as the lock's acquire() returns, so the KeyboardInterrupt left the lock held
    by the main thread (reentrant: it went on working) and every other thread waited on it
    for ever."""
    context = create_headless()
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        holding, go = threading.Event(), threading.Event()

        def hold():
            with context.use():
                holding.set()
                go.wait(30)

        threading.Thread(target=hold, daemon=True).start()
        assert holding.wait(30)

        def interrupt():
            # a thread inherits the signal mask of the thread that made it
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
            signal.raise_signal(signal.SIGINT)  # noted now, handled in the main thread ...
            time.sleep(0.2)
            go.set()  # ... once its acquire() returns

        threading.Timer(0.2, interrupt).start()
        with pytest.raises(KeyboardInterrupt), context.use():
            pass
        assert _wait_for_the_lock(context)
    finally:
        signal.signal(signal.SIGINT, handler)
        context.release()


def test_ctrl_c_while_freeing_dropped_objects_lets_the_context_go():
    """An interrupt while a context frees the objects dropped without release() (at its next
    use) escaped that use with the lock held and the context bound; the object being freed
    was lost. Now the use is undone and the object freed at the next one."""
    context = create_headless()
    released = []

    class Dropped:
        def release(self):
            if not released:
                released.append("interrupted")
                raise KeyboardInterrupt
            released.append("freed")

    try:
        context.release_later(Dropped())
        with pytest.raises(KeyboardInterrupt), context.use():
            pass
        assert _wait_for_the_lock(context)
        assert released == ["interrupted", "freed"]  # the other thread's use freed it
    finally:
        context.release()
