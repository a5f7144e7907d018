"""glmls.augment.Augment's own options: each bad value is refused when the Augment is made
(or, where the image's size decides, when it draws), the error naming the option."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from glmls.augment import Augment
from glmls.gl.context import create_headless


@pytest.mark.parametrize(
    ("preset", "options", "message"),
    [
        ("grid", {"displacement": 1e30}, "displacement=1e+30"),
        ("grid", {"displacement": 1e7, "units": "pixels"}, "displacement=10000000.0"),
        ("landmarks", {"displacement": 1e12}, "displacement=1000000000000.0"),
        ("text-distort", {"radius": 1e9}, "radius=1000000000.0"),
        ("text-stretch", {"radius": 1e9}, "radius=1000000000.0"),
        ("text-perspective", {"radius": 1e9}, "radius=1000000000.0"),
    ],
)
def test_a_magnitude_beyond_the_coordinate_limit_names_the_option(gl, preset, options, message):
    aug = Augment(preset, **options)
    images = np.zeros((2, 16, 24), np.uint8)
    with pytest.raises(ValueError, match=r"^images\[0\]: .*" + message.replace("+", r"\+")):
        aug(images, keypoints=np.full((2, 1, 2), 5.0))


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"warp_options": {"methd": "quads"}}, TypeError, "warp_options has no keyword methd"),
        ({"warp_options": {"keypoints": 1}}, TypeError, "warp_options cannot hold keypoints"),
        ({"warp_options": {"masks": None}}, TypeError, "warp_options cannot hold masks"),
        ({"warp_options": {"grid": 0}}, ValueError, "grid must be an integer from 1"),
        ({"warp_options": {"method": "swirl"}}, ValueError, "unknown method 'swirl'"),
        ({"clip_polygons": "no"}, TypeError, "clip_polygons must be True or False, got 'no'"),
        ({"box_step": True}, TypeError, "box_step must be a finite number > 0, got True"),
        (["grid"], TypeError, r"preset must be a name .* or a preset object, got list"),
    ],
)
def test_bad_options_are_refused_when_made(options, error, message):
    preset, keywords = ("grid", options) if isinstance(options, dict) else (options, {})
    with pytest.raises(error, match=message):
        Augment(preset, **keywords)


@pytest.mark.parametrize("value", [np.float32(1.5), np.int64(2), np.float64(3.0), 4])
def test_numpy_numbers_are_numbers(value):
    aug = Augment("grid", box_step=value, densify=value)
    assert aug.box_step == float(value) and aug.densify == float(value)


def test_landmarks_that_coincide_move_together(gl):
    """Datasets mark a missing landmark with one point, (0, 0) say: equal landmarks are one
    handle, moved by one offset (the first's), and a landmark on a pinned corner stays."""
    images = np.zeros((2, 16, 24), np.uint8)
    marks = np.array([[[0.0, 0.0], [12.0, 6.0], [0.0, 0.0], [-0.5, -0.5]]] * 2)
    out = Augment("landmarks", displacement=2, units="pixels", seed=4)(images, keypoints=marks)
    for params in out.params:
        src, dst = np.array(params["src"]), np.array(params["dst"])
        np.testing.assert_array_equal(dst[2], dst[0])
        np.testing.assert_array_equal(dst[3], src[3])
        assert not np.array_equal(dst[0], src[0])
    np.testing.assert_array_equal(out.keypoints[:, 2], out.keypoints[:, 0])
    unique = np.array([[[0.0, 0.0], [12.0, 6.0]]] * 2)
    alone = Augment("landmarks", displacement=2, units="pixels", seed=4)(images, keypoints=unique)
    np.testing.assert_array_equal(np.array(alone.params[0]["dst"])[:2], out.params[0]["dst"][:2])


def test_landmarks_next_to_another_handle(gl):
    """docs/augment.md: a landmark next to another handle that moves differently lands off
    its drawn target with the mesh, by up to most of the difference between the two moves;
    ``method="backward"`` moves it by f, onto the target."""
    images = np.zeros((16, 64, 64), np.uint8)
    marks = np.random.default_rng(2).uniform(10, 50, (16, 2, 2))
    marks[:, 1] = marks[:, 0] + (0.2, 0.0)
    for options, share in (({}, 0.9), ({"method": "backward"}, 1e-4)):
        out = Augment("landmarks", seed=0, warp_options=options)(images, keypoints=marks)
        for params, moved in zip(out.params, out.keypoints, strict=True):
            src, dst = np.array(params["src"])[:2], np.array(params["dst"])[:2]
            apart = np.linalg.norm((dst - src)[0] - (dst - src)[1])
            error = np.linalg.norm(moved - dst, axis=1).max()
            assert error <= share * apart, (options, error, apart)


def test_a_warp_options_object_is_its_fields(gl):
    """``warp_options={"options": glmls.WarpOptions(...)}`` (a keyword warp_batch takes)
    stands for its fields: over the defaults, under the other keywords given, and the
    params stay JSON that replays."""
    import json

    import glmls

    chosen = glmls.WarpOptions(method="backward", grid=4, border="reflect")
    aug = Augment("grid", seed=2, warp_options={"options": chosen, "grid": 2})
    images = np.random.default_rng(1).integers(0, 255, (2, 12, 16), dtype=np.uint8)
    first = aug(images)
    options = first.params[0]["options"]
    assert "options" not in options
    assert (options["method"], options["grid"], options["border"]) == ("backward", 2, "reflect")
    assert options["interpolation"] == "nearest" and options["transform"] == "similarity"
    record = json.loads(json.dumps(first.params))
    np.testing.assert_array_equal(aug.replay(images, record).images, first.images)
    expected = glmls.warp_batch(
        images, [r["src"] for r in record], [r["dst"] for r in record], options=chosen,
        grid=2, transform="similarity",
    )  # fmt: skip
    np.testing.assert_array_equal(first.images, expected)
    with pytest.raises(TypeError, match=r"warp_options: options must be a glmls\.WarpOptions"):
        Augment("grid", warp_options={"options": {"method": "backward"}})


def test_a_context_in_warp_options_stays_out_of_the_params(gl):
    """``warp_options={"ctx": ...}`` renders on that context; the params, which must be
    JSON, do not record it, and replay renders on the Augment's context again."""
    import json

    aug = Augment("grid", seed=5, warp_options={"ctx": gl})
    images = np.random.default_rng(2).integers(0, 255, (2, 12, 16), dtype=np.uint8)
    first = aug(images)
    assert "ctx" not in first.params[0]["options"]
    record = json.loads(json.dumps(first.params))
    np.testing.assert_array_equal(aug.replay(images, record).images, first.images)


def test_an_augment_with_a_context_of_its_own_copies_and_says_why_it_does_not_pickle(gl):
    """A context is the process's GL state: a (deep) copy of an Augment given ``ctx`` renders
    on that context too, and pickling it (for a spawn worker) says what to do."""
    ctx = create_headless()
    try:
        aug = Augment("grid", seed=2, warp_options={"ctx": ctx})
        images = np.random.default_rng(0).integers(0, 255, (2, 12, 16), dtype=np.uint8)
        for copied in (copy.copy(aug), copy.deepcopy(aug)):
            assert copied.warp_options["ctx"] is ctx
            np.testing.assert_array_equal(copied(images).images, aug(images).images)
        with pytest.raises(TypeError, match=r"GLContext cannot be pickled: .* leave ctx out"):
            pickle.dumps(aug)
    finally:
        ctx.release()


@pytest.mark.parametrize("kind", ["numpy", "torch"])
def test_indices_may_be_zero_dimensional_arrays_and_tensors(gl, kind):
    """An index taken from an array or a tensor (``for i in torch.randperm(n)``) is 0-d: it
    numbers the draw as its integer does."""
    make = np.array if kind == "numpy" else pytest.importorskip("torch").tensor
    aug = Augment("grid", seed=4)
    images = np.random.default_rng(1).integers(0, 255, (2, 10, 12), dtype=np.uint8)
    out = aug(images, indices=[make(7), make(2)])
    assert [p["index"] for p in out.params] == [7, 2]
    np.testing.assert_array_equal(out.images, aug(images, indices=[7, 2]).images)
    with pytest.raises(TypeError, match=r"indices\[0\] must be an integer >= 0"):
        aug(images, indices=[make(1.0), make(2)])


def test_each_record_is_its_own_and_holds_python_numbers():
    """Every sample's record owns its dicts and lists (changing one leaves the others), and
    numpy values given as options are recorded as the Python numbers and lists JSON holds."""
    aug = Augment(
        "grid",
        rows=np.int64(3),
        displacement=np.float32(0.25),
        warp_options={"background": np.array([1.0, 2.0, 3.0]), "alpha": np.float64(1.5)},
    )
    first, second = aug.draw([(10, 12), (10, 12)])
    first["options"]["background"][0] = 9.0
    first["config"]["rows"] = 7
    assert second["options"]["background"] == [1.0, 2.0, 3.0]
    assert second["config"]["rows"] == 3
    for record in (first, second):
        assert type(record["config"]["rows"]) is int
        assert type(record["config"]["displacement"]) is float
        assert type(record["options"]["alpha"]) is float
        assert all(type(v) is float for v in second["options"]["background"])
        assert all(type(v) is float for point in record["src"] for v in point)
