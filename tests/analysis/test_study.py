"""Studies over image sets: manifests, the table, winners, rank agreement and the heat-map."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import kendalltau

from glmls.analysis import studies
from glmls.analysis.tuning import MAX_TRIALS, label, parse_config, search_space
from glmls.core.config import MLSConfig, image_diagonal
from glmls.core.handleset import HandleSet
from glmls.data import StudyItem, read_manifest
from glmls.errors import InputFileError

SRC = np.array([[4.0, 4.0], [36.0, 6.0], [20.0, 30.0], [6.0, 26.0]])
REFERENCE = np.array([[10, 10], [30, 10], [20, 25], [12, 22], [28, 22.0]])


def items() -> list[StudyItem]:
    """Two small images of different sizes, with different edits."""
    a = HandleSet.validate(SRC, SRC + [[2.0, 1.0], [-2.0, 2.0], [4.0, -2.0], [0.0, 0.0]])
    b = HandleSet.validate(SRC * 1.5, SRC * 1.5 + [[0.0, 4.0], [3.0, 0.0], [0.0, 0.0], [-3, 2]])
    return [
        StudyItem("small", (32, 40), a, REFERENCE),
        StudyItem("large", (48, 60), b, REFERENCE * 1.5),
    ]


@pytest.fixture(scope="module")
def result(gl):
    return studies.study(items(), configs=["rigid:idw", "similarity:gaussian"], trials=2)


def test_configurations_are_matched_between_images_of_different_sizes(result):
    rows = result.table()
    assert len(rows) == 5  # 2 idw alphas + 3 radii, on both images
    labels = {row["label"] for row in rows}
    assert "rigid idw a=2" in labels
    for fraction in ("0.25", "0.5", "1"):  # the radii, relative to each image's diagonal
        assert any(f"similarity gaussian R={fraction} diag" in label for label in labels)
    for row in rows:
        assert set(row["images"]) == {"small", "large"}
        assert row["mean_rank"] == np.mean([c["rank"] for c in row["images"].values()])
    radii = {c["config"]["radius"] for r in rows for c in r["images"].values()}
    assert {12.8, 19.2} <= radii  # a quarter of each diagonal (51.2 and 76.8)
    assert [r["mean_rank"] for r in rows] == sorted(r["mean_rank"] for r in rows)


def test_summary_answers_the_papers_question(result):
    summary = result.summary()
    assert summary["images"] == ["small", "large"]
    rows = result.table()
    for name, winner in summary["winners"].items():
        best = [r for r in rows if r["images"][name]["rank"] == 1]
        assert [winner["label"]] == [r["label"] for r in best]
    assert summary["distinct_winners"] == len({w["label"] for w in summary["winners"].values()})
    assert summary["one_configuration_wins_everywhere"] == (summary["distinct_winners"] == 1)
    agreement = summary["rank_agreement"]
    small = [r["images"]["small"]["rank"] for r in rows]
    large = [r["images"]["large"]["rank"] for r in rows]
    assert agreement["mean_tau"] == pytest.approx(kendalltau(small, large).statistic)
    assert agreement["tau_matrix"][0][1] == agreement["mean_tau"]
    assert 0.0 <= agreement["kendall_w"] <= 1.0
    assert "distinct winner" in summary["answer"]
    assert summary["settings"]["trials"] == 2 and summary["timings"]["jobs"] == 1
    json.dumps(summary, allow_nan=False)  # plain JSON


def test_kendalls_w():
    def rows(*orders):
        return [
            {"images": {f"i{k}": {"rank": order[c]} for k, order in enumerate(orders)}}
            for c in range(len(orders[0]))
        ]

    assert studies.rank_agreement(rows([1, 2, 3], [1, 2, 3]), ["i0", "i1"])["kendall_w"] == 1.0
    reversed_ = studies.rank_agreement(rows([1, 2, 3, 4], [4, 3, 2, 1]), ["i0", "i1"])
    assert reversed_["kendall_w"] == 0.0 and reversed_["mean_tau"] == -1.0


def test_save_writes_the_outputs(result, tmp_path):
    summary = result.save(tmp_path)
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    table = json.loads((tmp_path / "table.json").read_text())
    assert table["images"] == ["small", "large"] and len(table["configurations"]) == 5
    lines = (tmp_path / "table.csv").read_text().splitlines()
    assert lines[0] == (
        "configuration,mean_rank,wins,small_rank,small_score,large_rank,large_score"
    )
    assert len(lines) == 6
    ranking = json.loads((tmp_path / "small" / "ranking.json").read_text())
    assert set(ranking) == {"input", "rank_by", "settings", "ranking", "skipped"}
    assert ranking["ranking"] == result.results[0].rows
    from PIL import Image

    with Image.open(tmp_path / "heatmap.png") as picture:
        assert picture.mode == "RGB" and picture.height > 5 * 16 and picture.width > 200


def test_worker_processes_give_the_same_study(result):
    parallel = studies.study(
        items(), configs=["rigid:idw", "similarity:gaussian"], trials=2, jobs=2
    )
    assert parallel.table() == result.table()
    assert parallel.summary()["winners"] == result.summary()["winners"]


def test_heatmap_marks_winners_and_missing_cells():
    rows = [
        {"label": "a", "mean_rank": 1.0, "images": {"x": {"rank": 1}, "y": {"rank": 1}}},
        {"label": "b", "mean_rank": 2.0, "images": {"x": {"rank": 2}}},
    ]
    picture = studies.render_heatmap(rows, ["x", "y"], title="t")
    assert picture.ndim == 3 and picture.dtype == np.uint8
    assert ((picture == [230, 0, 0]).all(axis=-1)).sum() > 50  # red boxes
    assert ((picture == [170, 170, 170]).all(axis=-1)).sum() > 50  # the missing cell


def test_bad_arguments(gl):
    with pytest.raises(ValueError, match="at least one item"):
        studies.study([])
    twice = [items()[0], items()[0]]
    with pytest.raises(ValueError, match="repeated: small"):
        studies.study(twice, configs=["rigid:idw"], trials=1)
    with pytest.raises(ValueError, match="trials must be an integer from 1 to 1000, got 0"):
        studies.study(items(), trials=0)
    with pytest.raises(ValueError, match="trials must be an integer from 1 to 1000, got 1001"):
        studies.study(items(), trials=MAX_TRIALS + 1)  # not hours of work, nor memory, first
    with pytest.raises(TypeError, match=r"trials must be an integer from 1 to 1000, got 1\.0"):
        studies.study(items(), trials=1.0)
    with pytest.raises(TypeError, match=r"configs must be a sequence of .*, got 'rigid:idw'"):
        studies.study(items(), configs="rigid:idw", trials=1)  # not read letter by letter
    with pytest.raises(TypeError, match=r"scheduler must be a string, .*got 3"):
        studies.study(items(), configs=["rigid:idw"], trials=1, scheduler=3)


def test_numpy_integers_give_a_summary_json_can_write(gl):
    found = studies.study(
        items()[:1], configs=["rigid:idw"], trials=np.int64(1), seed=np.array(0), jobs=np.int64(1)
    )
    summary = json.loads(json.dumps(found.summary()))
    assert summary["settings"]["trials"] == 1 and summary["timings"]["jobs"] == 1
    with pytest.raises(TypeError, match="expected MLSConfig or spec strings"):
        studies.study(items(), configs=[3])
    with pytest.raises(TypeError, match="items must be StudyItems"):
        studies.study(["x"])
    for bad in (None, items()[0]):  # one item alone, not in a list
        with pytest.raises(TypeError, match=r"^items must be a sequence of StudyItems, got "):
            studies.study(bad)
    with pytest.raises(TypeError, match=r"^configs must be a sequence of .*, got MLSConfig\("):
        studies.study(items(), configs=MLSConfig(transform="rigid"), trials=1)
    flat = StudyItem("flat", (32, 40), items()[0].handles, np.array([[1, 1], [5, 5], [9, 9.0]]))
    done = []
    with pytest.raises(ValueError, match=r"^item 1: flat: reference_points all lie on one"):
        studies.study(
            [items()[1], flat], configs=["rigid:idw:alpha=1"], trials=1,
            on_step=lambda: done.append(1),
        )  # fmt: skip
    assert not done  # found before any image is tuned
    configs = parse_config("rigid:idw:alpha=2", (32, 40))
    one = studies.study(items(), configs=configs, trials=1)
    assert [r["label"] for r in one.table()] == ["rigid idw a=2"]


def write_manifest(tmp_path, entries, name="set.json"):
    path = tmp_path / name
    path.write_text(json.dumps({"items": entries}), encoding="utf-8")
    return path


@pytest.fixture
def files(tmp_path):
    from PIL import Image

    Image.new("RGB", (40, 32)).save(tmp_path / "a.png")
    (tmp_path / "h.json").write_text(json.dumps({"src": SRC.tolist(), "dst": SRC.tolist()}))
    (tmp_path / "r.json").write_text(json.dumps({"points": REFERENCE.tolist()}))
    (tmp_path / "two.json").write_text(json.dumps({"points": [[1, 1], [5, 5]]}))
    (tmp_path / "line.json").write_text(json.dumps({"points": [[1, 1], [5, 5], [9, 9]]}))
    (tmp_path / "twice.json").write_text(json.dumps({"points": [[1, 1], [5, 1], [1, 1], [3, 9]]}))
    return tmp_path


def test_a_manifest_reads_its_items(files):
    sub = files / "sub"
    sub.mkdir()
    path = write_manifest(sub, [
        {"image": "../a.png", "handles": "../h.json", "reference": "../r.json"},
        {"name": "b", "image": str(files / "a.png"), "handles": "../h.json",
         "reference": "../r.json", "description": "ignored"},
    ])  # fmt: skip
    found = read_manifest(path)
    assert [item.name for item in found] == ["a", "b"]
    assert found[0].shape == (32, 40) and found[0].image().shape == (32, 40, 3)
    np.testing.assert_array_equal(found[1].reference, REFERENCE)
    bare = files / "bare.json"
    bare.write_text(json.dumps([{"image": "a.png", "handles": "h.json", "reference": "r.json"}]))
    assert [item.name for item in read_manifest(bare)] == ["a"]


GOOD = {"image": "a.png", "handles": "h.json", "reference": "r.json"}


@pytest.mark.parametrize(
    ("entries", "message"),
    [
        ([{**GOOD, "image": "gone.png"}], r'"items"\[0\] \(gone\)\."image": .*gone.png: no such'),
        (
            [{**GOOD, "handles": "gone.json"}],
            r'"items"\[0\] \(a\)\."handles": .*gone.json: no such',
        ),
        ([{**GOOD, "reference": "two.json"}], r'"reference": .*2 reference points; .* at least 3'),
        ([{**GOOD, "reference": "line.json"}], r'\(a\)\."reference": .*line.json: .*on one line'),
        ([{**GOOD, "reference": "twice.json"}], r'"reference": .*twice.json: .* the same point'),
        ([{**GOOD, "handles": "bad.json"}], r'"handles": .*bad.json: line 1: invalid JSON'),
        ([{"image": "a.png", "handles": "h.json"}], r'"items"\[0\]\."reference": expected a file'),
        ([GOOD, GOOD], r'"items"\[1\]: the name \'a\' is taken by item 0'),
        ([{**GOOD, "name": "../x"}], r'"items"\[0\]\."name": expected letters'),
        (["a.png"], r'"items"\[0\]: expected an object with image, handles, reference'),
        ([], r'"items": no items'),
    ],
)
def test_bad_manifests_name_the_item_and_field(files, entries, message):
    (files / "bad.json").write_text("{nope")
    with pytest.raises(InputFileError, match=message):
        read_manifest(write_manifest(files, entries))


def test_bad_manifest_files(files):
    for text, message in [
        ("{", "set.json: line 1: invalid JSON"),
        ('{"list": []}', 'set.json: top level: missing the key "items"'),
        ('{"items": 3}', 'set.json: "items": expected a list of items, got int'),
    ]:
        (files / "set.json").write_text(text)
        with pytest.raises(InputFileError, match=message):
            read_manifest(files / "set.json")
    with pytest.raises(InputFileError, match="no such file"):
        read_manifest(files / "missing.json")


def test_an_image_that_is_a_folder_is_named_so(files):
    (files / "folder").mkdir()
    entries = [{"image": "folder", "handles": "h.json", "reference": "r.json"}]
    with pytest.raises(InputFileError, match=r'"image": .*folder: not a file'):
        read_manifest(write_manifest(files, entries))


def test_a_spec_that_repeats_a_configuration_on_one_image_keeps_the_places(gl):
    """On "small" (diagonal 51.2) the explicit radius 25.6 is the default grid's half
    diagonal too: the repeat is tuned once, and the rows after it still hold one
    configuration each, the same fraction of every image's diagonal."""
    found = studies.study(
        items(), configs=["rigid:gaussian:radius=25.6,interpolating=true", "rigid:gaussian"],
        trials=1,
    )  # fmt: skip
    diagonals = dict(zip(found.names, found.diagonals, strict=True))
    for row in found.table():
        fractions = {
            round(cell["config"]["radius"] / diagonals[name], 2)
            for name, cell in row["images"].items()
        }
        explicit = all(cell["config"]["radius"] == 25.6 for cell in row["images"].values())
        assert explicit or len(fractions) == 1, row
    ranked = {r["label"]: sorted(r["images"]) for r in found.table()}
    assert ranked == {
        "rigid gaussian R=25.6 interp": ["large", "small"],
        "rigid gaussian R=0.25 diag interp": ["large", "small"],
        "rigid gaussian R=38.4 interp": ["large"],  # half of large's diagonal
        "rigid gaussian R=1 diag interp": ["large", "small"],
    }


