"""A ``glmls warp`` of many images that stops half-way keeps the images written whole and
leaves no temporary file and no empty folder it made (as ``glmls augment`` does)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import glmls
from glmls.cli import warp as command
from glmls.cli.main import main


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "in").mkdir()
    image = np.zeros((8, 8), np.uint8)
    for name in ("a.png", "b.png"):
        glmls.imwrite(tmp_path / "in" / name, image)
    handles = {"src": [[1, 1], [6, 1], [3, 6]], "dst": [[1, 2], [6, 1], [3, 6]]}
    (tmp_path / "h.json").write_text(json.dumps(handles))
    return tmp_path


def _stopped_while_writing(function, tasks, *, on_result, **_):
    """The first image written whole; the second's worker stopped in the middle of its
    write (its temporary file left beside its output), and the run interrupted."""
    first, second = tasks
    first.target.parent.mkdir(parents=True, exist_ok=True)
    glmls.imwrite(first.target, glmls.imread(first.source))  # as the worker writes it
    on_result(0, command.WarpOutcome(first.target, (8, 8), None))
    second.target.parent.mkdir(parents=True, exist_ok=True)
    (second.target.parent / ".b.png.swp").write_bytes(b"not glmls's: it stays")
    (second.target.parent / f".{second.target.name}.k3j_x0ab.png").write_bytes(b"half")
    raise KeyboardInterrupt


def _stopped_before_any_image(function, tasks, *, on_result, **_):
    for task in tasks:
        task.target.parent.mkdir(parents=True, exist_ok=True)
        (task.target.parent / f".{task.target.name}.q9z_1cd2.png").write_bytes(b"half")
    raise KeyboardInterrupt


def test_a_stopped_batch_keeps_its_images_and_no_temporary_file(inputs, monkeypatch):
    monkeypatch.setattr(command, "run_jobs", _stopped_while_writing)
    assert main(["warp", "in", "out", "--handles", "h.json", "--jobs", "2"]) == 130
    assert sorted(p.name for p in (inputs / "out").iterdir()) == [".b.png.swp", "a.png"]


def test_a_stopped_batch_removes_the_folders_it_made_when_empty(inputs, monkeypatch):
    monkeypatch.setattr(command, "run_jobs", _stopped_before_any_image)
    (inputs / "kept").mkdir()
    assert main(["warp", "in", "kept/new/deeper/", "--handles", "h.json", "--quiet"]) == 130
    assert (inputs / "kept").is_dir() and not any((inputs / "kept").iterdir())


def test_with_jobs_a_stopped_batch_prints_every_image_it_wrote(inputs):
    """With worker processes, a failing image stops the batch, and stdout lists each image
    that was written, those that the other worker was still warping among them (how many
    that is depends on how fast each worker starts: the items not started never start is
    tests/analysis/test_jobs.py's)."""
    from helpers import glmls_cli

    image = np.arange(64 * 64, dtype=np.uint16).reshape(64, 64)
    for name in ("a.png", "c.png", "d.png", "e.png", "f.png"):
        glmls.imwrite(inputs / "in" / name, image)
    (inputs / "in" / "b.png").write_bytes(b"\x89PNG\r\n\x1a\n broken")
    result = glmls_cli("warp", "in", "out", "--handles", "h.json", "--jobs", "2", cwd=inputs)
    assert result.returncode == 2, result.stderr
    assert "b.png" in result.stderr
    written = sorted(p.name for p in (inputs / "out").iterdir())
    assert sorted(Path(line).name for line in result.stdout.splitlines()) == written
    assert "b.png" not in written


def _not_run(*args, **kwargs):
    raise AssertionError("the work ran before the outputs were checked")


@pytest.mark.parametrize(
    ("args", "folder"),
    [
        (["in", "out", "--jobs", "2"], "out/b.png"),  # a batch: one output of many
        (["in/a.png", "out"], "out/a.png"),  # one image into an existing folder
        (["in/a.png", "out/x.png/"], "out/x.png/a.png"),
    ],
)
def test_an_output_name_taken_by_a_folder_is_refused_before_any_work(
    inputs, capsys, monkeypatch, args, folder
):
    """A folder where an output goes cannot be replaced: one line and exit status 2 before
    any image is warped, not exit status 1 after the work with the other images written."""
    monkeypatch.setattr(command, "run_jobs", _not_run)
    (inputs / folder).mkdir(parents=True)
    assert main(["warp", *args, "--handles", "h.json"]) == 2
    err = capsys.readouterr().err
    assert err == f"glmls warp: {folder}: an output's name, but it exists and is not a file\n"
    assert [p for p in (inputs / "out").rglob("*") if p.is_file()] == []


def test_a_volume_output_name_taken_by_a_folder_is_refused_before_the_warp(
    inputs, capsys, monkeypatch
):
    monkeypatch.setattr("glmls.cli.warp3d.read_3d_handles", _not_run)
    np.save(inputs / "v.npy", np.zeros((6, 7, 8), np.float32))
    (inputs / "out" / "v.npy").mkdir(parents=True)
    assert main(["warp", "v.npy", "out", "--handles", "h.json"]) == 2
    err = capsys.readouterr().err
    assert err == "glmls warp: out/v.npy: an output's name, but it exists and is not a file\n"


@pytest.mark.parametrize("source", ["in/a.png", "in", "v.npy"])
@pytest.mark.parametrize("out", ["", " "])
def test_an_empty_out_is_refused_not_taken_for_the_working_folder(
    inputs, capsys, monkeypatch, source, out
):
    """``Path("")`` is the working folder: an empty OUT (a shell variable left unset) wrote
    there, as ``glmls augment`` refuses it."""
    monkeypatch.setattr(command, "run_jobs", _not_run)
    monkeypatch.setattr("glmls.cli.warp3d.read_3d_handles", _not_run)
    np.save(inputs / "v.npy", np.zeros((6, 7, 8), np.float32))
    before = sorted(p.name for p in inputs.iterdir())
    assert main(["warp", source, out, "--handles", "h.json"]) == 2
    err = capsys.readouterr().err
    assert (
        err == "glmls warp: OUT is empty: give the file or folder to write into (. for this one)\n"
    )
    assert sorted(p.name for p in inputs.iterdir()) == before


def test_an_empty_out_folder_option_is_refused(inputs, capsys):
    with pytest.raises(SystemExit) as stop:  # argparse's: one line, exit status 2
        main(["analyze", "in/a.png", "--handles", "h.json", "--out", ""])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "argument --out: empty: give the folder to write into (. for this one)" in err, err
    assert sorted(p.name for p in inputs.iterdir()) == ["h.json", "in"]
