"""Fixtures of the batch tests."""

from __future__ import annotations

import pytest

from glmls.batch.single import SingleWarper


@pytest.fixture
def no_single(monkeypatch):
    """The single path refused: the batched path must take every image."""

    def refuse(self, *args, **keywords):
        raise AssertionError(f"images[{keywords['index']}] took the single path")

    monkeypatch.setattr(SingleWarper, "warp_one", refuse)
