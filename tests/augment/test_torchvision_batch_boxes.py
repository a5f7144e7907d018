"""MLSTransform on a batch with the wrong number of BoundingBoxes: torchvision's boxes are
(B, 4), with no batch dimension, so the error asks for one per sample in order and does not
offer boxes with the batch first, which torchvision cannot make."""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch", reason="torch not installed (the torch extra)")
tv_tensors = pytest.importorskip("torchvision.tv_tensors", reason="torchvision not installed")

from glmls.augment.torchvision import MLSTransform  # noqa: E402


def _boxes(count: int) -> list:
    return [
        tv_tensors.BoundingBoxes(
            torch.tensor([[5.0, 5.0, 20.0, 20.0]]), format="XYXY", canvas_size=(32, 48)
        )
        for _ in range(count)
    ]


@pytest.mark.parametrize("given", [1, 3])
def test_too_few_boxes_for_a_batch_ask_for_one_per_sample(given):
    images = tv_tensors.Image(torch.zeros(4, 3, 32, 48, dtype=torch.uint8))
    with pytest.raises(ValueError) as caught:
        MLSTransform()(images, *_boxes(given))
    message = str(caught.value)
    assert f"{given} BoundingBoxes for 4 samples: give one per sample, in order" in message
    assert "first dimension" not in message
    with pytest.raises(ValueError, match="Expected a 1D or 2D tensor"):  # no (N, B, 4) boxes
        tv_tensors.BoundingBoxes(torch.zeros(4, 1, 4), format="XYXY", canvas_size=(32, 48))


def test_keypoints_still_offer_the_batch_first():
    images = tv_tensors.Image(torch.zeros(4, 3, 32, 48, dtype=torch.uint8))
    points = [tv_tensors.KeyPoints(torch.zeros(2, 2), canvas_size=(32, 48)) for _ in range(2)]
    with pytest.raises(ValueError, match="or ones with the batch as their first dimension"):
        MLSTransform()(images, *points)


def test_one_box_set_per_sample_is_taken(gl):
    images = tv_tensors.Image(torch.zeros(4, 3, 32, 48, dtype=torch.uint8))
    out = MLSTransform(displacement=0)(images, *_boxes(4))
    for boxes in out[1:]:
        torch.testing.assert_close(boxes, _boxes(1)[0], atol=1e-6, rtol=0)


@pytest.mark.parametrize("empty", [torch.tensor([]), torch.zeros(0, 4)], ids=["(1, 0)", "(0, 4)"])
def test_an_image_without_boxes_passes_them_as_torchvision_does(gl, empty):
    """An image without objects: ``BoundingBoxes(torch.tensor([]))`` is (1, 0), which
    torchvision's transforms pass as it is; alone and as one sample of a batch."""
    v2 = pytest.importorskip("torchvision.transforms.v2")
    image = tv_tensors.Image(torch.zeros(3, 32, 48, dtype=torch.uint8))
    none = tv_tensors.BoundingBoxes(empty, format="XYXY", canvas_size=(32, 48))
    flipped = v2.RandomHorizontalFlip(1.0)(image, none)[1]
    out = MLSTransform()(image, none)[1]
    assert isinstance(out, tv_tensors.BoundingBoxes)
    assert out.shape == flipped.shape == none.shape
    batch = tv_tensors.Image(torch.zeros(2, 3, 32, 48, dtype=torch.uint8))
    moved = MLSTransform(displacement=0)(batch, _boxes(1)[0], none)
    torch.testing.assert_close(moved[1], _boxes(1)[0], atol=1e-6, rtol=0)
    assert moved[2].shape == none.shape
