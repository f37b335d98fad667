"""Models: PointNet++ layers, NavAff, baselines and ablations, one registry.

``build_model(name, ModelConfig(...))`` returns an :class:`AffordanceModel`;
``model(batch)`` gives ``{"pred": (B, Nf)}`` (plus ``loss``/``mse`` when labels are present).
Models defined in other packages plug in by name (:mod:`momakitchen.models.plugins`).
"""

from momakitchen.models.base import AffordanceModel, Backbone, num_parameters
from momakitchen.models.config import ModelConfig
from momakitchen.models.loss import WeightedMSELoss
from momakitchen.models.registry import (
    MODELS,
    ModelEntry,
    build_model,
    get_model_entry,
    model_names,
    register_model,
)

__all__ = [
    "MODELS",
    "AffordanceModel",
    "Backbone",
    "ModelConfig",
    "ModelEntry",
    "WeightedMSELoss",
    "build_model",
    "get_model_entry",
    "model_names",
    "num_parameters",
    "register_model",
]