def test_labels_tell_configurations_apart():
    one = parse_config("rigid:gaussian:radius=20,interpolating=true", (32, 40))[0]
    two = parse_config("rigid:gaussian:radius=20,interpolating=true,alpha=2", (32, 40))[0]
    assert label(one) == "rigid gaussian R=20 interp"
    assert label(two) == "rigid gaussian R=20 interp a=2"


def test_a_radius_of_the_same_fraction_is_labelled_by_it_whatever_the_rounding():
    """Each image's radius is rounded to 0.1 px: half of 62.48 px is 31.2, 0.4994 of it."""
    shapes = ((40, 48), (56, 64))
    configs = [search_space(s, transforms=["rigid"], weights=["gaussian"])[1] for s in shapes]
    diagonals = [image_diagonal(shape) for shape in shapes]
    assert studies.study_label(configs, diagonals) == "rigid gaussian R=0.5 diag interp"


def _with_a_one_handle_image(configs):
    """The study of ``items()[0]`` and an image with one handle, where every configuration
    is the same translation (a tie the tune orders by name), two trials."""
    one = HandleSet.validate(SRC[:1], SRC[:1] + [3.0, 2.0])
    items_ = [items()[0], StudyItem("one", (32, 40), one, REFERENCE)]
    return studies.study(items_, configs=configs, trials=2)


