"""The batch and augmentation contract at its edges: label shapes that the adapters' libraries
take and glmls's own reading of them."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.augment import Augment


def test_torchvision_batch_keypoints_of_more_leading_dimensions_follow_their_samples(gl):
    """tv_tensors.KeyPoints are [..., 2]: a batch's (N, A, B, 2) keypoints (A skeletons of B
    points per sample) move with their samples as the same points laid out (N, A * B, 2)."""
    torch = pytest.importorskip("torch", reason="torch not installed (the torch extra)")
    tv_tensors = pytest.importorskip("torchvision.tv_tensors", reason="torchvision not installed")
    from glmls.augment.torchvision import MLSTransform

    height, width = 24, 40
    images = tv_tensors.Image(torch.zeros(3, 1, height, width, dtype=torch.uint8))
    points = torch.from_numpy(np.random.default_rng(4).uniform(2, 20, (3, 2, 5, 2)))
    nested = tv_tensors.KeyPoints(points, canvas_size=(height, width))
    flat = tv_tensors.KeyPoints(points.reshape(3, 10, 2), canvas_size=(height, width))
    transform = MLSTransform("grid", displacement=0.1)
    torch.manual_seed(2)
    _, moved_nested = transform(images, nested)
    torch.manual_seed(2)
    _, moved_flat = transform(images, flat)
    assert isinstance(moved_nested, tv_tensors.KeyPoints)
    assert tuple(moved_nested.shape) == (3, 2, 5, 2)
    assert torch.equal(moved_nested.reshape(3, 10, 2), moved_flat.as_subclass(torch.Tensor))
    assert (moved_nested != nested).any()  # the points moved, each sample by its own draw


def test_replay_of_draws_with_different_warp_options_names_the_draw_and_the_option(gl):
    """Draws made with different warp options (two Augments' params joined) are one batch
    each: a replay of them together names the first draw that differs, and how."""
    images = np.zeros((3, 16, 24), np.uint8)
    first = Augment("grid", seed=1)(images[:2]).params
    second = Augment("grid", seed=1, warp_options={"interpolation": "nearest"})(images[:1]).params
    with pytest.raises(ValueError, match=r"params\[2\]\['options'\] differ from .*interpolation"):
        Augment("grid").replay(images, [*first, *second])
