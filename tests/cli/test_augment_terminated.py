"""``glmls augment`` stopped by SIGTERM (a job scheduler's kill, a container's stop) cleans
up as it does on Ctrl-C: no temporary file and no folder of its own are left behind."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import numpy as np
from helpers import child_env

import glmls


def test_sigterm_midway_leaves_nothing(tmp_path):
    rng = np.random.default_rng(3)
    glmls.imwrite(tmp_path / "big.png", rng.integers(0, 256, (128, 128, 3), dtype=np.uint8))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "glmls", "augment", "big.png", "out", "--n", "2000"]
    child = subprocess.Popen(
        command, cwd=tmp_path, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and child.poll() is None:
            if out.is_dir() and len(list(out.iterdir())) >= 3:  # writing its temporaries
                break
            time.sleep(0.05)
        assert child.poll() is None, "it finished before it could be stopped"
        child.send_signal(signal.SIGTERM)
        _, stderr = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == 128 + signal.SIGTERM, stderr
    assert stderr.decode().strip() == "glmls augment: terminated"
    assert not out.exists()
