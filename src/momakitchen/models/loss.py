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
        peak_weight: float = 0.0,
        peak_temperature: float = 0.1,
    ) -> None:
        super().__init__()
        self.lambda_zero = float(lambda_zero)
        self.prob = float(prob)
        self.zero_eps = float(zero_eps)
        self.kl_weight = float(kl_weight)
        self.peak_weight = float(peak_weight)
        self.peak_temperature = float(peak_temperature)

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
        if self.peak_weight > 0:
            loss = loss + self.peak_weight * peak_kl(pred, label, mask, self.peak_temperature)
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


def peak_kl(
    pred: torch.Tensor, label: torch.Tensor, mask: torch.Tensor, temperature: float = 0.1
) -> torch.Tensor:
    """Mean KL divergence of softmax(label / T) from softmax(pred / T) over each episode's
    real points (a listwise ranking loss, ListNet's top-one form); episodes whose label is
    all zero are left out (0 if every one is).

    With T well below the label range the target puts nearly all its mass on the map's
    best points, so the term rewards ranking those first: the point a robot is sent to
    is the argmax, which the MSE and the linear KL (:func:`map_kl`) weigh like any other.
    Zero when ``pred`` equals ``label``, like the other terms.

    Shapes:
        - ``pred``, ``label``: (B, N) float; ``mask``: (B, N) bool; output: scalar
    """
    keep = ((label > 0) & mask).any(1)
    if not bool(keep.any()):
        return pred.sum() * 0.0
    m = mask[keep]
    neg = torch.finfo(pred.dtype).min
    logq = torch.log_softmax((label[keep] / temperature).masked_fill(~m, neg), 1)
    logp = torch.log_softmax((pred[keep] / temperature).masked_fill(~m, neg), 1)
    return (logq.exp() * (logq - logp)).masked_fill(~m, 0.0).sum(1).mean()
