"""A corrupt 2D TIFF given to ``glmls warp``: exit status 2 and one line naming the file on
stderr, tifffile's own log lines held back (as for volumes, tests/cli/test_volume_dtypes.py)."""

from __future__ import annotations

import json
import logging
import struct

import pytest
from helpers import run_glmls

import glmls

#: A TIFF whose one page has a width and no strips: tifffile logs the tags it misses.
NO_STRIPS = b"II*\x00" + struct.pack("<I", 8) + struct.pack("<HHHII", 1, 256, 4, 1, 10) + bytes(4)


@pytest.mark.parametrize(
    "content", [NO_STRIPS, b"II*\x00\x08\x00\x00\x00\x00\x00", b"II*\x00garbage"]
)
def test_a_corrupt_tiff_is_one_line(tmp_path, content):
    (tmp_path / "corrupt.tif").write_bytes(content)
    handles = {"src": [[1, 2], [5, 6], [3, 1]], "dst": [[1, 3], [5, 6], [3, 1]]}
    (tmp_path / "h.json").write_text(json.dumps(handles))
    result = run_glmls("warp", "corrupt.tif", "o.png", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "corrupt.tif" in lines[0], result.stderr


def test_imread_keeps_tifffile_s_log_records_back(tmp_path, caplog):
    path = tmp_path / "corrupt.tif"
    path.write_bytes(NO_STRIPS)
    with caplog.at_level(logging.DEBUG), pytest.raises(ValueError, match=r"corrupt\.tif"):
        glmls.imread(path)
    assert not [r for r in caplog.records if r.name.startswith("tifffile")], caplog.records
    assert logging.getLogger("tifffile").level == logging.NOTSET  # left as it was