def test_configurations_a_tune_cannot_tell_apart_share_their_rank(gl):
    """With one handle every configuration is the same translation: the tune's order of
    them is by name only, and says nothing of which suits the image."""
    found = _with_a_one_handle_image(["rigid:idw", "affine:idw:alpha=1"])
    scores = {r["images"]["one"]["score"] for r in found.table()}
    assert len(scores) == 1  # a three-way tie
    agreement = found.summary()["rank_agreement"]
    assert agreement["kendall_tau"][0]["tau"] is None  # no order to agree with
    assert agreement["kendall_w"] == pytest.approx(0.5)  # a mean Spearman correlation of 0
    assert [r["images"]["one"]["tied_rank"] for r in found.table()] == [2.0, 2.0, 2.0]


def test_a_configuration_tied_for_first_wins_there_too(gl):
    """Where the tune cannot tell the configurations apart (one handle: the same
    translation), its order of them is by name: the winner elsewhere ties for first there,
    so one configuration wins everywhere, not as many as the names make."""
    found = _with_a_one_handle_image(["rigid:idw", "similarity:idw:alpha=1"])
    rows = found.table()
    best_small = min(rows, key=lambda r: r["images"]["small"]["rank"])
    first_by_name = min(rows, key=lambda r: r["images"]["one"]["rank"])
    assert first_by_name is not best_small  # the tie broken by name picks another
    summary = found.summary()
    assert summary["winners"]["small"]["label"] == best_small["label"]
    assert summary["winners"]["one"]["label"] == best_small["label"]
    assert summary["distinct_winners"] == 1
    assert summary["one_configuration_wins_everywhere"]
    assert summary["answer"].startswith("1 distinct winner over 2 images")
    others = {r["label"] for r in rows} - {best_small["label"]}
    assert set(summary["winners"]["one"]["tied_with"]) == others
    assert summary["winners"]["small"]["tied_with"] == []
    assert [r["images"]["one"]["winner"] for r in rows] == [True, True, True]
    assert [r["images"]["small"]["winner"] for r in rows] == [r is best_small for r in rows]
    assert best_small["wins"] == 2


