"""A PyTorch dataset that augments with glmls, and a script that reads it through a
DataLoader (``python augment_loader.py OUT METHOD WARM PERSISTENT``): the start method
(``default``, ``fork`` or ``spawn``), whether the parent process used glmls's GL before the
workers start, and persistent workers. It saves what the loader gave, in index order, to OUT
(.npz). tests/augment/test_loaders.py runs it in a fresh process per case."""

from __future__ import annotations

import sys

import numpy as np

from glmls.augment import Augment

COUNT = 6


class AugmentedImages:
    """Item i: image i deformed with the draw of index i, its keypoints and boxes."""

    def __init__(self, count: int = COUNT) -> None:
        rng = np.random.default_rng(5)
        self.images = rng.integers(0, 255, (count, 20, 28, 3), dtype=np.uint8)
        self.keypoints = rng.uniform(2, 18, (count, 3, 2))
        self.augment = Augment("text-distort", seed=9)

    def __len__(self) -> int:
        return len(self.images)

    def __getitem__(self, index: int):
        out = self.augment(
            self.images[index : index + 1],
            keypoints=self.keypoints[index : index + 1],
            boxes=[[[3.0, 3.0, 15.0, 12.0]]],
            indices=[index],
        )
        return out.images[0], out.keypoints[0], out.boxes[0], index


def main(path: str, method: str, warm: str, persistent: str) -> None:
    import torch
    from torch.utils.data import DataLoader

    dataset = AugmentedImages()
    if warm == "warm":
        dataset[0]  # the parent makes its GL context before the workers start
    loader = DataLoader(
        dataset,
        batch_size=2,
        num_workers=2,
        multiprocessing_context=None if method == "default" else method,
        persistent_workers=persistent == "persistent",
    )
    epochs = []
    for _ in range(2 if persistent == "persistent" else 1):
        parts = {"images": [], "keypoints": [], "boxes": [], "index": []}
        for images, keypoints, boxes, index in loader:
            for name, value in zip(parts, (images, keypoints, boxes, index), strict=True):
                parts[name].append(value.numpy())
        epochs.append({k: np.concatenate(v) for k, v in parts.items()})
    assert torch.utils.data.get_worker_info() is None
    saved = {f"{k}{e}": v for e, epoch in enumerate(epochs) for k, v in epoch.items()}
    np.savez(path, **saved)


if __name__ == "__main__":
    main(*sys.argv[1:])
