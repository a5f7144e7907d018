"""``glmls.cli.main.main`` called as a library function: it turns SIGTERM into an exception
only while its command runs, gives the caller's handler back however the command ends, and
runs in a thread other than the main one (where Python allows no signal handler)."""

from __future__ import annotations

import importlib
import signal
import threading

cli_main = importlib.import_module("glmls.cli.main")

#: A command that fails on its input at once: exit status 2, no GL.
_FAILING = ["warp", "missing.png", "out.png", "--handles", "missing.json"]


def _caller_s_handler(signum, frame):
    raise AssertionError("not to be called")


def test_the_caller_s_handler_is_back_after_each_call(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    previous = signal.signal(signal.SIGTERM, _caller_s_handler)
    try:
        for _ in range(2):
            assert cli_main.main(_FAILING) == 2
            assert signal.getsignal(signal.SIGTERM) is _caller_s_handler
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert "no such file" in capsys.readouterr().err


def test_a_handler_not_set_from_python_comes_back_as_the_default(tmp_path, monkeypatch, capsys):
    """signal.signal answers None for a handler that C code installed; None cannot be set
    back, so the default action is."""
    monkeypatch.chdir(tmp_path)
    calls = []
    real = signal.signal

    def signal_from_c(signum, handler):
        calls.append(handler)
        answer = real(signum, handler)
        return None if len(calls) == 1 else answer

    previous = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(cli_main.signal, "signal", signal_from_c)
    try:
        assert cli_main.main(_FAILING) == 2
        assert calls[-1] == signal.SIG_DFL
    finally:
        real(signal.SIGTERM, previous)
    capsys.readouterr()


def test_main_runs_in_another_thread(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    before = signal.getsignal(signal.SIGTERM)
    codes = []
    thread = threading.Thread(target=lambda: codes.append(cli_main.main(_FAILING)))
    thread.start()
    thread.join(60)
    assert codes == [2]
    assert signal.getsignal(signal.SIGTERM) is before
    capsys.readouterr()
