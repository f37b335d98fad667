"""Deployment: inference on a real robot's RGB-D frame and the end-to-end demo."""

from momakitchen.deploy.predict import Prediction, default_checkpoint, predict

__all__ = ["Prediction", "default_checkpoint", "predict"]
