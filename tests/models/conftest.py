import pytest
import torch

from momakitchen.models import ModelConfig
from momakitchen.models.config import TINY_MODEL

torch.set_num_threads(1)


@pytest.fixture
def tiny_config() -> ModelConfig:
    """A very small model so that every registered model runs in well under a second."""
    return TINY_MODEL
