"""``glmls augment``, end to end in subprocesses: the images and labels it writes equal the
API's for the same indices, whatever --jobs; bad input is one line and exit status 2, and a
failed run leaves no output behind."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import numpy as np
import pytest
from helpers import glmls_cli

import glmls
from glmls.augment import Augment


@pytest.fixture
def inputs(tmp_path):
    rng = np.random.default_rng(8)
    folder = tmp_path / "in"
    folder.mkdir()
    glmls.imwrite(folder / "a.png", rng.integers(0, 256, (24, 40, 3), dtype=np.uint8))
    glmls.imwrite(folder / "b.png", rng.integers(0, 256, (20, 32), dtype=np.uint8))
    labels = {
        "a.png": {"keypoints": [[10, 12], [30, 5]], "boxes": [[4, 4, 20, 16]]},
        "b.png": {"keypoints": [[8, 8]]},
    }
    (tmp_path / "labels.json").write_text(json.dumps(labels))
    return tmp_path


@pytest.mark.parametrize("preset", ["text-distort", "text-perspective"])
def test_augment_writes_what_the_api_gives(inputs, gl, preset):
    """Each preset's defaults, its transform too (text-perspective: affine)."""
    result = glmls_cli(
        "augment", "in", "out", "--n", "3", "--preset", preset, "--seed", "5",
        "--labels", "labels.json", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    names = sorted(p.name for p in (inputs / "out").iterdir())
    expected_names = [f"{s}_{k:03d}.png" for s in "ab" for k in range(3)]
    assert names == sorted([*expected_names, "labels.json"])
    assert result.stdout.split() == [str(Path("out") / n) for n in expected_names]
    labels = json.loads((inputs / "out" / "labels.json").read_text())
    aug = Augment(preset, seed=5)
    image = glmls.imread(inputs / "in" / "a.png")
    api = aug(
        np.stack([image] * 3),
        keypoints=[[[10, 12], [30, 5]]] * 3,
        boxes=[[[4, 4, 20, 16]]] * 3,
        indices=[0, 1, 2],
    )
    for k in range(3):
        name = f"a_{k:03d}.png"
        np.testing.assert_array_equal(glmls.imread(inputs / "out" / name), api.images[k])
        np.testing.assert_allclose(labels[name]["keypoints"], api.keypoints[k])
        np.testing.assert_allclose(labels[name]["boxes"], api.boxes[k])
        assert labels[name]["params"] == api.params[k]
        assert labels[name]["params"]["options"]["transform"] == aug.warp_options["transform"]
    grey = glmls.imread(inputs / "in" / "b.png")
    b = aug(grey[None], keypoints=[[[8, 8]]], indices=[4])  # second input: indices 3, 4, 5
    np.testing.assert_array_equal(glmls.imread(inputs / "out" / "b_001.png"), b.images[0])
    assert "boxes" not in labels["b_001.png"]
    # the params replay the image exactly
    replayed = aug.replay([image], [labels["a_002.png"]["params"]])
    np.testing.assert_array_equal(replayed.images[0], api.images[2])


def test_augment_with_jobs_gives_the_same(inputs):
    one = glmls_cli("augment", "in", "one", "--n", "2", "--seed", "1", cwd=inputs)
    two = glmls_cli("augment", "in", "two", "--n", "2", "--seed", "1", "--jobs", "2", cwd=inputs)
    assert one.returncode == 0 and two.returncode == 0, one.stderr + two.stderr
    assert one.stdout.replace("one", "two") == two.stdout  # the same files, in input order
    for name in ("a_000.png", "a_001.png", "b_000.png", "b_001.png"):
        first = glmls.imread(inputs / "one" / name)
        np.testing.assert_array_equal(first, glmls.imread(inputs / "two" / name))
    assert (inputs / "one" / "labels.json").read_text() == (
        inputs / "two" / "labels.json"
    ).read_text()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--preset", "wave"], "invalid choice: 'wave'"),
        (["--seed", "-1"], "seed must be an integer >= 0, got -1"),
        (["--n", "500001"], "would write 1,000,002 images; at most 1,000,000 a run"),
        (
            ["--preset", "text-stretch", "--rows", "3"],
            "--rows: not an option of --preset text-stretch; it takes --segments, --radius",
        ),
        (["--cols", "3", "--radius", "2"], "--radius: not an option of --preset grid; it takes"),
        (["--displacement", "nan"], "displacement must be a finite number >= 0"),
        (["--labels", "missing.json"], "missing.json: no such file"),
        (["--labels", "bad.json"], "bad.json: not a JSON labels file"),
        (["--labels", "other.json"], "'c.png' names no input image"),
        (["--labels", "nan.json"], "keypoints holds values that are not finite"),
        (["--labels", "wide.json"], "'a.png' keypoints must be a list of [2 numbers], got [[1"),
        (["--labels", "flat.json"], "'a.png' boxes must be a list of [4 numbers], got [1"),
        (["--preset", "landmarks"], "the landmarks preset moves each image's keypoints;"),
        (
            ["--preset", "landmarks", "--labels", "boxes.json"],
            "--labels gives none for a.png",
        ),
    ],
)
def test_bad_input_is_one_line_and_status_2_and_leaves_nothing(inputs, args, message):
    (inputs / "bad.json").write_text("{not json")
    (inputs / "other.json").write_text(json.dumps({"c.png": {"keypoints": [[1, 1]]}}))
    (inputs / "nan.json").write_text('{"a.png": {"keypoints": [[1, NaN]]}}')
    (inputs / "boxes.json").write_text('{"a.png": {"boxes": [[1, 1, 5, 5]]}}')
    # four numbers are not two keypoints, nor eight two boxes
    (inputs / "wide.json").write_text('{"a.png": {"keypoints": [[1, 2, 3, 4]]}}')
    (inputs / "flat.json").write_text('{"a.png": {"boxes": [1, 2, 3, 4, 5, 6, 7, 8]}}')
    result = glmls_cli("augment", "in", "out", "--n", "2", *args, cwd=inputs)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr and "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (inputs / "out").exists()


