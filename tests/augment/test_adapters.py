"""The adapters of glmls.augment: an albumentations DualTransform, a torchvision v2 Transform
and torch tensors in and out of Augment. Each follows its library's contract, draws from that
library's random numbers, and deforms every target through the same map as
Augment.replay with the draw it reports."""

from __future__ import annotations

import doctest
import importlib
import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

from glmls.augment import Augment

os.environ.setdefault("NO_ALBUMENTATIONS_UPDATE", "1")  # no version check over the network

A = pytest.importorskip("albumentations", reason="albumentations not installed (the extra)")
torch = pytest.importorskip("torch", reason="torch not installed (the torch extra)")
tv_tensors = pytest.importorskip("torchvision.tv_tensors", reason="torchvision not installed")

from glmls.augment.albumentations import MLSDeform  # noqa: E402
from glmls.augment.torchvision import MLSTransform  # noqa: E402


@pytest.mark.parametrize("module", ["glmls.augment.albumentations", "glmls.augment.torchvision"])
def test_the_examples_run(gl, module):
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    result = doctest.testmod(importlib.import_module(module), optionflags=flags)
    assert result.failed == 0 and result.attempted > 5


@pytest.fixture
def sample(rng):
    image = rng.integers(0, 255, (40, 64, 3), dtype=np.uint8)
    mask = np.zeros((40, 64), np.uint8)
    mask[10:30, 20:50] = 5
    return image, mask


def test_albumentations_compose_moves_every_target_through_one_map(gl, sample):
    image, mask = sample
    transform = MLSDeform("grid", preset_options={"displacement": 0.05})
    compose = A.Compose(
        [transform],
        keypoint_params=A.KeypointParams(format="xy", remove_invisible=False),
        bbox_params=A.BboxParams(format="pascal_voc", label_fields=["labels"]),
        seed=3,
    )
    points = [(30.0, 20.0), (10.0, 5.0)]
    out = compose(image=image, mask=mask, keypoints=points, bboxes=[(20, 10, 50, 30)], labels=[1])
    draw = transform.get_applied_params()["mls"]
    aug = transform.augment
    expected = aug.replay(
        [image],
        [draw],
        keypoints=[np.array(points)],
        masks=[mask],
        boxes=[[[19.5, 9.5, 49.5, 29.5]]],
    )
    np.testing.assert_array_equal(out["image"], expected.images[0])
    np.testing.assert_array_equal(out["mask"], expected.masks[0])
    np.testing.assert_allclose(out["keypoints"], expected.keypoints[0], atol=1e-4)
    np.testing.assert_allclose(out["bboxes"][0], expected.boxes[0][0] + 0.5, atol=1e-3)
    assert set(np.unique(out["mask"])) <= {0, 5}
    # the same seed, the same draw; another seed, another
    again = A.Compose([MLSDeform("grid", preset_options={"displacement": 0.05})], seed=3)
    np.testing.assert_array_equal(again(image=image)["image"], out["image"])
    other = A.Compose([MLSDeform("grid", preset_options={"displacement": 0.05})], seed=4)
    assert not np.array_equal(other(image=image)["image"], out["image"])


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.float16, bool, np.int32])
def test_albumentations_masks_of_any_dtype_albumentations_takes(gl, sample, dtype):
    """albumentations passes float masks (soft labels, a normalised pipeline) as readily as
    integer ones: each is warped with nearest sampling, its values kept, of its dtype."""
    image, mask = sample
    scale = 0.75 if np.dtype(dtype).kind == "f" else 7  # 5 -> 0.75 or 35
    values = (mask > 0) if dtype is bool else (mask / 5 * scale).astype(dtype)
    transform = MLSDeform("grid", preset_options={"displacement": 0.05})
    out = A.Compose([transform], seed=3)(image=image, mask=values, masks=[values, values])
    expected = transform.augment.replay([image], [transform.get_applied_params()["mls"]],
                                        masks=[mask])  # fmt: skip
    assert out["mask"].dtype == values.dtype and out["mask"].shape == mask.shape
    np.testing.assert_array_equal(out["mask"] != 0, expected.masks[0] != 0)
    assert set(np.unique(out["mask"]).tolist()) <= set(np.unique(values).tolist())
    for one in out["masks"]:
        np.testing.assert_array_equal(one, out["mask"])


