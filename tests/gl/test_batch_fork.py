"""glmls.warp_batch in processes forked from one that used GL (data-loader workers): it runs
through the helper process, with the same images, labels and maps as in the parent, and its
errors are raised as in the parent. Each case runs as a script in a fresh interpreter, every
child with a timeout, so that a hang fails the test instead of stopping the suite."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

FORK_TESTS = Path(__file__).with_name("test_fork.py")


def run_script(body: str, tmp_path, timeout: float = 180) -> str:
    """``body`` after test_fork.py's script preamble (its COMMON), run in a fresh interpreter."""
    namespace: dict = {}
    exec(compile(FORK_TESTS.read_text(), str(FORK_TESTS), "exec"), namespace)
    script = tmp_path / "script.py"
    script.write_text(namespace["COMMON"] + "\n" + textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=timeout
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def test_warp_batch_in_a_forked_child_equals_the_parent(tmp_path):
    out = run_script(
        """
        import hashlib
        rng = np.random.default_rng(0)
        batch = rng.integers(0, 255, (3, 48, 56, 3), dtype=np.uint8)
        src = np.repeat(SRC[None], 3, 0)
        dst = src + rng.normal(0, 2, src.shape)
        points = rng.uniform(0, 40, (3, 5, 2))
        masks = rng.integers(0, 4, (3, 48, 56)).astype(np.int32)

        def batches():  # digests: a pipe holds 64 KiB until the parent reads it
            plain = glmls.warp_batch(batch, src, dst, method="backward", grid=2)
            labelled = glmls.warp_batch(
                batch, src, dst, keypoints=points, masks=masks, return_maps=True
            )
            names = ("images", "keypoints", "keypoints_valid", "masks", "maps", "valid")
            arrays = [plain] + [getattr(labelled, name) for name in names]
            return [(a.dtype.str, a.shape, hashlib.sha256(a.tobytes()).hexdigest()) for a in arrays]

        expected = batches()
        assert in_child(batches) == expected

        def error():
            try:
                glmls.warp_batch(batch, src[:2], dst)
            except ValueError as error:
                return str(error)
        print(in_child(error))
        check_parent(warps(0)[0])
        """,
        tmp_path,
    )
    assert out.strip() == "src holds 2 handle sets for 3 images"
