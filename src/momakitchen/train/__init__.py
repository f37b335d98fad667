"""Training the learning models: configs, the training loop, checkpoints.

- :func:`train` ``(config, train_set, val_set, out_dir, resume=False) -> TrainResult``
- :func:`preset_config` ``(preset, model, **overrides) -> TrainConfig`` (``paper``, ``cpu``)
- :func:`load_checkpoint` ``(run_dir, model=None) -> LoadedRun``

Evaluation of a trained run is :func:`momakitchen.eval.evaluate.evaluate`.
"""

from momakitchen.train.checkpoint import LoadedRun, load_checkpoint
from momakitchen.train.config import PRESETS, TrainConfig, preset_config
from momakitchen.train.trainer import TrainResult, train

__all__ = [
    "PRESETS",
    "LoadedRun",
    "TrainConfig",
    "TrainResult",
    "load_checkpoint",
    "preset_config",
    "train",
]
