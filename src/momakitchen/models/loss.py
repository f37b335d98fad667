"""Weighted MSE on affordance maps (docs/DESIGN.md §3.6)."""

from __future__ import annotations

import torch
from torch import nn


class WeightedMSELoss(nn.Module):
    """Masked MSE whose zero-valued labels are weighted by ``lambda_zero`` on some steps.

    In training mode, with probability ``prob`` per call (one draw per batch from the
    global torch RNG), points whose label is 0 get weight ``lambda_zero`` instead of 1. In
    eval mode the loss is the plain masked MSE, so validation curves are deterministic.
    The mean runs over real points only (padding never counts).

    Shapes:
        - ``pred``, ``label``: (B, N) float; ``mask``: (B, N) bool
        - output: dict with ``loss`` (scalar, the optimised value) and ``mse`` (scalar,
          unweighted), both tensors
    """

    def __init__(self, lambda_zero: float = 0.7, prob: float = 0.5, zero_eps: float = 1e-6) -> None:
        super().__init__()
        self.lambda_zero = float(lambda_zero)
        self.prob = float(prob)
        self.zero_eps = float(zero_eps)

    def forward(
        self, pred: torch.Tensor, label: torch.Tensor, mask: torch.Tensor
    ) -> dict[str, torch.Tensor]:
        m = mask.to(pred.dtype)
        count = m.sum().clamp_min(1.0)
        sq = (pred - label).square() * m
        mse = sq.sum() / count
        if self.training and self.prob > 0 and float(torch.rand(())) < self.prob:
            w = torch.where(label.abs() <= self.zero_eps, self.lambda_zero, 1.0)
            loss = (sq * w).sum() / count
        else:
            loss = mse
        return {"loss": loss, "mse": mse.detach()}
