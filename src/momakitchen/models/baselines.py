"""Baselines adapted to per-floor-point affordance: PointNet++, VoteNet- and H3DNet-style.

All three read the union of the global and the floor cloud (features: position, colour,
the alignment channel, an is-floor flag) and predict a value for each floor point. Their
heads are conditioned on the robot descriptor (concatenated per point), so a gap to NavAff
measures the architecture, not missing inputs.

- ``PointNet2Backbone``: PointNet++ segmentation (3 multi-scale set abstractions, feature
  propagation back to the floor points).
- ``VoteNetBackbone``: PointNet++ backbone to seeds, VoteNet's voting module (per-seed
  offsets in position and feature) and vote aggregation into proposals; the detection heads
  are removed and proposal features are propagated to the floor points.
- ``H3DNetBackbone``: as VoteNet, with H3DNet's hierarchy of geometric primitives: separate
  voting modules for object centres, face centres and edge centres; each centre proposal
  aggregates the face and edge primitives around it (H3DNet's refinement step); the box
  heads are removed.
"""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from momakitchen.models.base import Backbone, context_floor
from momakitchen.models.config import ModelConfig
from momakitchen.models.pointnet2 import (
    FeaturePropagation,
    Plan,
    PointMLP,
    PointNet2Encoder,
    SetAbstractionMSG,
    ball_query,
    fourier_channels,
    fourier_features,
    gather_points,
    interpolation_geometry,
    masked_max,
)


def union_channels(pos_freqs: int) -> int:
    return fourier_channels(pos_freqs) + 3 + 1 + 1  # encoded xyz, rgb, alignment, is-floor


def union_cloud(
    batch: dict[str, Any], pos_freqs: int
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The global and the (context) floor clouds as one cloud with per-point features.

    Shapes:
        - output: xyz (B, Ng+Nc, 3), feats (B, Ng+Nc, ``union_channels``), mask
          (B, Ng+Nc) bool
    """
    gxyz, cxyz = batch["global_xyz"], context_floor(batch)[0]
    b, nc = cxyz.shape[:2]
    ng = gxyz.shape[1]
    gfeat = torch.cat(
        [
            fourier_features(gxyz, pos_freqs),
            batch["global_rgb"],
            batch["global_align"].unsqueeze(-1),
            gxyz.new_zeros(b, ng, 1),
        ],
        -1,
    )
    cfeat = torch.cat(
        [fourier_features(cxyz, pos_freqs), cxyz.new_zeros(b, nc, 4), cxyz.new_ones(b, nc, 1)], -1
    )
    xyz, mask = union_xyz(batch)
    return xyz, torch.cat([gfeat, cfeat], 1), mask


def union_xyz(batch: dict[str, Any]) -> tuple[torch.Tensor, torch.Tensor]:
    """Positions (B, Ng+Nc, 3) and mask (B, Ng+Nc) of :func:`union_cloud`."""
    cxyz, cmask = context_floor(batch)
    xyz = torch.cat([batch["global_xyz"], cxyz], 1)
    return xyz, torch.cat([batch["global_mask"], cmask], 1)


def union_encoder(cfg: ModelConfig) -> PointNet2Encoder:
    """The baselines' PointNet++ encoder over :func:`union_cloud` (its plan: that of
    :func:`union_xyz`)."""
    return PointNet2Encoder(
        union_channels(cfg.pos_freqs), (*cfg.global_npoints, cfg.num_tokens), cfg.ch, cfg.ns
    )


class PointNet2Backbone(Backbone):
    """PointNet++ segmentation over the union cloud, read out on the floor points.

    Shapes:
        - input: a batch; output: (B, Nf, ``out_channels``)
    """

    def __init__(self, cfg: ModelConfig) -> None:
        super().__init__()
        ch = cfg.ch
        self.encoder = union_encoder(cfg)
        e = self.encoder
        self.fp3 = FeaturePropagation(e.sa2.out_channels + e.sa3.out_channels, [ch(256), ch(256)])
        self.fp2 = FeaturePropagation(e.sa1.out_channels + ch(256), [ch(256), ch(128)])
        self.pos_freqs = cfg.pos_freqs
        self.fp1 = FeaturePropagation(fourier_channels(cfg.pos_freqs) + ch(128), [ch(128), ch(128)])
        self.out_channels = ch(128)

    def plan(self, batch: dict[str, Any]) -> Plan:
        """The encoder's set abstractions and the three propagations (``fp3``..``fp1``)."""
        plan = self.encoder.plan(*union_xyz(batch))
        (p1, p2, p3), fxyz = (plan[k] for k in ("sa1", "sa2", "sa3")), batch["floor_xyz"]
        plan["fp3"] = interpolation_geometry(p2["xyz"], p3["xyz"], p3["mask"])
        plan["fp2"] = interpolation_geometry(p1["xyz"], p2["xyz"], p2["mask"])
        plan["fp1"] = interpolation_geometry(fxyz, p1["xyz"], p1["mask"])
        return plan

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        plan = self.batch_plan(batch)
        xyz, feats, mask = union_cloud(batch, self.pos_freqs)
        (x1, f1, m1), (x2, f2, m2), (x3, f3, m3) = self.encoder(xyz, feats, mask, plan)
        u2 = self.fp3(x2, x3, f2, f3, m3, plan["fp3"])
        u1 = self.fp2(x1, x2, f1, u2, m2, plan["fp2"])
        fxyz = batch["floor_xyz"]
        fpos = fourier_features(fxyz, self.pos_freqs)
        return self.fp1(fxyz, x1, fpos, u1, m1, plan["fp1"])


