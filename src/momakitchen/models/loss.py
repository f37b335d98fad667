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

    def __init__(
        self,
        lambda_zero: float = 0.7,
        prob: float = 0.5,
        zero_eps: float = 1e-6,
        kl_weight: float = 0.0,
    ) -> None:
        super().__init__()
        self.lambda_zero = float(lambda_zero)
        self.prob = float(prob)
        self.zero_eps = float(zero_eps)
        self.kl_weight = float(kl_weight)

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
        if self.kl_weight > 0:
            loss = loss + self.kl_weight * map_kl(pred, label, mask)
        return {"loss": loss, "mse": mse.detach()}


def map_kl(pred: torch.Tensor, label: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean KL divergence of each episode's label map from its predicted map, both
    normalised to sum 1 over the real points (as saliency models are trained); episodes
    whose label is all zero are left out (0 if every one is).

    Shapes:
        - ``pred``, ``label``: (B, N) float; ``mask``: (B, N) bool; output: scalar
    """
    eps = 1e-7
    m = mask.to(pred.dtype)
    g, p = label.clamp_min(0) * m, pred * m
    total = g.sum(1)
    keep = total > 0
    if not bool(keep.any()):
        return pred.sum() * 0.0
    gn, pk = g[keep] / total[keep].unsqueeze(1), p[keep]
    pn = pk / (pk.sum(1, keepdim=True) + eps)
    return (gn * (torch.log(gn + eps) - torch.log(pn + eps))).sum(1).mean()
