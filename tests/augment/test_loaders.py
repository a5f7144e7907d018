"""glmls.augment in a PyTorch DataLoader (num_workers=2): forked workers whether or not the
parent used glmls's GL before, the platform's default start method (fork on Linux before
Python 3.14), spawn, and persistent workers; every case gives what one process gives for the
same indices."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch", reason="torch not installed (the torch extra)")

from augment_loader import AugmentedImages

SCRIPT = Path(__file__).with_name("augment_loader.py")
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def expected(gl):
    dataset = AugmentedImages()
    items = [dataset[i] for i in range(len(dataset))]
    return {
        "images": np.stack([item[0] for item in items]),
        "keypoints": np.stack([item[1] for item in items]),
        "boxes": np.stack([item[2] for item in items]),
    }


@pytest.mark.parametrize(
    ("method", "warm", "persistent"),
    [
        # fork named, not only as the default: Python 3.14 starts workers by forkserver
        ("fork", "cold", "once"),
        ("fork", "warm", "once"),
        ("default", "warm", "once"),
        ("spawn", "warm", "once"),
        ("fork", "warm", "persistent"),
    ],
)
def test_a_data_loader_gives_what_one_process_gives(tmp_path, expected, method, warm, persistent):
    out = tmp_path / "loaded.npz"
    env = dict(os.environ)
    parts = (str(ROOT), str(SCRIPT.parent), env.get("PYTHONPATH", ""))
    env["PYTHONPATH"] = os.pathsep.join(p for p in parts if p)
    done = subprocess.run(
        [sys.executable, "-W", "error", str(SCRIPT), str(out), method, warm, persistent],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    loaded = np.load(out)
    epochs = 2 if persistent == "persistent" else 1
    for epoch in range(epochs):
        assert loaded[f"index{epoch}"].tolist() == list(range(len(expected["images"])))
        np.testing.assert_array_equal(loaded[f"images{epoch}"], expected["images"])
        np.testing.assert_allclose(loaded[f"keypoints{epoch}"], expected["keypoints"], atol=1e-12)
        np.testing.assert_allclose(loaded[f"boxes{epoch}"], expected["boxes"], atol=1e-12)
