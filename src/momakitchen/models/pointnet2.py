"""PointNet++ layers with padding masks: sampling, grouping, set abstraction, propagation.

The geometry-only steps (farthest point sampling, ball query, three-nearest-neighbour
interpolation weights) are vectorised torch code over the batch and all points; farthest
point sampling loops over the *sampled* centroids only. They run without gradients.

Padding: every function takes a boolean mask of real points. Padded points are never
chosen as centroids (unless a cloud has fewer real points than centroids requested; then
real points are repeated and the extra centroids are flagged invalid), never grouped and
never used as interpolation sources. Per-point layers use LayerNorm (not BatchNorm), so a
padded entry cannot change the statistics seen by a real one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

_BIG = 1e10


def fourier_features(xyz: torch.Tensor, num_freqs: int) -> torch.Tensor:
    """Positions with sine/cosine encodings at wavelengths 4 m, 2 m, 1 m, ... (halving).

    Spatial functions such as "about 0.6 m from the target" are far easier to fit from
    these than from raw coordinates.

    Shapes:
        - ``xyz``: (..., 3); output: (..., 3 + 6 * num_freqs)
    """
    if num_freqs == 0:
        return xyz
    freqs = (math.pi / 2) * 2.0 ** torch.arange(num_freqs, dtype=xyz.dtype, device=xyz.device)
    angles = (xyz.unsqueeze(-1) * freqs).flatten(-2)
    return torch.cat([xyz, torch.sin(angles), torch.cos(angles)], -1)


def fourier_channels(num_freqs: int) -> int:
    return 3 + 6 * num_freqs


def gather_points(values: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """Gather rows of ``values`` along the point axis.

    Shapes:
        - ``values``: (B, N, C) or (B, N)
        - ``idx``: (B, ...) long indices into N
        - output: (B, ..., C) or (B, ...)
    """
    b = values.shape[0]
    flat = idx.reshape(b, -1)
    if values.dim() == 2:
        return torch.gather(values, 1, flat).reshape(idx.shape)
    c = values.shape[-1]
    out = torch.gather(values, 1, flat.unsqueeze(-1).expand(-1, -1, c))
    return out.reshape(*idx.shape, c)


def square_distance(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Pairwise squared Euclidean distances (one batched matrix product).

    Shapes:
        - ``a``: (B, N, 3), ``b``: (B, M, 3); output: (B, N, M), clamped at 0
    """
    aa = (a * a).sum(-1, keepdim=True)
    bb = (b * b).sum(-1).unsqueeze(1)
    return torch.baddbmm(aa + bb, a, b.transpose(1, 2), alpha=-2.0).clamp_min_(0.0)


