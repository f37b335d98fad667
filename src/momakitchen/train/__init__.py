"""Training and evaluation of the learning models.

- :func:`train` ``(config, train_set, val_set, out_dir, resume=False) -> TrainResult``
- :func:`preset_config` ``(preset, model, **overrides) -> TrainConfig`` (``paper``, ``cpu``)
- :func:`load_checkpoint` ``(run_dir, model=None) -> LoadedRun``
- :func:`predict_batch` ``(model, batch) -> (B, Nf) tensor``
- :func:`evaluate` ``(run_dir, dataset) -> dict`` (map metrics, per-robot and per-scene)
"""

from momakitchen.train.checkpoint import LoadedRun, load_checkpoint
from momakitchen.train.config import PRESETS, TrainConfig, preset_config
from momakitchen.train.evaluate import evaluate, predict_batch
from momakitchen.train.trainer import TrainResult, train

__all__ = [
    "PRESETS",
    "LoadedRun",
    "TrainConfig",
    "TrainResult",
    "evaluate",
    "load_checkpoint",
    "predict_batch",
    "preset_config",
    "train",
]
