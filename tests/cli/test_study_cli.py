"""``glmls study`` and the batch ``glmls warp`` over worker processes and a Dask cluster."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import glmls_cli, write_cli_handles

import glmls
from glmls.cli.main import main


@pytest.fixture
def inputs(tmp_path):
    rng = np.random.default_rng(3)
    for name, shape in (("a", (32, 40, 3)), ("b", (36, 44, 3)), ("c", (30, 40))):
        glmls.imwrite(tmp_path / f"{name}.png", rng.integers(0, 256, shape, dtype=np.uint8))
    write_cli_handles(tmp_path)
    items = [
        {"name": name, "image": f"{name}.png", "handles": "h.json", "reference": "r.json"}
        for name in ("a", "b")
    ]
    (tmp_path / "set.json").write_text(json.dumps({"items": items}))
    return tmp_path


def test_study_writes_the_summary_table_and_heatmap(inputs):
    result = glmls_cli(
        "study", "set.json", "--out", "st", "--configs", "rigid:idw", "affine:idw:alpha=1",
        "--trials", "1", "--jobs", "2", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    out = inputs / "st"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["images"] == ["a", "b"]
    assert set(summary["winners"]) == {"a", "b"}
    assert summary["winners"]["a"]["label"] in {"rigid idw a=1", "rigid idw a=2", "affine idw a=1"}
    assert summary["rank_agreement"]["kendall_tau"][0]["images"] == ["a", "b"]
    assert summary["answer"] in result.stdout
    assert "study [" in result.stderr and "2/2" in result.stderr
    for name in ("table.csv", "table.json", "heatmap.png", "a/ranking.json", "b/ranking.json"):
        assert (out / name).is_file(), name


def test_study_says_where_a_winner_ties_with_others(inputs):
    """One handle makes every configuration the same translation: the image's winner ties
    with the others, and stdout says so."""
    (inputs / "one.json").write_text(json.dumps({"src": [[8, 8]], "dst": [[11, 10]]}))
    items = [{"name": "one", "image": "a.png", "handles": "one.json", "reference": "r.json"}]
    (inputs / "one_set.json").write_text(json.dumps({"items": items}))
    result = glmls_cli(
        "study", "one_set.json", "--out", "st", "--configs", "rigid:idw", "--trials", "1",
        cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    winner = json.loads((inputs / "st" / "summary.json").read_text())["winners"]["one"]
    assert winner["tied_with"] == ["rigid idw a=2"]
    assert f"one  {winner['label']} (tied with 1 other)" in result.stdout.splitlines()


def test_study_of_the_bundled_set(tmp_path):
    code = main(["--quiet", "study", "--out", str(tmp_path), "--configs", "rigid:idw:alpha=1",
                 "similarity:idw:alpha=1", "--trials", "1"])  # fmt: skip
    assert code == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["images"] == ["astronaut", "chelsea", "coffee", "camera", "text", "rocket"]
    assert len(summary["winners"]) == 6 and "rank_agreement" in summary


def run_main(*args: str) -> int:
    """``glmls ARGS`` in this process: its exit status (argparse's errors exit)."""
    try:
        return main(list(args))
    except SystemExit as done:
        return done.code


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["missing.json"], "missing.json: no such file"),
        (["bad.json"], '"items"[0] (a)."reference": '),
        (["set.json", "--configs", "rigid:cubic"], "unknown weight 'cubic'"),
        (["set.json", "--jobs", "0"], "expected an integer >= 1, got 0"),
    ],
)
def test_study_usage_errors_exit_2(inputs, capsys, monkeypatch, args, message):
    bad = [{"image": "a.png", "handles": "h.json", "reference": "nothing.json"}]
    (inputs / "bad.json").write_text(json.dumps({"items": bad}))
    monkeypatch.chdir(inputs)
    assert run_main("study", *args, "--out", "x") == 2
    assert message in capsys.readouterr().err
    assert not (inputs / "x").exists()