class VotingModule(nn.Module):
    """VoteNet voting: each seed votes an offset in position and in feature space.

    Shapes:
        - input: ``xyz`` (B, S, 3), ``feats`` (B, S, C)
        - output: vote xyz (B, S, 3), vote feats (B, S, C)
    """

    def __init__(self, channels: int) -> None:
        super().__init__()
        self.mlp = PointMLP(channels, [channels, channels])
        self.offset = nn.Linear(channels, 3 + channels)

    def forward(self, xyz: torch.Tensor, feats: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        out = self.offset(self.mlp(feats))
        vote_xyz = xyz + out[..., :3]
        vote_feats = feats + out[..., 3:]
        vote_feats = vote_feats / vote_feats.norm(dim=-1, keepdim=True).clamp_min(1e-6)
        return vote_xyz, vote_feats


class _SeedNet(nn.Module):
    """PointNet++ to seeds (VoteNet: SA1-SA3, FP back to the SA2 points)."""

    def __init__(self, cfg: ModelConfig) -> None:
        super().__init__()
        ch = cfg.ch
        self.encoder = union_encoder(cfg)
        e = self.encoder
        self.fp = FeaturePropagation(e.sa2.out_channels + e.sa3.out_channels, [ch(256), ch(256)])
        self.out_channels = ch(256)
        self.pos_freqs = cfg.pos_freqs

    def plan(self, batch: dict[str, Any]) -> Plan:
        """The encoder's set abstractions, the propagation to the seeds (``fp``) and the
        seeds' propagation to the floor points (``floor``)."""
        plan = self.encoder.plan(*union_xyz(batch))
        p2, p3 = plan["sa2"], plan["sa3"]
        plan["fp"] = interpolation_geometry(p2["xyz"], p3["xyz"], p3["mask"])
        plan["floor"] = interpolation_geometry(batch["floor_xyz"], p2["xyz"], p2["mask"])
        return plan

    def forward(self, batch, plan: Plan):
        xyz, feats, mask = union_cloud(batch, self.pos_freqs)
        l1, (x2, f2, m2), (x3, f3, m3) = self.encoder(xyz, feats, mask, plan)
        return l1, x2, self.fp(x2, x3, f2, f3, m3, plan["fp"]), m2


class VoteNetBackbone(Backbone):
    """VoteNet-style: seeds, votes, vote aggregation; proposals propagated to the floor.

    Shapes:
        - input: a batch; output: (B, Nf, ``out_channels``)
    """

    def __init__(self, cfg: ModelConfig) -> None:
        super().__init__()
        ch, ns = cfg.ch, cfg.ns
        self.seeds = _SeedNet(cfg)
        c = self.seeds.out_channels
        self.vote = VotingModule(c)
        self.aggregate = SetAbstractionMSG(
            cfg.num_tokens, (0.3,), (ns(16),), c, [[ch(128), ch(128), ch(128)]]
        )
        self.proposal = PointMLP(ch(128), [ch(128), ch(128)])
        self.fp_seed = FeaturePropagation(fourier_channels(cfg.pos_freqs) + c, [ch(128), ch(128)])
        self.fp_prop = FeaturePropagation(ch(128) + ch(128), [ch(128), ch(128)])
        self.out_channels = ch(128)

    def plan(self, batch: dict[str, Any]) -> Plan:
        """The seed network's geometry (votes move with the weights: aggregated in the
        forward pass)."""
        return self.seeds.plan(batch)

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        plan = self.batch_plan(batch)
        _, sxyz, sfeat, smask = self.seeds(batch, plan)
        vxyz, vfeat = self.vote(sxyz, sfeat)
        pxyz, pfeat, pmask = self.aggregate(vxyz, vfeat, smask)
        pfeat = self.proposal(pfeat)
        fxyz = batch["floor_xyz"]
        fpos = fourier_features(fxyz, self.seeds.pos_freqs)
        x = self.fp_seed(fxyz, sxyz, fpos, sfeat, smask, plan["floor"])
        return self.fp_prop(fxyz, pxyz, x, pfeat, pmask)


class H3DNetBackbone(Backbone):
    """H3DNet-style: centre, face and edge primitives voted from seeds; centre proposals
    refined by the primitives around them; propagated to the floor.

    Shapes:
        - input: a batch; output: (B, Nf, ``out_channels``)
    """

    def __init__(self, cfg: ModelConfig) -> None:
        super().__init__()
        ch, ns = cfg.ch, cfg.ns
        self.seeds = _SeedNet(cfg)
        c = self.seeds.out_channels
        t = cfg.num_tokens
        self.kinds = ("center", "face", "edge")
        self.votes = nn.ModuleDict({k: VotingModule(c) for k in self.kinds})
        self.aggregate = nn.ModuleDict(
            {
                k: SetAbstractionMSG(
                    t if k == "center" else max(t // 2, 4),
                    (0.3,),
                    (ns(16),),
                    c,
                    [[ch(128), ch(128), ch(128)]],
                )
                for k in self.kinds
            }
        )
        self.primitive_radius = 0.6
        self.primitive_k = ns(16)
        self.refine_group = PointMLP(3 + ch(128) + 2, [ch(128), ch(128)], norm=False)
        self.refine = PointMLP(2 * ch(128), [ch(128), ch(128)])
        self.fp_seed = FeaturePropagation(fourier_channels(cfg.pos_freqs) + c, [ch(128), ch(128)])
        self.fp_prop = FeaturePropagation(ch(128) + ch(128), [ch(128), ch(128)])
        self.out_channels = ch(128)

    def plan(self, batch: dict[str, Any]) -> Plan:
        """The seed network's geometry (primitives move with the weights)."""
        return self.seeds.plan(batch)

    def forward(self, batch: dict[str, Any]) -> torch.Tensor:
        plan = self.batch_plan(batch)
        _, sxyz, sfeat, smask = self.seeds(batch, plan)
        prims = {}
        for k in self.kinds:
            vxyz, vfeat = self.votes[k](sxyz, sfeat)
            prims[k] = self.aggregate[k](vxyz, vfeat, smask)
        cxyz, cfeat, cmask = prims["center"]
        # Face and edge primitives as one set, with a one-hot primitive type.
        onehots = []
        for i, k in enumerate(("face", "edge")):
            f = prims[k][1]
            oh = f.new_zeros(*f.shape[:2], 2)
            oh[..., i] = 1.0
            onehots.append(torch.cat([f, oh], -1))
        qxyz = torch.cat([prims["face"][0], prims["edge"][0]], 1)
        qfeat = torch.cat(onehots, 1)
        qmask = torch.cat([prims["face"][2], prims["edge"][2]], 1)
        ((gidx, gmask),) = ball_query(self.primitive_radius, self.primitive_k, qxyz, qmask, cxyz)
        rel = (gather_points(qxyz, gidx) - cxyz.unsqueeze(2)) / self.primitive_radius
        grouped = self.refine_group(torch.cat([rel, gather_points(qfeat, gidx)], -1))
        ctx = masked_max(grouped, gmask & cmask.unsqueeze(-1), dim=2)
        pfeat = self.refine(torch.cat([cfeat, ctx], -1))
        fxyz = batch["floor_xyz"]
        fpos = fourier_features(fxyz, self.seeds.pos_freqs)
        x = self.fp_seed(fxyz, sxyz, fpos, sfeat, smask, plan["floor"])
        return self.fp_prop(fxyz, cxyz, x, pfeat, cmask)
