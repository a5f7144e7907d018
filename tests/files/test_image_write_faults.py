"""Image files written whole or not at all: a short write (a full disk, here a file-size
limit) is an error naming the file, for every format, and leaves no file behind."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import child_env, write_cli_handles
from PIL import Image

#: Runs the rest of its command line as Python with writes beyond LIMIT bytes cut short
#: (SIGXFSZ ignored: ``write`` returns a short count or EFBIG, as on a full disk).
LIMITED = (
    "import os, resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
    "resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000)); "
    "os.execv(sys.executable, [sys.executable, *sys.argv[1:]])"
)


def _limited(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    command = [sys.executable, "-c", LIMITED, *args]
    return subprocess.run(
        command, cwd=cwd, env=child_env(), capture_output=True, text=True, timeout=300
    )


def _noise() -> np.ndarray:
    return np.random.default_rng(0).integers(0, 256, (256, 256, 3), dtype=np.uint8)


@pytest.mark.parametrize("suffix", [".jpg", ".png", ".tif", ".bmp", ".webp"])
def test_imwrite_cut_short_raises_and_leaves_nothing(tmp_path, suffix):
    np.save(tmp_path / "noise.npy", _noise())
    code = (
        "import glmls, numpy as np; "
        f"glmls.imwrite('out{suffix}', np.load('noise.npy')); print('written')"
    )
    result = _limited("-c", code, cwd=tmp_path)
    assert result.returncode != 0 and "written" not in result.stdout
    assert f"OSError: out{suffix}: cannot write: File too large" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["noise.npy"]


def test_warp_to_a_jpeg_cut_short_fails_without_output(tmp_path):
    Image.fromarray(_noise()).save(tmp_path / "noise.png")
    write_cli_handles(tmp_path)
    result = _limited(
        "-m", "glmls", "warp", "noise.png", "out.jpg", "--handles", "h.json", cwd=tmp_path
    )
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip() == "glmls warp: out.jpg: cannot write: File too large"
    assert not list(tmp_path.glob("*out.jpg*"))


def test_augment_to_jpegs_cut_short_fails_without_output(tmp_path):
    Image.fromarray(_noise()).save(tmp_path / "noise.jpg")
    result = _limited(
        "-m", "glmls", "augment", "noise.jpg", "aug", "--n", "1", "--quiet", cwd=tmp_path
    )
    assert result.returncode != 0
    assert "aug/noise_000.jpg: cannot write: File too large" in result.stderr
    assert "Traceback" not in result.stderr
    assert not list(tmp_path.glob("aug/*noise*"))