@pytest.mark.parametrize(
    ("dtype", "label"), [(np.int64, 2**40), (np.uint32, 3_000_000_000), (np.int32, -(2**30))]
)
def test_albumentations_integer_masks_with_large_labels(gl, sample, dtype, label):
    """Instance ids beyond 2**24 (which float32 would round) come back bit for bit, as
    floating-point masks' values do: a mask is labels, however large its numbers."""
    image, mask = sample
    values = np.where(mask > 0, label, 7).astype(dtype)
    transform = MLSDeform("grid", preset_options={"displacement": 0.05})
    out = A.Compose([transform], seed=3)(image=image, mask=values)["mask"]
    draw = transform.get_applied_params()["mls"]
    small = np.where(mask > 0, 2, 1).astype(np.uint8)
    expected = transform.augment.replay([image], [draw], masks=[small])
    lookup = np.array([0, 7, label], dtype)
    assert out.dtype == values.dtype
    np.testing.assert_array_equal(out, lookup[expected.masks[0]])


def test_albumentations_landmarks_and_text_presets(gl, sample):
    image, _ = sample
    compose = A.Compose(
        [MLSDeform("landmarks", preset_options={"displacement": 3, "units": "pixels"})],
        keypoint_params=A.KeypointParams(format="xy", remove_invisible=False),
        seed=0,
    )
    out = compose(image=image, keypoints=[(30.0, 20.0)])
    assert out["image"].shape == image.shape and len(out["keypoints"]) == 1
    for name in ("text-distort", "text-stretch", "text-perspective"):
        assert A.Compose([MLSDeform(name)], seed=0)(image=image)["image"].shape == image.shape


def test_albumentations_names_the_row_of_a_keypoint_or_box_that_is_not_finite(gl):
    t = MLSDeform(preset_options={"displacement": 0})
    t.set_random_seed(0)
    draw = t.get_params_dependent_on_data({"shape": (16, 16)}, {})
    points = np.array([[4.0, 5.0, 0, 1], [1, 1, 0, 1], [2, 2, 0, 1], [np.inf, 3, 0, 1]])
    with pytest.raises(ValueError, match=r"^keypoints holds .* not finite .*: row 3$"):
        t.apply_to_keypoints(points, **draw)
    points[3, 0] = 1e300
    with pytest.raises(ValueError, match=r"^keypoints must lie within .*; row 3 reaches 1e\+300$"):
        t.apply_to_keypoints(points, **draw)
    boxes = np.array([[0.1, 0.2, 0.5, 0.6]] * 2 + [[0.1, 0.2, np.inf, 0.6]])
    with pytest.raises(ValueError, match=r"^bboxes holds .* not finite .*: row 2$"):
        t.apply_to_bboxes(boxes, **draw)


def test_torchvision_batch_draws_per_sample(gl, rng):
    images = torch.from_numpy(rng.integers(0, 255, (3, 3, 24, 40), dtype=np.uint8))
    masks = torch.zeros(3, 24, 40, dtype=torch.int64)
    masks[:, 5:15, 10:30] = 9
    points = torch.tensor([[[12.0, 10.0], [30.0, 14.0]]] * 3)
    inputs = (
        tv_tensors.Image(images),
        tv_tensors.Mask(masks),
        tv_tensors.KeyPoints(points, canvas_size=(24, 40)),
    )
    transform = MLSTransform("grid", displacement=0.06)
    torch.manual_seed(0)
    out_images, out_masks, out_points = transform(*inputs)
    params = transform.last_params
    assert len({str(p["dst"]) for p in params}) == 3  # a draw per sample
    assert isinstance(out_images, tv_tensors.Image) and out_images.dtype == torch.uint8
    assert isinstance(out_masks, tv_tensors.Mask) and out_masks.dtype == torch.int64
    assert isinstance(out_points, tv_tensors.KeyPoints) and out_points.canvas_size == (24, 40)
    expected = transform.augment.replay(
        np.moveaxis(images.numpy(), 1, -1),
        params,
        keypoints=points.numpy(),
        masks=masks.numpy(),
    )
    np.testing.assert_array_equal(np.moveaxis(out_images.numpy(), 1, -1), expected.images)
    np.testing.assert_array_equal(out_masks.numpy(), expected.masks)
    np.testing.assert_allclose(out_points.numpy(), expected.keypoints, atol=1e-5)
    torch.manual_seed(0)
    np.testing.assert_array_equal(transform(inputs[0]).numpy(), out_images.numpy())