@pytest.mark.parametrize("command", ["augment", "warp"])
def test_a_malformed_scheduler_address_is_a_usage_error(inputs, command):
    pytest.importorskip("distributed")
    (inputs / "h.json").write_text(json.dumps({"src": [[1, 1]], "dst": [[2, 2]]}))
    handles = ["--handles", "h.json"] if command == "warp" else []
    result = glmls_cli(
        command, "in", "out", *handles, "--jobs", "2", "--scheduler", "bogus", cwd=inputs
    )
    assert result.returncode == 2, result.stderr
    assert "argument --scheduler: expected 'local' or a Dask scheduler's address" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (inputs / "out").exists()


def test_a_failure_midway_leaves_no_half_written_output(inputs):
    (inputs / "in" / "c.png").write_bytes(b"not a png")  # read after a.png and b.png
    (inputs / "kept").mkdir()
    for out in ("out/deeper", "kept"):
        result = glmls_cli("augment", "in", out, "--n", "2", cwd=inputs)
        assert result.returncode == 2 and "c.png" in result.stderr, result.stderr
    assert not (inputs / "out").exists()  # the folders it made go again, empty
    assert (inputs / "kept").is_dir() and not any((inputs / "kept").iterdir())


def test_a_failure_with_jobs_leaves_no_temporary_file_of_the_other_workers(inputs):
    """The bad input fails at once while another worker still deforms its copies: those
    finish after the failure, and their temporary files go too."""
    (inputs / "in" / "_bad.png").write_bytes(b"not a png")  # sorted first
    result = glmls_cli("augment", "in", "out", "--n", "12", "--jobs", "2", cwd=inputs)
    assert result.returncode == 2 and "_bad.png" in result.stderr, result.stderr
    assert not (inputs / "out").exists(), sorted((inputs / "out").iterdir())


def test_inputs_of_one_name_in_two_folders_are_a_usage_error(inputs):
    for name in ("x", "y"):
        (inputs / name).mkdir()
        (inputs / name / "a.png").write_bytes((inputs / "in" / "a.png").read_bytes())
    result = glmls_cli("augment", "*/a.png", "out", "--n", "2", cwd=inputs)
    assert result.returncode == 2, result.stderr
    assert "in/a.png and x/a.png have one name" in result.stderr
    assert not (inputs / "out").exists()


def test_augment_help_lists_the_presets(inputs):
    result = glmls_cli("augment", "--help", cwd=inputs)
    assert result.returncode == 0 and "examples:" in result.stdout
    for name in ("grid", "text-distort", "text-stretch", "text-perspective", "landmarks"):
        assert name in result.stdout


def _task(inputs, count):
    from glmls.cli.augment import AugmentTask

    labels = json.loads((inputs / "labels.json").read_text())["a.png"]
    folder = inputs / "chunks"
    folder.mkdir(exist_ok=True)
    return AugmentTask(
        inputs / "in" / "a.png", folder, 6, count, "grid", {}, 3,
        {"transform": "similarity", "interpolation": "linear", "border": "edge"},
        2.0, labels, 10**8,
    )  # fmt: skip


