import pytest
import torch

from momakitchen.models import ModelConfig
from momakitchen.models.config import TINY_MODEL

torch.set_num_threads(1)


@pytest.fixture
def tiny_config() -> ModelConfig:
    """A very small model so that every registered model runs in well under a second."""
    return TINY_MODEL


@pytest.fixture(autouse=True)
def _coarse_reachability(monkeypatch: pytest.MonkeyPatch) -> None:
    """Models that read the robot's reachability sample it coarsely (seconds a robot)."""
    from momakitchen.sim import reachability
    from momakitchen.sim.sampling import SamplingConfig

    coarse = SamplingConfig(cell=0.1, psi_bins=8, fk_samples=5000)
    monkeypatch.setattr(reachability, "DEFAULT_SAMPLING", coarse)
