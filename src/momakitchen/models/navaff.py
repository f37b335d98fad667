"""NavAff: navigation affordance from a first-person cloud, a floor cloud and the robot.

Visual alignment: the global cloud carries a per-point channel (+1 target, -1 obstacle,
0 else) next to colour and position. PointNet++ encoders turn the global and the floor
cloud into ``num_tokens`` tokens each (MLP tokenizers plus a positional MLP of the token
centroid); the robot descriptor becomes ``num_robot_tokens`` tokens. Floor tokens query
[global tokens, robot tokens] with multi-head cross-attention; feature propagation brings
the attended floor tokens back to every floor point; a head gives a sigmoid per point.

Visual alignment also anchors the floor to the target: the centroid of the target's points
(alignment channel +1) gives every floor point its offset to the target as an input
feature, next to its own position. Affordance is mostly a function of that offset (reach,
approach side) and of what stands in between, so the floor branch no longer has to
discover where the target is through attention alone.

With ``target_points`` > 0, each first-level floor centroid also encodes the target's
sampled points in its own frame (a PointNet over the offsets, max-pooled): the target's
shape as seen from there, e.g. on which side of a door its hinge is and how far its
swing reaches, which the centroid alone does not say.

With ``reach_input``, every floor point also reads the robot's reachability of the target
from there (:mod:`momakitchen.models.reach_input`): what the arm on this base, at this
mount, can do from that point, computed from its URDF, where the descriptor's few numbers
do not carry from one body to another.

Ablations switch parts off: ``use_robot`` (robot tokens), ``use_alignment`` (the alignment
channel and the target-relative floor features), ``use_global`` (the global cloud).
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
    farthest_point_sample,
    fourier_channels,
    fourier_features,
    gather_points,
    interpolation_geometry,
    masked_max,
)
from momakitchen.models.reach_input import (
    REACH_CHANNELS,
    batch_floor_reach,
    reach_targets,
    target_centroid,
)
from momakitchen.robots.spec import DESCRIPTOR_DIM


def floor_features(fxyz: torch.Tensor, target: torch.Tensor | None, pos_freqs: int) -> torch.Tensor:
    """Encoded floor positions, plus the encoded offset to the target and its horizontal
    distance when ``target`` is given.

    Shapes:
        - ``fxyz``: (B, Nf, 3), ``target``: (B, 3) or None
        - output: (B, Nf, ``floor_channels(pos_freqs, target is not None)``)
    """
    parts = [fourier_features(fxyz, pos_freqs)]
    if target is not None:
        rel = fxyz - target.unsqueeze(1)
        parts += [fourier_features(rel, pos_freqs), rel[..., :2].norm(dim=-1, keepdim=True)]
    return torch.cat(parts, -1)


def floor_channels(pos_freqs: int, relative: bool) -> int:
    return fourier_channels(pos_freqs) * (2 if relative else 1) + (1 if relative else 0)


def sample_target(
    xyz: torch.Tensor, align: torch.Tensor, mask: torch.Tensor, k: int
) -> dict[str, torch.Tensor]:
    """``k`` target points (alignment +1) by farthest point sampling: their indices into
    the global cloud and which are real (a cloud with fewer than ``k`` target points
    repeats them; one with none has no real point).

    Shapes:
        - input: ``xyz`` (B, N, 3), ``align`` (B, N), ``mask`` (B, N) bool
        - output: ``idx`` (B, k) long, ``mask`` (B, k) bool
    """
    target = (align > 0.5) & mask
    has = target.any(1, keepdim=True)
    # Without a target point, sample any slot (never used: the mask says none is real).
    idx, valid = farthest_point_sample(xyz, target | ~has, k)
    return {"idx": idx, "mask": valid & has}


class TargetSetEncoder(nn.Module):
    """PointNet over the target's points in each query point's frame: an MLP of the offset
    from the query to every target point (in units of ``radius``), max-pooled over the
    target, then layer-normalised.

    The first layer is linear in the offset, so it runs once per target point and once per
    query, and the pairs only add the two (as in :class:`GroupedMLP`).

    Shapes:
        - input: ``target`` (B, K, 3), ``target_mask`` (B, K) bool, ``query`` (B, M, 3)
        - output: (B, M, widths[-1]); zeros for a cloud without target points
    """

    def __init__(self, widths: list[int], radius: float = 1.0) -> None:
        super().__init__()
        self.radius = radius
        self.first = nn.Linear(3, widths[0])
        self.rest = PointMLP(widths[0], widths[1:], norm=False)
        self.norm = nn.LayerNorm(widths[-1])
        self.out_channels = widths[-1]

    def forward(
        self, target: torch.Tensor, target_mask: torch.Tensor, query: torch.Tensor
    ) -> torch.Tensor:
        w = self.first.weight / self.radius
        per_target = target @ w.t() + self.first.bias  # (B, K, C0)
        per_query = query @ w.t()  # (B, M, C0)
        h = self.rest(torch.relu(per_target.unsqueeze(1) - per_query.unsqueeze(2)))
        b, m, k = h.shape[:3]
        pooled = masked_max(h, target_mask.unsqueeze(1).expand(b, m, k), dim=2)
        return self.norm(pooled) * target_mask.any(1).to(h.dtype)[:, None, None]


class Tokenizer(nn.Module):
    """Centroid features and positions to tokens.

    Shapes:
        - input: ``feats`` (B, T, C), ``xyz`` (B, T, 3); output: (B, T, E)
    """

    def __init__(self, in_channels: int, dim: int, pos_freqs: int) -> None:
        super().__init__()
        self.pos_freqs = pos_freqs
        self.feat = PointMLP(in_channels, [dim, dim], last_act=False)
        self.pos = PointMLP(fourier_channels(pos_freqs), [dim // 2, dim], last_act=False)

    def forward(self, feats: torch.Tensor, xyz: torch.Tensor) -> torch.Tensor:
        return self.feat(feats) + self.pos(fourier_features(xyz, self.pos_freqs))


class CrossAttentionBlock(nn.Module):
    """Pre-norm multi-head cross-attention + feed-forward, with key padding masks.

    Shapes:
        - input: ``query`` (B, Tq, E), ``kv`` (B, Tk, E), ``kv_pad`` (B, Tk) bool (True =
          padding, ignored)
        - output: (B, Tq, E)
    """

    def __init__(self, dim: int, heads: int, dropout: float) -> None:
        super().__init__()
        self.norm_q = nn.LayerNorm(dim)
        self.norm_kv = nn.LayerNorm(dim)
        self.attn = nn.MultiheadAttention(dim, heads, dropout=dropout, batch_first=True)
        self.norm_ff = nn.LayerNorm(dim)
        self.ff = nn.Sequential(
            nn.Linear(dim, 2 * dim), nn.GELU(), nn.Dropout(dropout), nn.Linear(2 * dim, dim)
        )
        self.drop = nn.Dropout(dropout)

    def forward(self, query: torch.Tensor, kv: torch.Tensor, kv_pad: torch.Tensor) -> torch.Tensor:
        kvn = self.norm_kv(kv)
        a, _ = self.attn(self.norm_q(query), kvn, kvn, key_padding_mask=kv_pad, need_weights=False)
        query = query + self.drop(a)
        return query + self.drop(self.ff(self.norm_ff(query)))


class GlobalEncoder(PointNet2Encoder):
    """PointNet++ (3 multi-scale set abstractions) over the global cloud, and its last
    level's centroids to tokens (:meth:`tokens`).

    Shapes:
        - input: ``xyz`` (B, Ng, 3), ``feats`` (B, Ng, C), ``mask`` (B, Ng)
        - output: as :class:`PointNet2Encoder` (calling it); of :meth:`tokens`: tokens
          (B, T, E), token xyz (B, T, 3), token mask (B, T) bool
    """

    def __init__(self, cfg: ModelConfig, in_channels: int) -> None:
        super().__init__(in_channels, (*cfg.global_npoints, cfg.num_tokens), cfg.ch, cfg.ns)
        self.tokenizer = Tokenizer(self.sa3.out_channels, cfg.embed_dim, cfg.pos_freqs)

    def tokens(
        self, xyz: torch.Tensor, feats: torch.Tensor, mask: torch.Tensor, plan: Plan
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """The last level as tokens, with its centroids and mask."""
        _, _, (x3, f3, m3) = self(xyz, feats, mask, plan)
        return self.tokenizer(f3, x3), x3, m3


class RobotTokenizer(nn.Module):
    """Robot descriptor to ``R`` tokens.

    Shapes:
        - input: (B, D); output: (B, R, E)
    """

    def __init__(self, dim: int, num_tokens: int, descriptor_dim: int = DESCRIPTOR_DIM) -> None:
        super().__init__()
        self.num_tokens = num_tokens
        self.descriptor_dim = descriptor_dim
        self.mlp = nn.Sequential(
            nn.Linear(descriptor_dim, dim), nn.ReLU(inplace=True), nn.Linear(dim, dim * num_tokens)
        )
        self.embed = nn.Parameter(torch.randn(num_tokens, dim) * 0.02)

    def forward(self, robot: torch.Tensor) -> torch.Tensor:
        b = robot.shape[0]
        return self.mlp(robot[:, : self.descriptor_dim]).view(b, self.num_tokens, -1) + self.embed


class NavAffBackbone(Backbone):
    """NavAff up to per-floor-point features (the head adds the sigmoid).

    Shapes:
        - input: batch with ``global_*`` (B, Ng, ...), ``floor_xyz`` (B, Nf, 3),
          ``floor_mask`` (B, Nf), ``robot`` (B, D)
        - output: (B, Nf, ``out_channels``)
    """

    def __init__(
        self,
        cfg: ModelConfig,
        use_robot: bool = True,
        use_alignment: bool = True,
        use_global: bool = True,
    ) -> None:
        super().__init__()
        if not (use_robot or use_global):
            raise ValueError("NavAff needs the global cloud or the robot tokens as keys")
        self.use_robot = use_robot
        self.use_alignment = use_alignment
        self.use_global = use_global
        ch, ns, dim = cfg.ch, cfg.ns, cfg.embed_dim
        if use_global:
            # encoded xyz, rgb, alignment
            in_ch = fourier_channels(cfg.pos_freqs) + 3 + (1 if use_alignment else 0)
            self.global_encoder = GlobalEncoder(cfg, in_ch)
        if use_robot:
            self.robot_tokenizer = RobotTokenizer(dim, cfg.num_robot_tokens, cfg.descriptor_dim)
        self.pos_freqs = cfg.pos_freqs
        self.relative = use_global and use_alignment
        self.relative_dropout = cfg.relative_dropout
        # The reachability is of the target: it needs the alignment channel to find it.
        self.reach_input = cfg.reach_input and self.relative
        self.reach_points = cfg.reach_points
        pos_ch = floor_channels(cfg.pos_freqs, self.relative)
        # Where the reachability channels start in the floor features (the last ones).
        self.reach_offset = pos_ch
        pos_ch += REACH_CHANNELS if self.reach_input else 0
        self.floor_sa1 = SetAbstractionMSG(
            cfg.floor_npoints,
            (0.1, 0.2),
            (ns(16), ns(32)),
            pos_ch,
            [[ch(32), ch(32), ch(64)], [ch(64), ch(64), ch(128)]],
        )
        # The target set needs the alignment channel to know which points are the target.
        self.target_points = cfg.target_points if self.relative else 0
        f1_ch = self.floor_sa1.out_channels
        if self.target_points:
            self.target_encoder = TargetSetEncoder([ch(64), ch(128)])
            f1_ch += self.target_encoder.out_channels
        self.floor_sa2 = SetAbstractionMSG(
            cfg.num_tokens,
            (0.2, 0.4),
            (ns(16), ns(32)),
            f1_ch,
            [[ch(128), ch(128), ch(256)], [ch(128), ch(128), ch(256)]],
        )
        self.floor_tokenizer = Tokenizer(self.floor_sa2.out_channels, dim, cfg.pos_freqs)
        self.blocks = nn.ModuleList(
            CrossAttentionBlock(dim, cfg.num_heads, cfg.dropout)
            for _ in range(cfg.attention_layers)
        )
        self.fp2 = FeaturePropagation(f1_ch + dim, [ch(256), ch(256)])
        self.fp1 = FeaturePropagation(pos_ch + self.fp2.out_channels, [ch(128), ch(128)])
        self.out_channels = self.fp1.out_channels

    def widen_for_reach(self, state: dict[str, torch.Tensor], prefix: str) -> None:
        """``state`` (weights of this backbone without ``reach_input``, keys under
        ``prefix``) given zero input columns for the reachability channels, in place: the
        widened model predicts what the original did until training gives them a use."""
        if not self.reach_input:
            return
        own = dict(self.named_parameters())
        at = {"fp1.mlp.0.weight": self.reach_offset}
        for i in range(len(self.floor_sa1.mlps)):  # after the 3 relative xyz columns
            at[f"floor_sa1.mlps.{i}.first.weight"] = 3 + self.reach_offset
        for name, col in at.items():
            w = state.get(prefix + name)
            if w is not None and w.ndim == 2 and w.shape[1] == own[name].shape[1] - REACH_CHANNELS:
                pad = w.new_zeros(w.shape[0], REACH_CHANNELS)
                state[prefix + name] = torch.cat([w[:, :col], pad, w[:, col:]], dim=1)

    def plan(self, batch: dict[str, Any]) -> Plan:
        """Global encoder (``global.sa1``..``global.sa3``), floor set abstractions
        (``floor.sa1``, ``floor.sa2``), feature propagation (``fp2``, ``fp1``) and, with
        ``target_points``, the sampled target (``target``)."""
        plan: Plan = {}
        if self.use_global:
            for k, v in self.global_encoder.plan(batch["global_xyz"], batch["global_mask"]).items():
                plan[f"global.{k}"] = v
        if self.target_points:
            plan["target"] = sample_target(
                batch["global_xyz"], batch["global_align"], batch["global_mask"], self.target_points
            )
        f1 = plan["floor.sa1"] = self.floor_sa1.sample_and_group(*context_floor(batch))
        f2 = plan["floor.sa2"] = self.floor_sa2.sample_and_group(f1["xyz"], f1["mask"])
        plan["fp2"] = interpolation_geometry(f1["xyz"], f2["xyz"], f2["mask"])
        plan["fp1"] = interpolation_geometry(batch["floor_xyz"], f1["xyz"], f1["mask"])
        return plan

    def encode(self, batch: dict[str, Any]) -> dict[str, torch.Tensor]:
        """Everything before the cross-attention (no dropout): keys, floor tokens and the
        floor hierarchy that feature propagation needs."""
        plan = self.batch_plan(batch)
        fxyz = batch["floor_xyz"]
        cxyz, cmask = context_floor(batch)
        b = fxyz.shape[0]
        keys, pads = [], []
        if self.use_global:
            parts = [fourier_features(batch["global_xyz"], self.pos_freqs), batch["global_rgb"]]
            if self.use_alignment:
                parts.append(batch["global_align"].unsqueeze(-1))
            gplan = {k: plan[f"global.{k}"] for k in ("sa1", "sa2", "sa3")}
            gtok, _, gm = self.global_encoder.tokens(
                batch["global_xyz"], torch.cat(parts, -1), batch["global_mask"], gplan
            )
            keys.append(gtok)
            pads.append(~gm)
        if self.use_robot:
            rtok = self.robot_tokenizer(batch["robot"])
            keys.append(rtok)
            pads.append(torch.zeros(b, rtok.shape[1], dtype=torch.bool, device=fxyz.device))
        kv, kv_pad = torch.cat(keys, 1), torch.cat(pads, 1)

        target = None
        if self.relative:
            target = target_centroid(
                batch["global_xyz"], batch["global_align"], batch["global_mask"]
            )
        fpos = floor_features(fxyz, target, self.pos_freqs)
        cpos = fpos if cxyz is fxyz else floor_features(cxyz, target, self.pos_freqs)
        if self.relative and self.training and self.relative_dropout > 0:
            # Hide the target offset from some episodes (one draw each, global RNG).
            keep = torch.rand(b, 1, 1, device=fxyz.device) >= self.relative_dropout
            absolute = fourier_channels(self.pos_freqs)
            fpos, cpos = (
                torch.cat([p[..., :absolute], p[..., absolute:] * keep.to(p.dtype)], -1)
                for p in (fpos, cpos)
            )
        if self.reach_input:  # never hidden: it shows no obstacle, the global cloud must
            assert target is not None
            names = batch.get("robot_name", [])
            mount = batch.get("robot_mount", batch["robot"][:, 1])
            at = reach_targets(batch, target, self.reach_points)
            reach = batch_floor_reach(names, mount, at, fxyz)
            creach = reach if cxyz is fxyz else batch_floor_reach(names, mount, at, cxyz)
            fpos, cpos = torch.cat([fpos, reach], -1), torch.cat([cpos, creach], -1)
        x1, f1, m1 = self.floor_sa1(cxyz, cpos, cmask, plan["floor.sa1"])
        if self.target_points:
            tgt = plan["target"]
            txyz = gather_points(batch["global_xyz"], tgt["idx"])
            seen = self.target_encoder(txyz, tgt["mask"], x1) * m1.unsqueeze(-1).to(f1.dtype)
            f1 = torch.cat([f1, seen], -1)
        x2, f2, m2 = self.floor_sa2(x1, f1, m1, plan["floor.sa2"])
        nn2, nn1 = plan["fp2"], plan["fp1"]
        return {
            "q": self.floor_tokenizer(f2, x2),
            "kv": kv,
            "kv_pad": kv_pad,
            "fxyz": fxyz,
            "fpos": fpos,
            "x1": x1,
            "f1": f1,
            "m1": m1,
            "x2": x2,
            "m2": m2,
            "nn2_idx": nn2["idx"],
            "nn2_w": nn2["weight"],
            "nn1_idx": nn1["idx"],
            "nn1_w": nn1["weight"],
        }

    def decode(self, ctx: dict[str, torch.Tensor]) -> torch.Tensor:
        """Cross-attention (where the dropout is) and feature propagation."""
        q = ctx["q"]
        for block in self.blocks:
            q = block(q, ctx["kv"], ctx["kv_pad"])
        nn2 = {"idx": ctx["nn2_idx"], "weight": ctx["nn2_w"]}
        nn1 = {"idx": ctx["nn1_idx"], "weight": ctx["nn1_w"]}
        up1 = self.fp2(ctx["x1"], ctx["x2"], ctx["f1"], q, ctx["m2"], nn2)
        return self.fp1(ctx["fxyz"], ctx["x1"], ctx["fpos"], up1, ctx["m1"], nn1)