def test_many_copies_are_deformed_a_chunk_at_a_time(inputs, gl, monkeypatch):
    """A chunk of copies at a time (one here), each draw numbered by its index: the same
    images and labels as all at once."""
    from glmls.cli import augment as command

    whole = command.augment_file(_task(inputs, 3))
    monkeypatch.setattr(command, "CHUNK_BYTES", 1)
    calls = []
    real = command.Augment.__call__
    monkeypatch.setattr(
        command.Augment, "__call__", lambda self, *a, **k: calls.append(1) or real(self, *a, **k)
    )
    chunked = command.augment_file(_task(inputs, 3))
    assert len(calls) == 3 and whole.error is None and chunked.error is None
    assert chunked.labels == whole.labels
    for (one, _), (other, _) in zip(whole.written, chunked.written, strict=True):
        np.testing.assert_array_equal(glmls.imread(one), glmls.imread(other))


def test_an_unexpected_error_leaves_no_temporary_file(inputs, gl, monkeypatch):
    from glmls.cli import augment as command

    monkeypatch.setattr(command, "CHUNK_BYTES", 1)
    real = command.Augment.__call__
    calls = []

    def fails_second(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("the GL driver went away")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(command.Augment, "__call__", fails_second)
    with pytest.raises(RuntimeError, match="went away"):
        command.augment_file(_task(inputs, 3))
    assert not any((inputs / "chunks").iterdir())


@pytest.mark.parametrize(
    "keypoints", [[[True, 2.0]], [[1.0, False]], [["1", 2.0]], [[1.0, None]], [[[1.0], 2.0]]]
)
def test_labels_that_are_not_numbers_are_named(tmp_path, keypoints):
    """JSON's true and false are no coordinates, though numpy reads them as 1 and 0."""
    from glmls.cli.augment import read_labels
    from glmls.cli.options import UsageError

    (tmp_path / "labels.json").write_text(json.dumps({"a.png": {"keypoints": keypoints}}))
    with pytest.raises(UsageError, match=r"'a\.png' keypoints must be a list of \[2 numbers\]"):
        read_labels(str(tmp_path / "labels.json"), [tmp_path / "a.png"])
    (tmp_path / "labels.json").write_text(json.dumps({"a.png": {"keypoints": [[1, 2.5]]}}))
    labels = read_labels(str(tmp_path / "labels.json"), [tmp_path / "a.png"])
    assert labels["a.png"]["keypoints"] == [[1.0, 2.5]]


@pytest.mark.parametrize("name", ["b_001.png", "labels.json"])
def test_an_output_name_taken_by_a_folder_is_refused_before_any_output(inputs, name):
    """A folder where an output goes cannot be replaced: refused before the work, not found
    by the final renames after the outputs before it were renamed into place (and the
    temporary files after it left behind)."""
    (inputs / "out" / name).mkdir(parents=True)
    result = glmls_cli("augment", "in", "out", "--n", "3", "--labels", "labels.json", cwd=inputs)
    assert result.returncode == 2, result.stderr
    assert f"{name}: an output's name, but it exists and is not a file" in result.stderr
    assert sorted(p.name for p in (inputs / "out").iterdir()) == [name]


def test_outputs_that_would_overwrite_an_input_or_the_labels_are_refused(inputs):
    """OUT the input folder: an output named like an input image (a_001.png, an input, is
    also a.png's second output), or like the --labels file, would overwrite what the run
    read: refused before any work, every file as it was."""
    folder = inputs / "in"
    (folder / "a_001.png").write_bytes((folder / "a.png").read_bytes())
    (folder / "labels.json").write_text((inputs / "labels.json").read_text())
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    for labels, message in [
        ("in/labels.json", "in/labels.json: an output's name, but it is the --labels file"),
        ("labels.json", "in/a_001.png: an output's name, but it is an input image"),
    ]:
        result = glmls_cli("augment", "in", "in", "--n", "2", "--labels", labels, cwd=inputs)
        assert result.returncode == 2, result.stderr
        assert message in result.stderr, result.stderr
        assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


@pytest.mark.parametrize("out", ["", "labels.json/sub"])
def test_an_out_that_cannot_be_a_folder_is_refused_before_the_work(inputs, out):
    # "" named the working folder; a folder below a file was found only when it was made
    result = glmls_cli("augment", "in", out, "--n", "1", cwd=inputs)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    expected = "OUT is empty" if not out else "labels.json is a file, not a folder"
    assert expected in result.stderr
    assert sorted(p.name for p in inputs.iterdir()) == ["in", "labels.json"]


def test_a_labels_file_with_a_byte_order_mark_is_read(tmp_path):
    """Windows editors start UTF-8 files with a byte order mark, as the handle files take."""
    from glmls.cli.augment import read_labels

    text = json.dumps({"a.png": {"keypoints": [[1, 2.5]]}})
    (tmp_path / "labels.json").write_text(text, encoding="utf-8-sig")
    labels = read_labels(str(tmp_path / "labels.json"), [tmp_path / "a.png"])
    assert labels["a.png"]["keypoints"] == [[1.0, 2.5]]


@pytest.mark.parametrize(
    ("text", "fault"),
    [
        ('{"a.png": {"keypoints": [[1' + "0" * 5000 + ", 1]]}}", "4300 digits"),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        ("", "not a JSON labels file"),
        (None, "/dev/zero: a device, not a file"),
    ],
)
def test_a_labels_file_json_cannot_hold_is_one_line(inputs, capsys, text, fault):
    """An integer beyond Python's 4300 digits or nesting beyond its recursion limit is a
    mistake in the file, and an endless device no file: one line and exit status 2, not a
    traceback or a read that never ends."""
    from glmls.cli.main import main

    labels = inputs / "labels.json" if text is not None else Path("/dev/zero")  # endless
    if text is not None:
        labels.write_text(text)
    assert main(["augment", str(inputs / "in"), str(inputs / "out"), "--labels",
                 str(labels)]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and fault in err and labels.name in err, err
    assert not (inputs / "out").exists()


def test_a_labels_file_with_a_key_twice_is_refused(tmp_path):
    """json keeps the last of two entries of one name without a word: which was meant is
    not known."""
    from glmls.cli.augment import read_labels
    from glmls.cli.options import UsageError

    labels = tmp_path / "labels.json"
    labels.write_text('{"a.png": {"keypoints": [[1, 2]]}, "a.png": {"keypoints": [[3, 4]]}}')
    with pytest.raises(UsageError, match=r'labels\.json: the key "a\.png" twice in one object'):
        read_labels(str(labels), [tmp_path / "a.png"])
    labels.write_text('{"a.png": {"keypoints": [[1, 2]], "keypoints": [[3, 4]]}}')
    with pytest.raises(UsageError, match='the key "keypoints" twice'):
        read_labels(str(labels), [tmp_path / "a.png"])


def test_a_labels_json_that_cannot_be_written_leaves_nothing(inputs, gl, capsys, monkeypatch):
    """A full disk while labels.json is written: its temporary file goes too, and the
    message names it."""
    from glmls.cli.main import main

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(json, "dump", full)
    assert main(["augment", str(inputs / "in"), str(inputs / "out"), "--n", "1"]) == 1
    err = capsys.readouterr().err
    assert "labels.json: cannot write: No space left on device" in err, err
    assert not (inputs / "out").exists()


def test_a_rename_that_fails_midway_takes_back_the_renamed_outputs(inputs, gl, monkeypatch):
    from glmls.cli import augment as command
    from glmls.cli.main import main

    real = os.replace
    calls = []

    def fails_third(source, target):
        calls.append(target)
        if len(calls) == 3:
            raise OSError(5, "Input/output error")
        real(source, target)

    monkeypatch.setattr(command.os, "replace", fails_third)
    (inputs / "out").mkdir()
    assert main(["augment", str(inputs / "in"), str(inputs / "out"), "--n", "2"]) == 1
    assert len(calls) == 3 and not any((inputs / "out").iterdir())


@pytest.mark.parametrize("number", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_during_the_renames_waits_for_the_whole_set(tmp_path, number):
    """Ctrl-C between two renames would leave part of the set: it is raised once all are
    in place."""
    from glmls.cli.augment_outputs import rename_all

    written = []
    for k in range(3):
        temporary = tmp_path / f".a_{k}.png.tmp"
        temporary.write_bytes(b"x")
        written.append((str(temporary), str(tmp_path / f"a_{k}.png")))
    real = os.replace
    handled = []

    def stop(*_):
        handled.append(1)
        raise KeyboardInterrupt

    stopped = signal.signal(number, stop)
    try:
        with pytest.MonkeyPatch.context() as patch, pytest.raises(KeyboardInterrupt):
            patch.setattr(os, "replace", lambda a, b: signal.raise_signal(number) or real(a, b))
            rename_all(written)
    finally:
        signal.signal(number, stopped)
    assert handled == [1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_0.png", "a_1.png", "a_2.png"]


def _names_in(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_a_second_run_replaces_the_first_runs_set(inputs):
    """--n 4 then --n 2 into one OUT: the first run's images past the second's are removed,
    so that OUT holds one run's images, those its labels.json names, and the files that no
    run wrote stay."""
    first = glmls_cli("augment", "in", "out", "--n", "4", cwd=inputs)
    assert first.returncode == 0, first.stderr
    (inputs / "out" / "notes.txt").write_text("mine")
    (inputs / "out" / "z_000.png").write_bytes((inputs / "in" / "a.png").read_bytes())
    second = glmls_cli("augment", "in/a.png", "out", "--n", "2", cwd=inputs)
    assert second.returncode == 0, second.stderr
    assert "removed 6 images of an earlier run" in second.stderr, second.stderr
    labels = json.loads((inputs / "out" / "labels.json").read_text())
    assert sorted(labels) == ["a_000.png", "a_001.png"]
    assert _names_in(inputs / "out") == [*sorted(labels), "labels.json", "notes.txt", "z_000.png"]
    again = glmls_cli("augment", "in/a.png", "out", "--n", "2", "--quiet", cwd=inputs)
    assert again.returncode == 0 and again.stderr == "", again.stderr


def test_a_second_run_keeps_the_files_it_reads_and_a_labels_json_of_its_own(inputs):
    """The earlier run's images that this run reads stay; a labels.json that glmls did not
    write (no source and params per entry) names nothing to remove."""
    out = inputs / "out"
    assert glmls_cli("augment", "in/a.png", "out", "--n", "3", cwd=inputs).returncode == 0
    result = glmls_cli("augment", "out/a_00[01].png", "out", "--n", "1", cwd=inputs)
    assert result.returncode == 0, result.stderr
    assert _names_in(out) == ["a_000.png", "a_000_000.png", "a_001.png", "a_001_000.png",
                              "labels.json"]  # fmt: skip
    (out / "labels.json").write_text(json.dumps({"a_000.png": {"keypoints": []}}))
    result = glmls_cli("augment", "in/b.png", "out", "--n", "1", cwd=inputs)
    assert result.returncode == 0, result.stderr
    assert "a_000.png" in _names_in(out) and "b_000.png" in _names_in(out)


def test_an_earlier_runs_name_for_a_file_this_run_wrote_stays(tmp_path):
    """Two names of one file (on a case-insensitive file system an earlier run's A_000.png
    is this run's a_000.png; a hard link here): the earlier run's name is not removed, as
    that would remove this run's image."""
    import argparse

    from glmls.cli.augment_outputs import remove_former

    written = tmp_path / "a_000.png"
    written.write_bytes(b"new image")
    alias = tmp_path / "A_000.png"
    os.link(written, alias)
    other = tmp_path / "a_001.png"
    other.write_bytes(b"earlier image")
    remove_former(argparse.Namespace(quiet=True), [alias, other], "labels.json", [written])
    assert alias.exists() and written.read_bytes() == b"new image"
    assert not other.exists()


def test_clearing_up_after_a_failure_lists_each_folder_once(tmp_path, monkeypatch):
    """The temporary files of thousands of outputs in one folder are found by one listing
    of it, not one per output (which took minutes for --n 20000)."""
    from glmls.files.atomic import remove_leftovers

    outputs = [tmp_path / f"a_{k:04d}.png" for k in range(300)]
    for path in outputs[:5]:
        path.write_bytes(b"whole")
        (tmp_path / f".{path.name}.k3j_x0ab.png").write_bytes(b"half")
    kept = [".a_0000.png.swp", ".a_0001.png.k3j_x0a.png", ".b.png.k3j_x0ab.png", "c.png"]
    for name in kept:
        (tmp_path / name).write_bytes(b"not a temporary of the outputs")
    real, listings = os.scandir, []
    monkeypatch.setattr(os, "scandir", lambda *a: listings.append(a) or real(*a))
    remove_leftovers(outputs)
    assert len(listings) == 1
    assert _names_in(tmp_path) == sorted([p.name for p in outputs[:5]] + kept)


def test_an_image_that_cannot_be_written_is_exit_status_1(inputs, gl, capsys, monkeypatch):
    """A full disk while an image is written is a failure to write, exit status 1 as for
    labels.json and for ``glmls warp``, not a mistake in the command line (2)."""
    from glmls.cli.main import main

    def full(self, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", full)
    assert main(["augment", str(inputs / "in"), str(inputs / "out"), "--n", "1"]) == 1
    err = capsys.readouterr().err
    assert "a_000.png: cannot write: No space left on device" in err, err
    assert not (inputs / "out").exists()