def test_a_study_of_one_image_does_not_answer_the_question(gl):
    """One image has one winner: that it wins everywhere says nothing, and that no
    configuration does is false; the answer says that one image cannot tell."""
    summary = studies.study(items()[:1], configs=["rigid:idw"], trials=1).summary()
    assert summary["distinct_winners"] == 1
    assert summary["answer"].startswith("1 winner over 1 image: ")
    assert "no configuration wins everywhere" not in summary["answer"]
    assert "one image cannot tell" in summary["answer"]


def test_a_tie_broken_by_name_does_not_decide_the_mean_rank(gl):
    """On an image where the tune cannot tell the configurations apart, the mean rank
    takes their shared tied rank, not the order by name: the winner elsewhere is best."""
    found = _with_a_one_handle_image(["rigid:idw", "similarity:idw:alpha=1"])
    rows = found.table()
    for row in rows:
        cells = row["images"].values()
        assert row["mean_rank"] == pytest.approx(np.mean([c["tied_rank"] for c in cells]))
    best_small = min(rows, key=lambda r: r["images"]["small"]["tied_rank"])
    assert rows[0]["label"] == best_small["label"]
    assert found.summary()["best_overall"]["label"] == best_small["label"]


@pytest.mark.parametrize("name", ["summary.json", "Table.CSV", "heatmap.png"])
def test_an_item_named_like_a_study_file_is_refused(name):
    """Its folder would take the place of the study's own file, found only after the work."""
    with pytest.raises(ValueError, match="one of the study's own files"):
        studies.study([StudyItem(name, (32, 40), items()[0].handles, REFERENCE)], trials=1)
