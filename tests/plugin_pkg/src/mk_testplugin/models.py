"""Plug-in models: the batch contract in, per-floor-point affordance out."""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from momakitchen.models import Backbone, ModelConfig
from momakitchen.robots.spec import DESCRIPTOR_DIM


def _inputs(batch: dict[str, Any]) -> torch.Tensor:
    """Per floor point: its offset from the target's centroid, its distance, the robot.
    Shapes: (B, Nf, 3 + 1 + D)."""
    target = (batch["global_align"] > 0) & batch["global_mask"]
    w = target.float().unsqueeze(-1)
    centroid = (batch["global_xyz"] * w).sum(1) / w.sum(1).clamp(min=1.0)  # (B, 3)
    offset = batch["floor_xyz"] - centroid.unsqueeze(1)  # (B, Nf, 3)
    dist = offset[..., :2].norm(dim=-1, keepdim=True)
    robot = batch["robot"].unsqueeze(1).expand(-1, offset.shape[1], -1)
    return torch.cat([offset, dist, robot], -1)


class TinyAffordance(nn.Module):
    """Tiny per-point MLP on the offset to the target and the robot."""

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        hidden = max(8, round(64 * config.width))
        self.mlp = nn.Sequential(
            nn.Linear(4 + DESCRIPTOR_DIM, hidden),
            nn.ReLU(),
            nn.Dropout(config.dropout),
            nn.Linear(hidden, 1),
        )

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        return torch.sigmoid(self.mlp(_inputs(batch)).squeeze(-1))  # (B, Nf)


class TinyBackbone(Backbone):
    """Per-point features; the package adds its own head."""

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.out_channels = 16
        self.mlp = nn.Sequential(nn.Linear(4 + DESCRIPTOR_DIM, 16), nn.ReLU())

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        return self.mlp(_inputs(batch))  # (B, Nf, 16)


class BadShape(TinyAffordance):
    """Does not follow the interface: one value per episode."""

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        return super().forward(batch).mean(1)  # (B,)
