"""``glmls.read_volume`` of a ``.npy`` file: a copy-on-write map of the file where the array
is in C order (a warp uploads it slab by slab; the array can be changed as one read whole,
and a change never reaches the file), read whole where it is in Fortran order; writing over
the file replaces it whole."""

from __future__ import annotations

import json

import numpy as np
import pytest

import glmls
from glmls.cli.main import main
from glmls.files import volumes


def _mapped(array: np.ndarray) -> bool:
    """Whether ``array``'s memory is a file's map (a ``np.memmap`` somewhere in its bases)."""
    while array is not None:
        if isinstance(array, np.memmap):
            return True
        array = array.base if isinstance(array.base, np.ndarray) else None
    return False


@pytest.fixture
def ramp() -> np.ndarray:
    return (np.arange(5 * 6 * 7, dtype=np.float32) * np.float32(0.25) - 3).reshape(5, 6, 7)


def test_a_c_order_npy_is_a_copy_on_write_map_of_its_file(tmp_path, ramp):
    path = tmp_path / "v.npy"
    np.save(path, ramp)
    before = path.read_bytes()
    volume = glmls.read_volume(path)
    assert _mapped(volume.data)
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.data.dtype == ramp.dtype and volume.data.flags.writeable
    # changed as an array read whole would be: in memory, never in the file
    volume.data[0, 0, 0] = 99
    volume.data[-1] *= 2
    assert volume.data[0, 0, 0] == 99
    np.testing.assert_array_equal(volume.data[-1], 2 * ramp[-1])
    assert path.read_bytes() == before
    np.testing.assert_array_equal(glmls.read_volume(path).data, ramp)


def test_a_fortran_order_npy_is_read_whole(tmp_path, ramp):
    path = tmp_path / "f.npy"
    np.save(path, np.asfortranarray(ramp))
    volume = glmls.read_volume(path)
    assert not _mapped(volume.data)
    np.testing.assert_array_equal(volume.data, ramp)


def test_an_object_npy_is_still_refused_as_a_pickle(tmp_path):
    path = tmp_path / "o.npy"
    np.save(path, np.empty((2, 2, 2), dtype=object), allow_pickle=True)
    with pytest.raises(glmls.errors.InputFileError, match="allow_pickle"):
        glmls.read_volume(path)


def test_a_mapped_volume_written_over_its_own_file(tmp_path, ramp):
    """write_volume replaces the file whole (a new file renamed over it): the map it was read
    from keeps the old values, and the file has the new ones."""
    path = tmp_path / "v.npy"
    np.save(path, ramp)
    volume = glmls.read_volume(path)
    glmls.write_volume(path, volume.data[::-1])
    np.testing.assert_array_equal(np.load(path), ramp[::-1])
    np.testing.assert_array_equal(volume.data, ramp)


def _warp_twice(tmp_path, monkeypatch, ramp, out: str) -> tuple[bytes, bytes]:
    """The bytes ``glmls warp v.npy OUT`` writes from the file's map, and those it writes
    from the array read whole, as before the map."""
    monkeypatch.chdir(tmp_path)
    # the box's corners (x, y, z), moved by one voxel along x and a half along z
    src = np.array([[x, y, z] for x in (0, 6) for y in (0, 5) for z in (0, 4)], float)
    dst = src + [1.0, 0.0, 0.5]
    (tmp_path / "h3.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    np.save(tmp_path / "v.npy", ramp)
    assert main(["warp", "v.npy", out, "--handles", "h3.json"]) == 0
    mapped = (tmp_path / out).read_bytes()
    whole = {"called": False}

    def read_whole(path):
        whole["called"] = True
        return np.load(path, allow_pickle=False)

    monkeypatch.setattr(volumes, "_load_npy", read_whole)
    (tmp_path / out).unlink()
    assert main(["warp", "v.npy", out, "--handles", "h3.json"]) == 0
    assert whole["called"]
    return mapped, (tmp_path / out).read_bytes()


def test_glmls_warp_of_a_mapped_npy_writes_the_same_bytes(tmp_path, monkeypatch, gl, ramp, capsys):
    mapped, whole = _warp_twice(tmp_path, monkeypatch, ramp, "out.npy")
    assert mapped == whole
    warped = np.load(tmp_path / "out.npy")
    assert warped.shape == ramp.shape and not np.array_equal(warped, ramp)  # it moved
    capsys.readouterr()


def test_glmls_warp_onto_its_mapped_input_is_refused_and_keeps_it(
    tmp_path, monkeypatch, ramp, capsys
):
    monkeypatch.chdir(tmp_path)
    src, dst = glmls.data.phantom_handles()
    (tmp_path / "h3.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    np.save(tmp_path / "v.npy", ramp)
    before = (tmp_path / "v.npy").read_bytes()
    assert main(["warp", "v.npy", "v.npy", "--handles", "h3.json"]) == 2
    assert "which writing it would overwrite" in capsys.readouterr().err
    assert (tmp_path / "v.npy").read_bytes() == before
