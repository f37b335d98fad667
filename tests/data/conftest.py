"""Fixtures of the dataset tests."""

from __future__ import annotations

from pathlib import Path

import pytest
from dataset_helpers import make_dataset


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Five synthetic scenes (4 train, 1 test), 2 configurations x 3 episodes each."""
    root = tmp_path_factory.mktemp("ds") / "small"
    make_dataset(root, card=True)
    return root
