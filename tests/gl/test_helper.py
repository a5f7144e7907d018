"""The helper process of glmls.gl.helper (GL work for a process forked from one that used GL)
under stress: a call interrupted by a signal, a helper killed mid-call, answers that do not
unpickle, Ctrl-C, a caller that dies mid-call, large arrays, grandchildren. Every case runs as
a script in a fresh interpreter under ``-X dev -W error`` with a timeout, so that a hang fails
the test instead of stopping the suite, and its standard error must be empty: no traceback, no
ResourceWarning."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

COMMON = """
import os, signal, sys, threading, time
import numpy as np
import glmls
from glmls.gl import helper

SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
DST = np.array([[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]])

class Interrupted(Exception):
    pass

def interrupt(*_):
    raise Interrupted()

# Ctrl-C raises KeyboardInterrupt here even where the tests run as a background job, which
# starts Python with SIGINT ignored
signal.signal(signal.SIGINT, signal.default_int_handler)

def image(seed, size=(48, 56, 3)):
    return np.random.default_rng(seed).integers(0, 255, size, dtype=np.uint8)

def in_fork(function):
    # function() in a child forked with os.fork; its exit status (1 where it raised)
    pid = os.fork()
    if pid == 0:
        try:
            function()
            code = 0
        except BaseException:
            import traceback
            traceback.print_exc()
            code = 1
        sys.stdout.flush()
        os._exit(code)
    return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
"""


def ended(pid: int) -> bool:
    """Whether process ``pid`` has ended (gone, or a zombie that no one reaped yet)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] in "ZX"
    except (FileNotFoundError, ProcessLookupError):
        return True


def wait_ended(pid: int, seconds: float = 5) -> bool:
    deadline = time.monotonic() + seconds
    while not ended(pid):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def run_script(body: str, tmp_path, timeout: float = 60, env: dict | None = None) -> str:
    """``body`` after COMMON in a fresh interpreter; its stdout. It must exit with status 0
    and write nothing on stderr."""
    script = tmp_path / "script.py"
    script.write_text(COMMON + "\n" + textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, "-X", "dev", "-W", "error", str(script)],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stderr == "", done.stderr[-3000:]
    return done.stdout


def test_a_call_interrupted_in_the_caller_leaves_no_stale_answer_and_ends_the_helper(tmp_path):
    """An exception raised by a signal handler (a timeout's) or Ctrl-C while the caller waits
    for the helper must not leave the helper's late answer to be read as the next call's: the
    helper is ended at once, and the next call starts another."""
    out = run_script(
        """
        signal.signal(signal.SIGALRM, interrupt)
        signal.setitimer(signal.ITIMER_REAL, 0.3)
        try:
            helper.call("time", "sleep", (1.5,))
            print("not interrupted")
        except Interrupted:
            print("interrupted")
        print(helper.call("operator", "add", (1, 2)))
        pid = helper.process_id()
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        try:
            helper.call("time", "sleep", (5,))
        except KeyboardInterrupt:
            print("KeyboardInterrupt")
        try:
            os.kill(pid, 0)
            print("the old helper runs on")
        except ProcessLookupError:  # ended and reaped at once, not after its 5 s
            print(helper.call("operator", "add", (1, 2)), helper.process_id() != pid)
        """,
        tmp_path,
    )
    assert out.splitlines() == ["interrupted", "3", "KeyboardInterrupt", "3 True"]


def test_a_warp_interrupted_in_a_forked_child_does_not_return_the_old_image(tmp_path):
    out = run_script(
        """
        expected = glmls.warp(image(2), SRC, DST)  # the parent uses GL: children use helpers

        def child():
            signal.signal(signal.SIGALRM, interrupt)
            signal.setitimer(signal.ITIMER_REAL, 0.2)  # the helper takes longer to start
            try:
                glmls.warp(image(1), SRC, DST)
                print("not interrupted")
            except Interrupted:
                print("interrupted")
            print("right image:", np.array_equal(glmls.warp(image(2), SRC, DST), expected))

        print("status", in_fork(child))
        """,
        tmp_path,
    )
    assert out.split("\n")[:3] == ["interrupted", "right image: True", "status 0"]


