"""Deployment: inference on a real robot's RGB-D frame (no simulator is loaded)."""

from momakitchen.deploy.predict import predict
from momakitchen.models.inference import Prediction
from momakitchen.train.checkpoint import default_checkpoint

__all__ = ["Prediction", "default_checkpoint", "predict"]
