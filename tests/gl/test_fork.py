"""glmls in processes forked from one that used GL (data-loader workers): glmls.warp works
there through a helper process, bit for bit as in the parent; making a context there raises
GLUnavailableError at once; children forked before any GL and spawned children make their own
contexts; the parent keeps working. Each case runs as a script in a fresh interpreter, every
child with a timeout, so that a hang fails the test instead of stopping the suite."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from glmls.gl import helper

COMMON = """
import multiprocessing, os, sys, threading
import numpy as np
import glmls
SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
DST = np.array([[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]])
METHODS = ("quads", "backward")

def image(seed):
    return np.random.default_rng(seed).integers(0, 255, (48, 56, 3), dtype=np.uint8)

def warp(seed, method="quads"):
    return glmls.warp(image(seed), SRC, DST, weight="gaussian", radius=30.0, method=method)

def warps(seed):
    return [warp(seed, method) for method in METHODS], os.getpid()

def in_child(function, timeout=60):
    # function() in a forked child, bounded by timeout: its result, or the exception it raised
    receive, send = multiprocessing.Pipe(duplex=False)
    def main():
        try:
            send.send((True, function()))
        except BaseException as error:
            send.send((False, error))
    child = multiprocessing.get_context("fork").Process(target=main)
    child.start()
    child.join(timeout)
    if child.is_alive():
        child.kill()
        raise AssertionError("the forked child hung")
    assert receive.poll(), f"the child exited with {child.exitcode} and no answer"
    ok, value = receive.recv()
    if not ok:
        raise value
    return value

def check_parent(expected):
    for method, result in zip(METHODS, expected):
        assert np.array_equal(warp(0, method), result), method
    assert glmls.gl.get_context().mgl.error == "GL_NO_ERROR"
"""


def run_script(body: str, tmp_path, timeout: float = 120) -> str:
    """``body`` after COMMON, as a script file (spawned workers import its functions)."""
    script = tmp_path / "script.py"
    script.write_text(COMMON + "\n" + textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=timeout
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def test_a_child_forked_after_the_parent_warped_warps_bit_for_bit(tmp_path):
    out = run_script(
        """
        expected = warps(0)[0]
        results, pid = in_child(lambda: warps(0))
        assert pid != os.getpid()
        for method, a, b in zip(METHODS, results, expected):
            assert a.dtype == b.dtype and np.array_equal(a, b), method

        def errors():  # what fails in the child fails as in the parent
            found = []
            for attempt in (
                lambda: glmls.warp(image(0), SRC, DST, methd="quads"),
                lambda: glmls.warp(image(0), SRC, DST, weight="nope"),
                lambda: glmls.MLS(SRC, DST),  # a context of its own: refused, with advice
            ):
                try:
                    attempt()
                    found.append("no error")
                except Exception as error:
                    found.append(f"{type(error).__name__}: {error}")
            return found
        print("\\n".join(in_child(errors)))
        check_parent(expected)
        """,
        tmp_path,
    )
    unknown, bad_value, mls = out.splitlines()
    assert unknown == "TypeError: warp() got an unknown keyword methd"
    assert bad_value.startswith("ValueError") and "nope" in bad_value
    assert mls.startswith("GLUnavailableError") and "'spawn' start method" in mls
    assert "glmls.warp() works here" in mls


def test_children_forked_before_any_gl_and_spawned_children_work(tmp_path):
    run_script(
        """
        if __name__ == "__main__":
            before, pid = in_child(lambda: warps(1))
            expected = warps(1)[0]  # now the parent uses GL
            for a, b in zip(before, expected):
                assert np.array_equal(a, b)
            with multiprocessing.get_context("spawn").Pool(1) as pool:
                spawned, pid = pool.apply(warps, (1,))
            for a, b in zip(spawned, expected):
                assert np.array_equal(a, b)
            check_parent(warps(0)[0])
        """,
        tmp_path,
    )


def test_a_child_forked_while_another_thread_holds_the_context_works(tmp_path):
    run_script(
        """
        expected = warps(2)[0]
        context = glmls.gl.get_context()
        held, release = threading.Event(), threading.Event()

        def hold():
            with context.use():
                held.set()
                release.wait(60)

        thread = threading.Thread(target=hold)
        thread.start()
        held.wait(60)
        try:
            results, pid = in_child(lambda: warps(2))
        finally:
            release.set()
            thread.join()
        for a, b in zip(results, expected):
            assert np.array_equal(a, b)
        check_parent(warps(0)[0])
        """,
        tmp_path,
    )


def test_a_fork_pool_of_persistent_workers_warps_after_the_parent_did(tmp_path):
    """A multiprocessing Pool standing in for a DataLoader: two forked workers, each doing
    several warps through its one helper process, while the parent warps too."""
    run_script(
        """
        expected = [warps(seed)[0] for seed in range(6)]
        with multiprocessing.get_context("fork").Pool(2) as pool:
            pending = pool.map_async(warps, range(6), chunksize=1)
            check_parent(expected[0])  # the parent works meanwhile
            answers = pending.get(timeout=90)
            again = pool.map(warps, range(6), chunksize=3)  # the same workers again
        pids = {pid for _, pid in answers + again}
        assert len(pids) <= 2 and os.getpid() not in pids, pids
        for (results, _), wanted in zip(answers + again, expected + expected):
            for a, b in zip(results, wanted):
                assert np.array_equal(a, b)
        check_parent(expected[0])
        """,
        tmp_path,
    )


def test_the_helper_raises_and_warns_in_the_caller():
    with pytest.warns(UserWarning, match="from the helper"):
        assert helper.call("warnings", "warn", ("from the helper", UserWarning)) is None
    with pytest.raises(ZeroDivisionError):
        helper.call("operator", "truediv", (1, 0))
    assert helper.call("operator", "add", (np.arange(3), 1)).tolist() == [1, 2, 3]
