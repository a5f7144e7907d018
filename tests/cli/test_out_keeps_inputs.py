"""``--out`` folders of ``analyze`` and ``tune``: an input that lies there under the name of
an output (``deformed.png``, ``report.json``, ``ranking.json``...) is refused, exit status 2,
and stays as it was, as ``warp`` refuses an output that is its input."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from helpers import CLI_DST, CLI_REFERENCE, CLI_SRC

import glmls
from glmls.cli.main import main


@pytest.fixture
def out(tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()
    rng = np.random.default_rng(3)
    glmls.imwrite(tmp_path / "photo.png", rng.integers(0, 256, (32, 40, 3), dtype=np.uint8))
    (tmp_path / "h.json").write_text(json.dumps({"src": CLI_SRC, "dst": CLI_DST}))
    (tmp_path / "r.json").write_text(json.dumps({"points": CLI_REFERENCE}))
    rows = "".join(f"{x},{y}\n" for x, y in CLI_REFERENCE)
    (tmp_path / "r.csv").write_text("x,y\n" + rows)
    return folder


def _move(out, source: str, name: str) -> str:
    path = out / name
    shutil.move(out.parent / source, path)
    return str(path)


@pytest.mark.parametrize(
    ("source", "name", "option"),
    [
        ("photo.png", "deformed.png", None),
        ("photo.png", "error_field_colorbar.png", None),
        ("h.json", "report.json", "--handles"),
        ("r.json", "report.json", "--reference"),
    ],
)
def test_analyze_keeps_an_input_named_like_an_output(out, gl, capsys, source, name, option):
    files = {"photo.png": str(out.parent / "photo.png"), "h.json": str(out.parent / "h.json")}
    files[source] = _move(out, source, name)
    before = (out / name).read_bytes()
    args = ["analyze", files["photo.png"], "--handles", files["h.json"], "--out", str(out)]
    if option == "--reference":
        args += ["--reference", files["r.json"]]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.splitlines()[-1].startswith(f"glmls analyze: {out / name}: the output is "), err
    assert (out / name).read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == [name]


@pytest.mark.parametrize(("source", "name"), [("r.json", "ranking.json"), ("r.csv", "ranking.csv")])
def test_tune_keeps_an_input_named_like_an_output(out, capsys, source, name):
    reference = _move(out, source, name)
    before = (out / name).read_bytes()
    args = ["tune", str(out.parent / "photo.png"), "--handles", str(out.parent / "h.json"),
            "--reference", reference, "--out", str(out), "--trials", "1"]  # fmt: skip
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{out / name}: the output is the --reference file" in err, err
    assert (out / name).read_bytes() == before


def _not_run(*args, **kwargs):
    raise AssertionError("the work ran before the outputs were checked")


def test_analyze_refuses_a_picture_name_before_the_analysis(out, gl, capsys, monkeypatch):
    monkeypatch.setattr("glmls.cli.analyze.report", _not_run)
    photo = _move(out, "photo.png", "triangle_angle.png")
    args = ["analyze", photo, "--handles", str(out.parent / "h.json"), "--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.splitlines()[-1].startswith(f"glmls analyze: {photo}: the output is the input"), err
    assert sorted(p.name for p in out.iterdir()) == ["triangle_angle.png"]


def test_tune_refuses_a_winner_picture_name_before_the_tune(out, capsys, monkeypatch):
    monkeypatch.setattr("glmls.cli.tune.tune", _not_run)
    (out / "winner").mkdir()
    photo = shutil.move(out.parent / "photo.png", out / "winner" / "deformed.png")
    handles, reference = str(out.parent / "h.json"), str(out.parent / "r.json")
    args = ["tune", str(photo), "--handles", handles, "--reference", reference, "--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.splitlines()[-1].startswith(f"glmls tune: {photo}: the output is the input"), err
    assert sorted(p.name for p in out.iterdir()) == ["winner"]  # no ranking written


def test_analyze_volume_refuses_a_picture_name_before_the_analysis(out, capsys, monkeypatch):
    monkeypatch.setattr("glmls.cli.analyze_volume.volume_report", _not_run)
    np.save(out.parent / "v.npy", np.zeros((6, 7, 8), np.uint8))
    src = [[1, 1, 1], [6, 1, 1], [1, 5, 1], [1, 1, 4]]
    (out.parent / "h3.json").write_text(json.dumps({"src": src, "dst": src}))
    reference = out / "folds.png"  # a CSV of reference points, named like a picture
    reference.write_text("x,y,z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in src))
    args = ["analyze", str(out.parent / "v.npy"), "--handles", str(out.parent / "h3.json"),
            "--reference", str(reference), "--out", str(out)]  # fmt: skip
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{reference}: the output is the --reference file" in err, err
    assert sorted(p.name for p in out.iterdir()) == ["folds.png"]


@pytest.mark.parametrize("name", ["report.json", "deformed.png", "error_field_colorbar.png"])
def test_analyze_refuses_a_folder_named_like_an_output_before_the_analysis(
    out, gl, capsys, monkeypatch, name
):
    monkeypatch.setattr("glmls.cli.analyze.report", _not_run)
    (out / name).mkdir()
    args = ["analyze", str(out.parent / "photo.png"), "--handles", str(out.parent / "h.json"),
            "--out", str(out), "--quiet"]  # fmt: skip
    assert main(args) == 2
    err = capsys.readouterr().err
    expected = f"{out / name}: an output's name, but it exists and is not a file"
    assert err == f"glmls analyze: {expected}\n"
    assert sorted(p.name for p in out.iterdir()) == [name]