def test_sigint_reaches_the_caller_only_and_a_killed_helper_is_replaced(tmp_path):
    """Ctrl-C in a terminal signals the whole process group: the helper ignores it (its caller
    decides), so that it prints no traceback and a caller that carries on keeps its helper. A
    helper killed mid-call makes the call raise at once, saying so; the next call works."""
    out = run_script(
        """
        helper.call("operator", "add", (1, 2))
        pid = helper.process_id()
        threading.Timer(0.3, os.kill, (pid, signal.SIGINT)).start()
        print(helper.call("time", "sleep", (1,)), helper.process_id() == pid)
        threading.Timer(0.3, os.kill, (pid, signal.SIGKILL)).start()
        start = time.monotonic()
        try:
            helper.call("time", "sleep", (30,))
        except glmls.GLUnavailableError as error:
            print(type(error).__name__, "after", round(time.monotonic() - start) < 10)
            print(error)
        print(helper.call("operator", "add", (1, 2)), helper.process_id() != pid)
        helper.stop()
        """,
        tmp_path,
    )
    kept, first, message, last = out.splitlines()
    assert kept == "None True"
    assert first == "GLUnavailableError after True"
    assert "killed by signal 9 (SIGKILL)" in message
    assert last == "3 True"


def test_answers_that_cannot_be_sent_or_read_leave_the_helper_in_step(tmp_path):
    (tmp_path / "oddities.py").write_text(
        textwrap.dedent(
            """
            class Odd(Exception):
                def __init__(self, a, b):  # pickles as Odd(a): does not unpickle
                    super().__init__(a)

            def raise_odd():
                raise Odd(1, 2)

            def unpicklable():
                return [bytes(300_000), lambda: 0]
            """
        )
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), *sys.path]))
    out = run_script(
        """
        for name in ("raise_odd", "unpicklable"):
            try:
                helper.call("oddities", name)
            except Exception as error:
                print(type(error).__name__, "|", error)
            print(helper.call("operator", "add", (1, 2)))
        """,
        tmp_path,
        env=env,
    )
    odd, three, unpicklable, three_again = out.splitlines()
    assert odd.startswith("RuntimeError | the answer of oddities.raise_odd could not be read")
    assert unpicklable.startswith("RuntimeError | the result of oddities.unpicklable could")
    assert three == three_again == "3"


def test_large_arrays_go_both_ways_and_the_helper_ends_with_its_caller(tmp_path):
    out = run_script(
        """
        big = np.arange(64 * 224 * 224 * 3, dtype=np.uint32).reshape(64, 224, 224, 3)
        start = time.monotonic()
        back = helper.call("numpy", "add", (big, 1))
        print(back.dtype, back.shape, bool((back - big == 1).all()), back.flags.writeable)
        print("fast:", time.monotonic() - start < 20)
        print(helper.process_id())
        """,
        tmp_path,
    )
    kind, fast, pid = out.splitlines()
    assert kind == "uint32 (64, 224, 224, 3) True True" and fast == "fast: True"
    assert wait_ended(int(pid)), "the helper outlived its caller"


def test_a_helper_whose_caller_died_mid_call_ends_quietly(tmp_path):
    script, noted = tmp_path / "caller.py", tmp_path / "helper.pid"
    script.write_text(
        COMMON
        + textwrap.dedent(
            f"""
            helper.call("operator", "add", (1, 2))
            __import__("pathlib").Path({str(noted)!r}).write_text(str(helper.process_id()))
            helper.call("time", "sleep", (1,))
            """
        )
    )
    with subprocess.Popen(
        [sys.executable, "-X", "dev", "-W", "error", str(script)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as caller:
        try:
            deadline = time.monotonic() + 60
            while not noted.exists() or not noted.read_text():
                assert time.monotonic() < deadline and caller.poll() is None, "no helper"
                time.sleep(0.05)
            time.sleep(0.3)
            os.kill(caller.pid, signal.SIGKILL)
            # stderr ends when the helper, which shares it, has gone too
            _, stderr = caller.communicate(timeout=30)
        finally:
            caller.kill()
    assert stderr == ""
    assert wait_ended(int(noted.read_text())), "the helper outlived its caller"


def test_children_and_grandchildren_of_a_gl_process_warp_without_warnings(tmp_path):
    """A forked child forks again, in the middle of another thread's helper call: each process
    has a helper of its own; the inherited ones are left alone (no ResourceWarning, no bytes
    written into the parent's helper)."""
    out = run_script(
        """
        expected = glmls.warp(image(0), SRC, DST)

        def grandchild():
            print("grandchild", np.array_equal(glmls.warp(image(0), SRC, DST), expected))

        def child():
            assert np.array_equal(glmls.warp(image(0), SRC, DST), expected)
            busy = threading.Thread(target=lambda: helper.call("time", "sleep", (0.5,)))
            busy.start()
            time.sleep(0.1)
            print("grandchild status", in_fork(grandchild))
            busy.join()
            print("child", np.array_equal(glmls.warp(image(0), SRC, DST), expected))

        print("child status", in_fork(child))
        """,
        tmp_path,
        timeout=120,
    )
    assert out.splitlines() == [
        "grandchild True",
        "grandchild status 0",
        "child True",
        "child status 0",
    ]
