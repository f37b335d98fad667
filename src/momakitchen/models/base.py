"""Model = backbone + head + loss, returning dicts (the layout every model here follows)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import torch
from torch import nn

from momakitchen.models.config import ModelConfig
from momakitchen.models.loss import WeightedMSELoss
from momakitchen.models.pointnet2 import Plan, PointMLP
from momakitchen.models.reach_input import footprint_gate, reach_gate
from momakitchen.robots.spec import DESCRIPTOR_DIM

# Initial value of every prediction (a typical mean label is a few per cent).
PRIOR = 0.05


PLAN_KEY = "plan"


def context_floor(batch: dict[str, Any]) -> tuple[torch.Tensor, torch.Tensor]:
    """The floor points a backbone encodes: the batch's floor context when it carries one
    (inference: the training density, see :mod:`momakitchen.data.batch`), else the floor
    points themselves. Features are then interpolated to every point of ``floor_xyz``.

    Shapes:
        - output: xyz (B, Nc, 3), mask (B, Nc) bool
    """
    if "context_xyz" in batch:
        return batch["context_xyz"], batch["context_mask"]
    return batch["floor_xyz"], batch["floor_mask"]


class Backbone(nn.Module):
    """Maps a batch to per-floor-point features.

    Shapes:
        - input: a batch (see :mod:`momakitchen.data.batch`)
        - output: (B, Nf, ``out_channels``)
    """

    out_channels: int

    def plan(self, batch: dict[str, Any]) -> Plan:
        """The geometry of the batch that does not depend on the weights: every layer's
        centroids (FPS), neighbourhoods and interpolation weights that can be found from
        the input positions alone. A batch may carry it under ``"plan"`` (computed ahead,
        e.g. in a DataLoader worker, by a backbone of the same configuration); the forward
        pass then skips that work and gives the same result. Default: nothing."""
        return {}

    def batch_plan(self, batch: dict[str, Any]) -> Plan:
        """The batch's own plan if it carries one, else :meth:`plan`."""
        plan = batch.get(PLAN_KEY)
        return plan if plan is not None else self.plan(batch)

    def encode(self, batch: dict[str, Any]) -> dict[str, torch.Tensor]:
        """The deterministic part (no dropout), run once for MC-dropout sampling: a dict of
        tensors with the batch on dim 0. Default: the whole backbone, which is right for
        backbones without dropout (a test checks the registered ones)."""
        if type(self).forward is Backbone.forward:
            raise NotImplementedError(f"{type(self).__name__} defines neither forward nor encode")
        return {"feats": self.forward(batch)}

    def decode(self, ctx: dict[str, torch.Tensor]) -> torch.Tensor:
        """The rest of the backbone, from :meth:`encode`'s output. Shapes: (B, Nf, C)."""
        return ctx["feats"]

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        return self.decode(self.encode(batch))


