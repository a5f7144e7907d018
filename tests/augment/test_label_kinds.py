"""Augment's arguments each come back in the kind they came in, whatever the images' kind:
numpy images with torch labels, torch images with numpy labels, one label a tensor among
numpy ones; the values as the all-numpy call gives them (the float64 reference of the moved
points is the numpy call's own, tested elsewhere)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="torch not installed (the torch extra)")

from glmls.augment import Augment  # noqa: E402

H, W = 24, 32
KEYPOINTS = np.array([[[5.0, 5.0], [20.0, 12.0]], [[3.5, 18.0], [30.0, 2.0]]])
BOXES = np.array([[[4.0, 4.0, 14.0, 12.0]], [[10.0, 6.0, 28.0, 20.0]]], dtype=np.float32)
TRIANGLE = np.array([[2.0, 2.0], [16.0, 3.0], [9.0, 15.0]])
LABELS = ("keypoints", "masks", "boxes", "polygons")


def _inputs():
    images = np.random.default_rng(5).integers(0, 255, (2, H, W, 3), dtype=np.uint8)
    masks = np.zeros((2, H, W), np.uint8)
    masks[:, 6:14, 8:20] = 3
    labels = {
        "keypoints": KEYPOINTS,
        "masks": masks,
        "boxes": BOXES,
        "polygons": [[TRIANGLE], [TRIANGLE + 4.0]],
    }
    return images, labels


def _as_tensors(name: str, value):
    if name == "polygons":
        return [[torch.from_numpy(p) for p in shapes] for shapes in value]
    return torch.from_numpy(value)


def _numpy(value):
    if isinstance(value, torch.Tensor):
        return value.numpy()
    if isinstance(value, list):
        return [_numpy(v) for v in value]
    return value


def _check_kind(name: str, out, tensor: bool) -> None:
    kind = torch.Tensor if tensor else np.ndarray
    value = getattr(out, name)
    items = [p for shapes in value for p in shapes] if name == "polygons" else [value]
    assert all(isinstance(item, kind) for item in items), (name, type(items[0]))
    if name in ("keypoints", "boxes"):
        assert isinstance(getattr(out, f"{name}_valid"), kind)


def _same(got, want) -> None:
    """Equal, a tensor's values to its dtype's rounding of the numpy call's (float32 boxes
    come back float32 as tensors, float64 as arrays)."""
    np.testing.assert_array_equal(got, np.asarray(want).astype(np.asarray(got).dtype))


def _assert_same(out, expected) -> None:
    for name in ("images", *LABELS):
        got, want = _numpy(getattr(out, name)), getattr(expected, name)
        if name == "polygons":
            for shapes, wanted in zip(got, want, strict=True):
                for one, other in zip(shapes, wanted, strict=True):
                    _same(one, other)
        else:
            _same(got, want)


@pytest.mark.parametrize("tensor_label", LABELS)
def test_numpy_images_with_one_tensor_label(gl, tensor_label):
    images, labels = _inputs()
    aug = Augment("grid", seed=2)
    expected = aug(images, **labels)
    given = {**labels, tensor_label: _as_tensors(tensor_label, labels[tensor_label])}
    out = aug(images, **given)
    assert isinstance(out.images, np.ndarray)
    for name in LABELS:
        _check_kind(name, out, name == tensor_label)
    _assert_same(out, expected)


def test_numpy_images_with_every_label_a_tensor_and_replay(gl):
    images, labels = _inputs()
    aug = Augment("grid", seed=3)
    expected = aug(images, **labels)
    given = {name: _as_tensors(name, value) for name, value in labels.items()}
    out = aug(images, **given)
    assert isinstance(out.images, np.ndarray)
    for name in LABELS:
        _check_kind(name, out, True)
    assert out.keypoints.dtype == torch.float64 and out.boxes.dtype == torch.float32
    assert out.masks.dtype == torch.uint8
    _assert_same(out, expected)
    again = aug.replay(images, out.params, **given)
    _assert_same(again, expected)
    assert isinstance(again.keypoints, torch.Tensor) and isinstance(again.images, np.ndarray)


def test_torch_images_with_numpy_labels(gl):
    images, labels = _inputs()
    aug = Augment("grid", seed=4)
    expected = aug(images, **labels)
    batch = torch.from_numpy(images).permute(0, 3, 1, 2)
    out = aug(batch, **labels)
    assert isinstance(out.images, torch.Tensor) and out.images.shape == (2, 3, H, W)
    np.testing.assert_array_equal(out.images.permute(0, 2, 3, 1).numpy(), expected.images)
    for name in LABELS:
        _check_kind(name, out, False)
    _assert_same(dataclass_images_last(out), expected)


def dataclass_images_last(out):
    """``out`` with its torch images channels last, as the numpy call gives them."""
    import dataclasses

    return dataclasses.replace(out, images=out.images.permute(0, 2, 3, 1))


def test_keypoints_per_image_as_tensors_come_back_per_image(gl):
    images, _ = _inputs()
    aug = Augment("grid", seed=5)
    expected = aug(images, keypoints=list(KEYPOINTS))
    given = [torch.from_numpy(k).float() for k in KEYPOINTS]
    out = aug(images, keypoints=given)
    assert isinstance(out.keypoints, list) and len(out.keypoints) == 2
    for moved, want in zip(out.keypoints, expected.keypoints, strict=True):
        assert isinstance(moved, torch.Tensor) and moved.dtype == torch.float32
        np.testing.assert_allclose(moved.numpy(), want, rtol=0, atol=1e-5)  # float32's rounding


def test_landmarks_preset_takes_tensor_keypoints_with_numpy_images(gl):
    images, _ = _inputs()
    aug = Augment("landmarks", seed=6)
    expected = aug(images, keypoints=KEYPOINTS)
    out = aug(images, keypoints=torch.from_numpy(KEYPOINTS))
    assert isinstance(out.images, np.ndarray) and isinstance(out.keypoints, torch.Tensor)
    np.testing.assert_array_equal(out.images, expected.images)
    np.testing.assert_array_equal(out.keypoints.numpy(), expected.keypoints)
    assert aug.draw([(H, W)] * 2, landmarks=torch.from_numpy(KEYPOINTS)) == expected.params
