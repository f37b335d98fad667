import pytest
import torch

from momakitchen.models import ModelConfig

torch.set_num_threads(1)


@pytest.fixture
def tiny_config() -> ModelConfig:
    """A very small model so that every registered model runs in well under a second."""
    return ModelConfig(
        embed_dim=32,
        num_tokens=8,
        num_heads=4,
        num_robot_tokens=2,
        dropout=0.1,
        width=0.125,
        global_npoints=(64, 32),
        floor_npoints=32,
        nsample_scale=0.25,
    )