def test_torchvision_batch_labels_must_have_the_batch_first(gl, rng):
    """One Mask or KeyPoints for a batch of N has N first; another first dimension is an
    error, not the samples' labels split or merged."""
    images = tv_tensors.Image(torch.zeros(4, 3, 24, 32, dtype=torch.uint8))
    transform = MLSTransform("grid")
    wrong = [
        tv_tensors.KeyPoints(torch.rand(8, 2) * 20, canvas_size=(24, 32)),  # not 4 x (2, 2)
        tv_tensors.Mask(torch.zeros(8, 24, 32, dtype=torch.uint8)),  # not 4 x 2 layers
        tv_tensors.Mask(torch.zeros(24, 32, dtype=torch.uint8)),
    ]
    for label in wrong:
        shape = tuple(label.shape)
        with pytest.raises(ValueError, match=rf"of shape \({shape[0]}, .* for a batch of 4"):
            transform(images, label)
    one = tv_tensors.Image(torch.zeros(1, 3, 24, 32, dtype=torch.uint8))
    points = tv_tensors.KeyPoints(torch.full((2, 2), 9.0), canvas_size=(24, 32))
    assert tuple(transform(one, points)[1].shape) == (2, 2)  # a batch of one may leave it out


def test_torchvision_boxes_per_sample_in_any_format(gl, rng):
    image = tv_tensors.Image(torch.from_numpy(rng.random((3, 32, 32), dtype=np.float32)))
    boxes = tv_tensors.BoundingBoxes(
        torch.tensor([[4.0, 6.0, 10.0, 8.0]]), format="XYWH", canvas_size=(32, 32)
    )
    transform = MLSTransform("grid", displacement=0.0)
    out_image, out_boxes = transform(image, boxes)
    assert out_boxes.format == tv_tensors.BoundingBoxFormat.XYWH
    np.testing.assert_allclose(out_boxes.numpy(), boxes.numpy(), atol=1e-4)
    assert out_image.dtype == torch.float32
    moved = MLSTransform("grid", displacement=0.1)
    torch.manual_seed(1)
    _, shifted = moved(image, boxes)
    assert not torch.allclose(shifted, boxes)
    with pytest.raises(ValueError, match="2 BoundingBoxes for 3 samples"):
        moved(tv_tensors.Image(torch.zeros(3, 1, 32, 32)), boxes, boxes)


def test_torchvision_landmarks_and_a_single_image(gl):
    image = tv_tensors.Image(torch.zeros(1, 16, 16, dtype=torch.uint8))
    marks = tv_tensors.KeyPoints(torch.tensor([[8.0, 8.0]]), canvas_size=(16, 16))
    transform = MLSTransform("landmarks", displacement=2.0, units="pixels")
    _, moved = transform(image, marks)
    dst = np.asarray(transform.last_params[0]["dst"][0])
    np.testing.assert_allclose(moved.numpy()[0], dst, atol=0.05)