@torch.no_grad()
def farthest_point_sample(
    xyz: torch.Tensor, mask: torch.Tensor, npoint: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Farthest point sampling over real points, starting from each cloud's first real point.

    NumPy, vectorised over the batch and all points; the loop runs over the ``npoint``
    centroids only. Padded points keep distance -1 and are never the farthest; once a cloud
    has no unsampled real point left, real points repeat.

    Shapes:
        - ``xyz``: (B, N, 3); ``mask``: (B, N) bool
        - output: ``idx`` (B, npoint) long, ``valid`` (B, npoint) bool. ``valid[b, j]`` is
          ``j < number of real points in cloud b``; invalid centroids repeat real points.
    """
    b, n, _ = xyz.shape
    pts = xyz.detach().to("cpu", torch.float32).numpy()
    m = mask.detach().cpu().numpy()
    coords = [np.ascontiguousarray(pts[..., i]) for i in range(3)]
    dist = np.where(m, np.float32(np.inf), np.float32(-1.0)).astype(np.float32)
    acc = np.empty((b, n), np.float32)
    tmp = np.empty((b, n), np.float32)
    rows = np.arange(b)
    far = m.argmax(axis=1)  # first real point
    idx = np.empty((b, npoint), np.int64)
    for j in range(npoint):
        idx[:, j] = far
        for i, c in enumerate(coords):
            out = acc if i == 0 else tmp
            np.subtract(c, c[rows, far][:, None], out=out)
            np.multiply(out, out, out=out)
            if i:
                acc += tmp
        np.minimum(dist, acc, out=dist)  # padding stays at -1
        far = dist.argmax(axis=1)
    count = m.sum(1, keepdims=True)
    valid = np.arange(npoint)[None, :] < count
    return (
        torch.from_numpy(idx).to(xyz.device),
        torch.from_numpy(valid).to(xyz.device),
    )


@torch.no_grad()
def ball_query(
    radius: float | Sequence[float],
    nsample: int | Sequence[int],
    xyz: torch.Tensor,
    mask: torch.Tensor,
    centers: torch.Tensor,
) -> list[tuple[torch.Tensor, torch.Tensor]]:
    """The ``nsample`` nearest real points within ``radius`` of each centre, for one or
    several (radius, nsample) scales sharing one distance computation and one top-k.

    Shapes:
        - ``xyz``: (B, N, 3); ``mask``: (B, N) bool; ``centers``: (B, M, 3)
        - output: per scale, ``idx`` (B, M, K) long and ``group_mask`` (B, M, K) bool,
          K = min(nsample, N). Slots without a neighbour point at the nearest real point
          and are masked out.
    """
    radii = [radius] if isinstance(radius, (int, float)) else list(radius)
    counts = [nsample] if isinstance(nsample, int) else list(nsample)
    kmax = min(max(counts), xyz.shape[1])
    d2 = square_distance(centers, xyz)
    d2.masked_fill_(~mask.unsqueeze(1), _BIG)
    near_d, near_i = torch.topk(d2, kmax, dim=-1, largest=False, sorted=True)
    out = []
    for r, k in zip(radii, counts, strict=True):
        k = min(k, kmax)
        gmask = near_d[..., :k] <= r * r
        idx = torch.where(gmask, near_i[..., :k], near_i[..., :1])
        out.append((idx, gmask))
    return out


@torch.no_grad()
def three_nn_weights(
    dst: torch.Tensor, src: torch.Tensor, src_mask: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Inverse-distance weights of the three nearest real source points.

    Shapes:
        - ``dst``: (B, N, 3); ``src``: (B, M, 3); ``src_mask``: (B, M) bool
        - output: ``idx`` (B, N, k) long, ``weight`` (B, N, k) float summing to 1 over k,
          k = min(3, M); padded sources get weight 0.
    """
    k = min(3, src.shape[1])
    d2 = square_distance(dst, src)
    d2.masked_fill_(~src_mask.unsqueeze(1), _BIG)
    dk, idx = torch.topk(d2, k, dim=-1, largest=False, sorted=True)
    w = 1.0 / (dk + 1e-8)
    w = torch.where(dk < _BIG / 2, w, torch.zeros_like(w))
    w = w / w.sum(-1, keepdim=True).clamp_min(1e-12)
    return idx, w


class PointMLP(nn.Sequential):
    """Shared per-point MLP on channel-last tensors: (Linear, [LayerNorm], ReLU) per layer.

    Shapes:
        - input: (..., C_in); output: (..., widths[-1])
    """

    def __init__(
        self, in_channels: int, widths: Sequence[int], last_act: bool = True, norm: bool = True
    ) -> None:
        layers: list[nn.Module] = []
        c = in_channels
        for i, w in enumerate(widths):
            layers.append(nn.Linear(c, w))
            if last_act or i < len(widths) - 1:
                if norm:
                    layers.append(nn.LayerNorm(w))
                layers.append(nn.ReLU(inplace=True))
            c = w
        super().__init__(*layers)
        self.out_channels = c


def masked_max(x: torch.Tensor, mask: torch.Tensor, dim: int) -> torch.Tensor:
    """Max over ``dim`` ignoring masked-out entries (all masked: zeros).

    Shapes:
        - ``x``: (..., K, C) with ``dim`` pointing at K; ``mask``: x.shape without C, bool
    """
    filled = x.masked_fill(~mask.unsqueeze(-1), float("-inf"))
    out = filled.amax(dim=dim)
    return torch.where(torch.isfinite(out), out, torch.zeros_like(out))


class SetAbstractionMSG(nn.Module):
    """PointNet++ set abstraction with multi-scale grouping.

    Args:
        npoint: centroids sampled by FPS.
        radii, nsamples: one ball radius and neighbour count per scale.
        in_channels: per-point feature channels (0: xyz only).
        mlps: per-scale MLP widths; relative xyz (3 channels) is prepended to the features.

    Shapes:
        - input: ``xyz`` (B, N, 3), ``feats`` (B, N, C) or None, ``mask`` (B, N) bool
        - output: ``new_xyz`` (B, npoint, 3), ``new_feats`` (B, npoint, sum of last
          widths), ``new_mask`` (B, npoint) bool
    """

    def __init__(
        self,
        npoint: int,
        radii: Sequence[float],
        nsamples: Sequence[int],
        in_channels: int,
        mlps: Sequence[Sequence[int]],
    ) -> None:
        super().__init__()
        if not len(radii) == len(nsamples) == len(mlps):
            raise ValueError("radii, nsamples and mlps need one entry per scale")
        self.npoint = npoint
        self.radii = tuple(radii)
        self.nsamples = tuple(nsamples)
        # Grouped MLPs run on (B, M, K, C): no per-entry norm there (it dominated the cost);
        # a LayerNorm after pooling keeps the scales in check.
        self.mlps = nn.ModuleList(PointMLP(in_channels + 3, w, norm=False) for w in mlps)
        self.norms = nn.ModuleList(nn.LayerNorm(m.out_channels) for m in self.mlps)
        self.out_channels = sum(m.out_channels for m in self.mlps)

    def forward(
        self, xyz: torch.Tensor, feats: torch.Tensor | None, mask: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        idx, new_mask = farthest_point_sample(xyz, mask, self.npoint)
        new_xyz = gather_points(xyz, idx)
        outs = []
        groups = ball_query(self.radii, self.nsamples, xyz, mask, new_xyz)
        for radius, (gidx, gmask), mlp, norm in zip(
            self.radii, groups, self.mlps, self.norms, strict=True
        ):
            rel = (gather_points(xyz, gidx) - new_xyz.unsqueeze(2)) / radius
            grouped = rel if feats is None else torch.cat([rel, gather_points(feats, gidx)], -1)
            gmask = gmask & new_mask.unsqueeze(-1)
            outs.append(norm(masked_max(mlp(grouped), gmask, dim=2)))
        return new_xyz, torch.cat(outs, -1), new_mask


class SetAbstractionAll(nn.Module):
    """Group-all set abstraction: one global feature per cloud (masked max pooling).

    Shapes:
        - input: ``xyz`` (B, N, 3), ``feats`` (B, N, C), ``mask`` (B, N)
        - output: (B, widths[-1])
    """

    def __init__(self, in_channels: int, widths: Sequence[int]) -> None:
        super().__init__()
        self.mlp = PointMLP(in_channels + 3, widths)
        self.out_channels = self.mlp.out_channels

    def forward(self, xyz: torch.Tensor, feats: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        return masked_max(self.mlp(torch.cat([xyz, feats], -1)), mask, dim=1)


class FeaturePropagation(nn.Module):
    """PointNet++ feature propagation: 3-NN inverse-distance interpolation + skip + MLP.

    Shapes:
        - input: ``dst_xyz`` (B, N, 3), ``src_xyz`` (B, M, 3), ``dst_feats`` (B, N, C1) or
          None, ``src_feats`` (B, M, C2), ``src_mask`` (B, M) bool
        - output: (B, N, widths[-1])
    """

    def __init__(self, in_channels: int, widths: Sequence[int]) -> None:
        super().__init__()
        self.mlp = PointMLP(in_channels, widths)
        self.out_channels = self.mlp.out_channels

    def forward(
        self,
        dst_xyz: torch.Tensor,
        src_xyz: torch.Tensor,
        dst_feats: torch.Tensor | None,
        src_feats: torch.Tensor,
        src_mask: torch.Tensor,
    ) -> torch.Tensor:
        idx, w = three_nn_weights(dst_xyz, src_xyz, src_mask)
        interp = (gather_points(src_feats, idx) * w.unsqueeze(-1)).sum(2)
        x = interp if dst_feats is None else torch.cat([dst_feats, interp], -1)
        return self.mlp(x)
