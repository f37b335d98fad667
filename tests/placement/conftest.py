"""Fixtures of the placement tests: one real generated view, its inputs, and a coarse
reachability sampling that keeps the default suite fast."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from placement_helpers import COARSE

from momakitchen.sim.sampling import SamplingConfig


@pytest.fixture(scope="session")
def episodes(real_view: Path) -> list[Any]:
    """The view's episodes (each with depth, masks, camera pose, robot and labels)."""
    from momakitchen.data.shard import SceneShard

    with SceneShard(real_view / "scenes" / "scene_000003.h5") as shard:
        return [shard.episode(0, i) for i in shard.episode_indices(0)]


@pytest.fixture
def coarse_maps(monkeypatch: pytest.MonkeyPatch) -> SamplingConfig:
    """``place`` samples reachability coarsely (:data:`COARSE`) while the test runs."""
    from momakitchen.sim import reachability

    monkeypatch.setattr(reachability, "DEFAULT_SAMPLING", COARSE)
    return COARSE
