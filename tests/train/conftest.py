import pytest
import torch

from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
from momakitchen.models.config import TINY_MODEL
from momakitchen.train import TrainConfig

torch.set_num_threads(1)


def tiny_train_config(**changes) -> TrainConfig:
    base = TrainConfig(
        model="navaff",
        preset="custom",
        model_config=TINY_MODEL,
        num_global=256,
        num_floor=128,
        epochs=2,
        batch_size=4,
        progress=False,
        log_every=1,
    )
    return base.replace(**changes)


@pytest.fixture(scope="session")
def make_config():
    """A factory of tiny training configs (keyword arguments change fields); stateless, so
    module-scoped fixtures can use it too."""
    return tiny_train_config


@pytest.fixture(scope="session")
def tiny_sets():
    train = SyntheticEpisodes(SyntheticConfig(num_episodes=8, num_global=256, num_floor=128))
    val = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=256, num_floor=128, seed=9))
    return train, val
