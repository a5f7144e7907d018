"""A signal whose Python handler raises (Ctrl-C's KeyboardInterrupt, a timeout's alarm)
while moderngl builds a program: moderngl calls back into Python once per uniform and dies of
an exception raised there, so glmls holds those signals while it compiles
(:mod:`glmls.gl.signals`): the handler runs after the build, and the process warps on. Each
case runs in a fresh interpreter (its programs not compiled yet), with a timeout."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import threading

import pytest

from glmls.gl.signals import signals_held

SCRIPT = """
import os, signal
import numpy as np
import _moderngl
import glmls

class Alarm(Exception):
    pass

def handler(signum, frame):
    raise Alarm

signal.signal(signal.SIGUSR1, handler)
original = _moderngl.make_uniform

def uniform(*args, **kwargs):
    # the signal arrives while moderngl makes the program's first uniform
    _moderngl.make_uniform = original
    os.kill(os.getpid(), signal.SIGUSR1)
    return original(*args, **kwargs)

_moderngl.make_uniform = uniform
src = np.array([[5.0, 5.0], [20.0, 5.0], [12.0, 20.0]])
image = np.arange(24 * 24, dtype=np.uint8).reshape(24, 24)
try:
    glmls.warp(image, src, src + [1.0, 0.5])
    print("no alarm")
except Alarm:
    print("alarm after the build")
out = glmls.warp(image, src, src + [1.0, 0.5])
print("warped", out.shape, int(out[12, 12]))
"""


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1"), reason="POSIX signals")
def test_a_handler_that_raises_during_a_compile_runs_after_it():
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(SCRIPT)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, (done.returncode, done.stderr[-3000:])
    lines = done.stdout.splitlines()
    assert lines[0] == "alarm after the build", done.stdout
    assert lines[1].startswith("warped (24, 24)"), done.stdout


def test_handlers_come_back_and_the_signals_noted_are_raised_after():
    seen: list[int] = []

    def handler(signum: int, frame: object) -> None:
        seen.append(signum)

    previous = signal.signal(signal.SIGUSR2, handler)
    try:
        with signals_held():
            signal.raise_signal(signal.SIGUSR2)
            signal.raise_signal(signal.SIGUSR2)
            assert seen == []  # noted, not handled, inside
            assert signal.getsignal(signal.SIGUSR2) is not handler
        assert seen == [signal.SIGUSR2]  # once, after the block
        assert signal.getsignal(signal.SIGUSR2) is handler
        outside: list = []
        thread = threading.Thread(target=lambda: outside.append(_inside_thread()))
        thread.start()
        thread.join()
        assert outside == [True]  # another thread changes no handler
    finally:
        signal.signal(signal.SIGUSR2, previous)


def _inside_thread() -> bool:
    before = signal.getsignal(signal.SIGUSR2)
    with signals_held():
        return signal.getsignal(signal.SIGUSR2) is before