class AffordanceHead(nn.Module):
    """Per-point MLP to one value in [0, 1], optionally conditioned on the robot descriptor.

    Shapes:
        - input: ``feats`` (B, Nf, C), ``robot`` (B, D)
        - output: (B, Nf) in [0, 1]
    """

    def __init__(
        self,
        in_channels: int,
        hidden: int,
        use_robot: bool,
        dropout: float,
        descriptor_dim: int = DESCRIPTOR_DIM,
    ) -> None:
        super().__init__()
        self.use_robot = use_robot
        self.descriptor_dim = descriptor_dim
        robot_ch = 0
        if use_robot:
            robot_ch = max(8, hidden // 4)
            self.robot_mlp = PointMLP(descriptor_dim, [robot_ch, robot_ch])
        self.mlp = PointMLP(in_channels + robot_ch, [hidden])
        self.drop = nn.Dropout(dropout)
        self.out = nn.Linear(hidden, 1)
        # Start from a flat map at a small prior (as detection heads do for rare classes):
        # affordance maps are mostly zero, and from 0.5 the first epoch is spent lowering
        # the mean, driving the sigmoid into saturation where per-point detail stops
        # getting a gradient.
        nn.init.zeros_(self.out.weight)
        nn.init.constant_(self.out.bias, math.log(PRIOR / (1.0 - PRIOR)))

    def forward(self, feats: torch.Tensor, robot: torch.Tensor) -> torch.Tensor:
        if self.use_robot:
            r = self.robot_mlp(robot[:, : self.descriptor_dim])
            r = r.unsqueeze(1).expand(-1, feats.shape[1], -1)
            feats = torch.cat([feats, r], -1)
        return torch.sigmoid(self.out(self.drop(self.mlp(feats))).squeeze(-1))


class AffordanceModel(nn.Module):
    """A registered model: ``backbone`` → ``head`` → ``criterion``.

    ``model(batch)`` returns ``{"pred": (B, Nf)}`` with values in [0, 1]; when the batch
    carries ``floor_label`` the dict also holds ``loss`` and ``mse`` from the criterion.
    Predictions on padded floor points are set to 0.
    """

    def __init__(
        self, name: str, config: ModelConfig, backbone: Backbone, head_uses_robot: bool
    ) -> None:
        super().__init__()
        self.name = name
        self.config = config
        self.backbone = backbone
        hidden = max(16, backbone.out_channels)
        self.head = AffordanceHead(
            backbone.out_channels,
            hidden,
            head_uses_robot,
            config.dropout,
            config.descriptor_dim,
        )
        self.criterion = WeightedMSELoss(
            config.lambda_zero,
            config.zero_weight_prob,
            kl_weight=config.kl_weight,
            peak_weight=config.peak_weight,
            peak_temperature=config.peak_temperature,
        )
        # The last batch's gates, by the objects they were computed from: inference runs
        # a batch once plainly and once for its MC-dropout spread, and the gates (KD-trees,
        # reachability lookups) need not run twice.
        self._gates: tuple[tuple[Any, ...], torch.Tensor] | None = None

    def visible(self, batch: dict[str, Any]) -> dict[str, Any]:
        """``batch`` with the descriptor columns the model does not read
        (``ModelConfig.hidden_descriptor``) zeroed; itself when it reads them all. The
        mount height stays known as ``robot_mount`` (B,): the reachability input is the
        arm's at its mount."""
        keep = self.config.descriptor_keep
        if all(keep):
            return batch
        robot = batch["robot"]
        mask = torch.ones(robot.shape[-1], dtype=robot.dtype, device=robot.device)
        mask[: len(keep)] = torch.tensor(keep, dtype=robot.dtype)
        return {**batch, "robot": robot * mask, "robot_mount": robot[:, 1]}

    def forward(self, batch: dict[str, Any]) -> dict[str, torch.Tensor]:
        batch = self.visible(batch)
        feats = self.backbone(batch)
        pred = self.head(feats, batch["robot"]) * self._keep(batch, feats.dtype)
        out = {"pred": pred}
        if "floor_label" in batch:
            out.update(self.criterion(pred, batch["floor_label"], batch["floor_mask"]))
        return out

    @torch.no_grad()
    def sample_predictions(self, batch: dict[str, Any], samples: int) -> torch.Tensor:
        """``samples`` predictions of one episode with dropout active (MC dropout). The
        deterministic part of the backbone runs once, the rest on ``samples`` copies. Uses
        the global torch RNG. Shapes: a batch of one episode -> (samples, Nf)."""
        if batch["floor_xyz"].shape[0] != 1:
            raise ValueError("sample_predictions takes a batch of one episode")
        was_training = self.training
        batch = self.visible(batch)
        try:
            self.eval()
            ctx = self.backbone.encode(batch)
            self.train()
            copies = {k: v.expand(samples, *v.shape[1:]).contiguous() for k, v in ctx.items()}
            feats = self.backbone.decode(copies)
            robot = batch["robot"].expand(samples, -1)
            return self.head(feats, robot) * self._keep(batch, feats.dtype)
        finally:
            self.train(was_training)

    def _keep(self, batch: dict[str, Any], dtype: torch.dtype) -> torch.Tensor:
        """What of each prediction stands: 0 on padded floor points, else 1 or, with
        ``ModelConfig.reach_gate`` and ``ModelConfig.index_gate``, the robot's
        reachability gates, and with ``ModelConfig.footprint_gate``, where its base
        fits. Shapes: (B, Nf)."""
        keep = batch["floor_mask"].to(dtype)
        cfg = self.config
        if cfg.reach_gate <= 0 and cfg.index_gate <= 0 and not cfg.footprint_gate:
            return keep
        key = (batch, *(batch.get(k) for k in _GATE_INPUTS))
        if self._gates is None or any(a is not b for a, b in zip(self._gates[0], key, strict=True)):
            gate = torch.ones_like(keep)
            if cfg.reach_gate > 0 or cfg.index_gate > 0:
                gate = gate * reach_gate(
                    batch, cfg.reach_gate, cfg.reach_points, cfg.index_gate, cfg.index_picks_only
                )
            if cfg.footprint_gate:
                gate = gate * footprint_gate(batch)
            self._gates = (key, gate)
        return keep * self._gates[1].to(dtype)


# What a batch's gates are computed from (AffordanceModel._keep).
_GATE_INPUTS = (
    "floor_xyz",
    "global_xyz",
    "global_align",
    "robot",
    "robot_name",
    "obstacle_xyz",
    "target_opens",
)


def num_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())


class PlanningCollator:
    """Collates a batch and adds the model's geometry plan (:meth:`Backbone.plan`).

    In DataLoader workers this takes farthest point sampling and the neighbour searches
    off the training thread; the forward pass gives the same result with or without it.
    The plan depends on the point positions and the model's sizes only, never on the
    weights, so a worker's copy of the backbone serves as well as the trained one.
    """

    def __init__(
        self, collate: Callable[[Sequence[Any]], dict[str, Any]], backbone: Backbone
    ) -> None:
        self.collate = collate
        self.backbone = backbone

    def __call__(self, samples: Sequence[Any]) -> dict[str, Any]:
        batch = self.collate(samples)
        batch[PLAN_KEY] = self.backbone.plan(batch)
        return batch