def test_scheduler_without_dask_exits_2(inputs, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    monkeypatch.chdir(inputs)
    assert run_main("study", "set.json", "--out", "x", "--scheduler", "local") == 2
    assert "pip install 'glmls[distributed]'" in capsys.readouterr().err
    assert run_main("warp", ".", "w", "--handles", "h.json", "--scheduler", "local") == 2


def _outputs(folder: Path) -> dict[str, np.ndarray]:
    return {p.name: glmls.imread(p) for p in sorted(folder.iterdir())}


def test_batch_warp_over_workers_matches_the_sequential_one(inputs):
    args = ["warp", "*.png", "{}", "--handles", "h.json", "--method", "backward"]
    one = glmls_cli(*[a.format("one") for a in args], cwd=inputs)
    assert one.returncode == 0, one.stderr
    two = glmls_cli(*[a.format("two") for a in args], "--jobs", "2", cwd=inputs)
    assert two.returncode == 0, two.stderr
    folders = ["two"]
    if importlib.util.find_spec("distributed") is not None:  # scripts/setup.sh installs it
        dask = glmls_cli(*[a.format("dask") for a in args], "--jobs", "2", "--scheduler",
                         "local", cwd=inputs)  # fmt: skip
        assert dask.returncode == 0, dask.stderr
        folders.append("dask")
    expected = _outputs(inputs / "one")
    assert sorted(expected) == ["a.png", "b.png", "c.png"]
    for folder in folders:
        found = _outputs(inputs / folder)
        assert sorted(found) == sorted(expected)
        assert all((found[n] == expected[n]).all() for n in expected), folder
    assert sorted(two.stdout.split()) == sorted(f"two/{n}" for n in expected)
    assert "warp [" in two.stderr and "3/3" in two.stderr


def test_batch_warp_keep_going_over_workers(inputs):
    (inputs / "b.png").write_bytes(b"not an image")
    kept = glmls_cli("warp", ".", "out", "--handles", "h.json", "--jobs", "2", "--keep-going",
                     cwd=inputs)  # fmt: skip
    assert kept.returncode == 1, kept.stderr
    assert sorted(p.name for p in (inputs / "out").iterdir()) == ["a.png", "c.png"]
    assert "skipped" in kept.stderr and "b.png" in kept.stderr
    assert "1 of 3 images failed" in kept.stderr
    stopped = glmls_cli("warp", ".", "stop", "--handles", "h.json", "--jobs", "2", cwd=inputs)
    assert stopped.returncode == 2
    assert "b.png" in stopped.stderr and "Traceback" not in stopped.stderr


def test_a_manifest_naming_3d_handles_says_studies_take_2d_ones(inputs, capsys, monkeypatch):
    """A study deforms 2D images: a manifest's 3D handle file is an input error naming the
    file and saying so, on one line (not the library's advice to call read_handles)."""
    points = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    (inputs / "h3.json").write_text(json.dumps({"src": points, "dst": points}))
    items = [{"image": "a.png", "handles": "h3.json", "reference": "r.json"}]
    (inputs / "three.json").write_text(json.dumps({"items": items}))
    monkeypatch.chdir(inputs)
    assert run_main("study", "three.json", "--out", "x") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith('glmls study: three.json: "items"[0] (a)."handles": '), err
    assert "h3.json: 3D handles (x, y, z), but a study deforms 2D images: it takes 2D" in err
    assert "read_handles" not in err and not (inputs / "x").exists()


def test_study_warns_of_a_configuration_parameter_its_weight_does_not_use(
    inputs, capsys, monkeypatch
):
    monkeypatch.chdir(inputs)
    code = run_main(
        "study", "set.json", "--out", str(inputs / "st"), "--configs", "rigid:gaussian:s=2",
        "--trials", "1",
    )  # fmt: skip
    assert code == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert warnings == [
        "glmls study: warning: --configs rigid:gaussian:s=2: s=2 is not used by the gaussian "
        "weight (idw's)"
    ]


@pytest.mark.parametrize("name", ["summary.json", "table.json", "a/ranking.json"])
def test_study_keeps_a_manifest_named_like_an_output(inputs, capsys, monkeypatch, name):
    """The manifest in --out under an output's name is refused before the work, and stays."""
    monkeypatch.chdir(inputs)
    manifest = inputs / name
    manifest.parent.mkdir(exist_ok=True)
    text = (inputs / "set.json").read_text()
    if "/" in name:  # its items' paths are relative to it
        text = text.replace('"a.png"', '"../a.png"').replace('"b.png"', '"../b.png"')
        text = text.replace('"h.json"', '"../h.json"').replace('"r.json"', '"../r.json"')
    manifest.write_text(text)
    assert run_main("study", name, "--out", ".", "--configs", "rigid:idw", "--trials", "1") == 2
    err = capsys.readouterr().err
    assert f"{name}: the output is the manifest" in err, err
    assert manifest.read_text() == text
    assert not (inputs / "heatmap.png").exists()


def test_a_file_where_an_items_folder_goes_is_refused_before_the_work(inputs, capsys, monkeypatch):
    """A file named like an item in --out: its ranking.json could not be written there."""
    monkeypatch.chdir(inputs)
    (inputs / "out").mkdir()
    (inputs / "out" / "a").write_text("mine")
    args = ("study", "set.json", "--out", "out", "--configs", "rigid:idw", "--trials", "1")
    assert run_main(*args) == 2
    err = capsys.readouterr().err
    assert "out/a: the folder of an output (ranking.json)" in err, err
    assert sorted(p.name for p in (inputs / "out").iterdir()) == ["a"]


@pytest.mark.parametrize(
    ("field", "name"),
    [
        ("handles", "summary.json"),
        ("handles", "a/ranking.json"),
        ("reference", "table.json"),
        ("image", "heatmap.png"),
    ],
)
def test_study_keeps_an_items_file_named_like_an_output(inputs, capsys, monkeypatch, field, name):
    """A handles, reference or image file that a manifest names, in --out under an output's
    name, is refused before the work, and stays."""
    monkeypatch.chdir(inputs)
    source = {"handles": "h.json", "reference": "r.json", "image": "a.png"}[field]
    target = inputs / "st" / name
    target.parent.mkdir(parents=True)
    target.write_bytes((inputs / source).read_bytes())
    items = [{"name": "a", "image": "a.png", "handles": "h.json", "reference": "r.json"}]
    items[0][field] = f"st/{name}"
    (inputs / "in_out.json").write_text(json.dumps({"items": items}))
    args = ("study", "in_out.json", "--out", "st", "--configs", "rigid:idw", "--trials", "1")
    assert run_main(*args) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1, captured
    assert lines[0] == (
        f"glmls study: st/{name}: the output is the {field} file of item a, which writing it "
        "would overwrite: write to another name or folder"
    )
    assert target.read_bytes() == (inputs / source).read_bytes()
    written = [p.relative_to(inputs / "st").as_posix() for p in (inputs / "st").rglob("*")]
    assert sorted(p for p in written if p != "a") == [name]


def test_a_manifest_naming_3d_reference_points_in_a_csv_is_refused(inputs, capsys, monkeypatch):
    """As a JSON file of 3D points is: a CSV's z column is not dropped without a word."""
    (inputs / "r3.csv").write_text("x,y,z\n10,10,0\n30,10,1\n20,25,2\n12,22,3\n28,22,4\n")
    items = [{"name": "a", "image": "a.png", "handles": "h.json", "reference": "r3.csv"}]
    (inputs / "three.json").write_text(json.dumps({"items": items}))
    monkeypatch.chdir(inputs)
    assert run_main("study", "three.json", "--out", "x", "--trials", "1") == 2
    err = capsys.readouterr().err
    assert err == (
        'glmls study: three.json: "items"[0] (a)."reference": r3.csv: line 1: expected 2D '
        "points (the header x,y), got 3D points (the header 'x,y,z')\n"
    )
    assert not (inputs / "x").exists()


@pytest.mark.parametrize("trials", ["0", "1001", "1000000000"])
def test_study_bounds_the_trial_count(inputs, capsys, monkeypatch, trials):
    monkeypatch.chdir(inputs)
    assert run_main("study", "set.json", "--out", "x", "--trials", trials) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"glmls study: argument --trials: expected an integer from 1 to 1000, got {trials}"
    ), err
    assert not (inputs / "x").exists()