def test_augment_takes_and_gives_torch_tensors(gl, rng):
    images = torch.from_numpy(rng.integers(0, 255, (2, 3, 16, 24), dtype=np.uint8))
    points = torch.tensor([[[4.0, 4.0]], [[10.0, 8.0]]], dtype=torch.float32)
    aug = Augment("grid", seed=1)
    out = aug(images, keypoints=points, boxes=torch.tensor([[[2.0, 2.0, 9.0, 9.0]]] * 2))
    assert isinstance(out.images, torch.Tensor) and out.images.shape == images.shape
    assert out.images.dtype == torch.uint8 and out.keypoints.dtype == torch.float32
    assert isinstance(out.boxes, torch.Tensor) and out.boxes_valid.dtype == torch.bool
    plain = aug(np.moveaxis(images.numpy(), 1, -1), keypoints=points.numpy())
    np.testing.assert_array_equal(np.moveaxis(out.images.numpy(), 1, -1), plain.images)
    again = aug.replay(images, out.params)
    assert torch.equal(again.images, out.images)


def _run_child(code: str, cwd) -> str:
    """The stdout of ``code`` run in a fresh process, which must exit with status 0."""
    if importlib.util.find_spec("triton") is None:
        pytest.skip("triton is not installed: no two LLVMs to clash")
    pytest.importorskip("torchvision")
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=cwd
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_torchvision_imports_after_glmls_first_warp(tmp_path):
    """torchvision (and its triton, with an LLVM of its own) imported after glmls made its
    first GL context, Mesa's llvmpipe where there is no GPU driver: the process neither
    crashes nor refuses, and both go on working."""
    code = (
        "import numpy as np, glmls\n"
        "image = np.arange(64, dtype=np.uint8).reshape(8, 8)\n"
        "glmls.warp(image, [[1, 1]], [[2, 2]])\n"
        "import torch, torchvision\n"
        "from torchvision.transforms import v2\n"
        "from glmls.augment.torchvision import MLSTransform\n"
        "out = MLSTransform('grid')(torch.zeros(1, 16, 16, dtype=torch.uint8))\n"
        "again = glmls.warp(image, [[1, 1]], [[2, 2]])\n"
        "print(tuple(out.shape), again.shape)\n"
    )
    assert "(1, 16, 16) (8, 8)" in _run_child(code, tmp_path)


def test_another_librarys_gl_context_first_is_an_import_error(tmp_path):
    """Where a GL context that glmls did not make loaded Mesa's LLVM before triton's, the
    adapter's import raises, naming the order, instead of letting triton end the process."""
    code = (
        "import sys, moderngl\n"
        "ctx = moderngl.create_context(standalone=True, backend='egl', require=430)\n"
        "if 'libLLVM' not in open('/proc/self/maps').read():\n"
        "    print('no clash here'); sys.exit(0)\n"
        "try:\n"
        "    import glmls.augment.torchvision\n"
        "except ImportError as error:\n"
        "    print(error); sys.exit(0)\n"
        "sys.exit(3)\n"
    )
    out = _run_child(code, tmp_path)
    assert "no clash here" in out or "before the process makes its first" in out


def test_albumentations_integer_keypoints_and_boxes_come_back_as_floats(gl):
    """Called directly with integer arrays, the moved keypoints and the normalised boxes keep
    their fractions (float64), equal to the float input's; float input keeps its dtype."""
    t = MLSDeform(preset_options={"displacement": 0.1})
    t.set_random_seed(0)
    draw = t.get_params_dependent_on_data({"shape": (16, 16)}, {})
    points = np.array([[4, 5, 0, 1], [9, 2, 0, 1]])
    moved = t.apply_to_keypoints(points, **draw)
    assert moved.dtype == np.float64
    np.testing.assert_array_equal(moved, t.apply_to_keypoints(points.astype(float), **draw))
    assert not np.array_equal(moved[:, :2], np.round(moved[:, :2]))  # fractions kept
    assert t.apply_to_keypoints(points.astype(np.float32), **draw).dtype == np.float32
    boxes = np.array([[0, 0, 1, 1]])
    out = t.apply_to_bboxes(boxes, **draw)
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, t.apply_to_bboxes(boxes.astype(float), **draw))
