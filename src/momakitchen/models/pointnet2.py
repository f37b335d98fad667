"""PointNet++ layers with padding masks: sampling, grouping, set abstraction, propagation.

The geometry-only steps run without gradients and without Python loops over points:
farthest point sampling is NumPy vectorised over all points (looping over the *sampled*
centroids only); ball query and three-nearest-neighbour interpolation use a k-d tree per
cloud (scipy) on CPU and a masked top-k over the distance matrix on other devices.

Padding: every function takes a boolean mask of real points. Padded points are never
chosen as centroids (unless a cloud has fewer real points than centroids requested; then
real points are repeated and the extra centroids are flagged invalid), never grouped and
never used as interpolation sources. Per-point layers use LayerNorm (not BatchNorm), so a
padded entry cannot change the statistics seen by a real one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import torch
from scipy.spatial import cKDTree
from torch import nn

_BIG = 1e10

# Precomputed geometry of a layer (see SetAbstractionMSG.sample_and_group): tensors by name.
Geometry = dict[str, torch.Tensor]
# The geometry of a batch, by layer (see Backbone.plan).
Plan = dict[str, Geometry]
# One level of a set-abstraction stack: centroid xyz, their features and mask.
Level = tuple[torch.Tensor, torch.Tensor, torch.Tensor]


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
    b, n = values.shape[:2]
    # Rows of the flattened (B*N, C) tensor: index_select copies whole rows, ~10x faster
    # on CPU than torch.gather with an expanded index (the same values).
    flat = idx.reshape(b, -1)
    if b > 1:
        flat = flat + torch.arange(b, device=idx.device).unsqueeze(1) * n
    rows = values.reshape(b * n, -1).index_select(0, flat.reshape(-1))
    return rows.reshape(idx.shape) if values.dim() == 2 else rows.reshape(*idx.shape, -1)


def square_distance(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Pairwise squared Euclidean distances (one batched matrix product).

    Shapes:
        - ``a``: (B, N, 3), ``b``: (B, M, 3); output: (B, N, M), clamped at 0
    """
    aa = (a * a).sum(-1, keepdim=True)
    bb = (b * b).sum(-1).unsqueeze(1)
    return torch.baddbmm(aa + bb, a, b.transpose(1, 2), alpha=-2.0).clamp_min_(0.0)


def _fps_cloud(points: np.ndarray, npoint: int) -> np.ndarray:
    """FPS on one cloud of real points (n, 3), starting at index 0; indices into it."""
    n = points.shape[0]
    q = np.ascontiguousarray(points.T)
    dist = np.full(n, np.inf, np.float32)
    d3 = np.empty((3, n), np.float32)
    acc = np.empty(n, np.float32)
    out = np.empty(npoint, np.int64)
    far = 0
    for j in range(npoint):
        out[j] = far
        np.subtract(q, q[:, far : far + 1], out=d3)
        np.multiply(d3, d3, out=d3)
        np.add(d3[0], d3[1], out=acc)
        acc += d3[2]
        np.minimum(dist, acc, out=dist)
        far = int(dist.argmax())
    return out


def _fps_batched(pts: np.ndarray, m: np.ndarray, npoint: int) -> np.ndarray:
    """FPS vectorised over a batch (B, N, 3) with masks (B, N); padding keeps distance -1."""
    b, n, _ = pts.shape
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
    return idx


@torch.no_grad()
def farthest_point_sample(
    xyz: torch.Tensor, mask: torch.Tensor, npoint: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Farthest point sampling over real points, starting from each cloud's first real point.

    NumPy, vectorised over all points (and over the batch for batches of more than two
    clouds); the loop runs over the ``npoint`` centroids only. Padded points are never
    chosen; once a cloud has no unsampled real point left, real points repeat.

    Shapes:
        - ``xyz``: (B, N, 3); ``mask``: (B, N) bool
        - output: ``idx`` (B, npoint) long, ``valid`` (B, npoint) bool. ``valid[b, j]`` is
          ``j < number of real points in cloud b``; invalid centroids repeat real points.
    """
    b = xyz.shape[0]
    pts = xyz.detach().to("cpu", torch.float32).numpy()
    m = mask.detach().cpu().numpy()
    if b <= 2:  # per cloud on its real points: fastest for single episodes
        idx = np.empty((b, npoint), np.int64)
        for i in range(b):
            real = np.flatnonzero(m[i])
            idx[i] = real[_fps_cloud(pts[i, real], npoint)]
    else:
        idx = _fps_batched(pts, m, npoint)
    valid = np.arange(npoint)[None, :] < m.sum(1, keepdims=True)
    return torch.from_numpy(idx).to(xyz.device), torch.from_numpy(valid).to(xyz.device)


def _knn(
    points: torch.Tensor, mask: torch.Tensor, queries: torch.Tensor, k: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """The k nearest real points of each query: squared distances and indices, sorted.

    On CPU a k-d tree per cloud (scipy, built on the real points only); elsewhere a
    masked top-k over the full distance matrix.

    Shapes:
        - ``points``: (B, N, 3), ``mask``: (B, N), ``queries``: (B, M, 3)
        - output: (B, M, k) float distances squared (1e10 where fewer than k real points),
          (B, M, k) long indices into N
    """
    b, m = queries.shape[:2]
    if points.device.type != "cpu":
        d2 = square_distance(queries, points)
        d2.masked_fill_(~mask.unsqueeze(1), _BIG)
        return torch.topk(d2, k, dim=-1, largest=False, sorted=True)
    pts = points.detach().to(torch.float32).numpy()
    qs = queries.detach().to(torch.float32).numpy()
    msk = mask.numpy()
    dist = np.full((b, m, k), _BIG, np.float32)
    idx = np.zeros((b, m, k), np.int64)
    for i in range(b):
        real = np.flatnonzero(msk[i])
        if real.size == 0:
            continue
        kk = min(k, real.size)
        d, j = cKDTree(pts[i, real]).query(qs[i], k=kk)
        d, j = d.reshape(m, kk), j.reshape(m, kk)
        dist[i, :, :kk] = d * d
        idx[i, :, :kk] = real[j]
        idx[i, :, kk:] = real[j[:, :1]]
    return torch.from_numpy(dist), torch.from_numpy(idx)


@torch.no_grad()
def ball_query(
    radius: float | Sequence[float],
    nsample: int | Sequence[int],
    xyz: torch.Tensor,
    mask: torch.Tensor,
    centers: torch.Tensor,
) -> list[tuple[torch.Tensor, torch.Tensor]]:
    """The ``nsample`` nearest real points within ``radius`` of each centre, for one or
    several (radius, nsample) scales sharing one nearest-neighbour search.

    Shapes:
        - ``xyz``: (B, N, 3); ``mask``: (B, N) bool; ``centers``: (B, M, 3)
        - output: per scale, ``idx`` (B, M, K) long and ``group_mask`` (B, M, K) bool,
          K = min(nsample, N). Slots without a neighbour point at the nearest real point
          and are masked out.
    """
    radii = [radius] if isinstance(radius, (int, float)) else list(radius)
    counts = [nsample] if isinstance(nsample, int) else list(nsample)
    kmax = min(max(counts), xyz.shape[1])
    near_d, near_i = _knn(xyz, mask, centers, kmax)
    near_d, near_i = near_d.to(xyz.device), near_i.to(xyz.device)
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
    dk, idx = _knn(src, src_mask, dst, k)
    dk, idx = dk.to(dst.device), idx.to(dst.device)
    w = 1.0 / (dk + 1e-8)
    w = torch.where(dk < _BIG / 2, w, torch.zeros_like(w))
    w = w / w.sum(-1, keepdim=True).clamp_min(1e-12)
    return idx, w


def interpolation_geometry(
    dst: torch.Tensor, src: torch.Tensor, src_mask: torch.Tensor
) -> Geometry:
    """:func:`three_nn_weights` as a :data:`Geometry` (``idx``, ``weight``) for
    :class:`FeaturePropagation`."""
    idx, weight = three_nn_weights(dst, src, src_mask)
    return {"idx": idx, "weight": weight}


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
                layers.append(nn.ReLU())
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


class GroupedMLP(nn.Module):
    """Shared MLP over neighbourhoods: relative position (scaled by the radius) + features.

    The first layer is linear in ``[(p_j - c) / r, f_j]``, so it is applied once per point
    and once per centre, and only its (narrow) output is gathered per neighbourhood: the
    same function as gathering ``[rel, f]`` first, at a fraction of the cost. Every layer
    ends in ReLU, so outputs are non-negative.

    Shapes:
        - input: ``xyz`` (B, N, 3), ``feats`` (B, N, C) or None, ``centers`` (B, M, 3),
          ``idx`` (B, M, K) long, ``radius`` float
        - output: (B, M, K, widths[-1])
    """

    def __init__(self, in_channels: int, widths: Sequence[int]) -> None:
        super().__init__()
        self.first = nn.Linear(in_channels + 3, widths[0])
        self.rest = PointMLP(widths[0], widths[1:], norm=False) if len(widths) > 1 else None
        self.out_channels = widths[-1]

    def forward(
        self,
        xyz: torch.Tensor,
        feats: torch.Tensor | None,
        centers: torch.Tensor,
        idx: torch.Tensor,
        radius: float,
    ) -> torch.Tensor:
        w = self.first.weight
        w_rel = w[:, :3] / radius
        per_point = torch.addmm(self.first.bias, xyz.reshape(-1, 3), w_rel.t())
        per_point = per_point.view(*xyz.shape[:2], -1)
        if feats is not None:
            per_point = per_point + feats @ w[:, 3:].t()
        per_center = centers @ w_rel.t()
        h = torch.relu(gather_points(per_point, idx) - per_center.unsqueeze(2))
        return self.rest(h) if self.rest is not None else h


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
        grouped = [GroupedMLP(in_channels, w) for w in mlps]
        self.mlps = nn.ModuleList(grouped)
        self.norms = nn.ModuleList(nn.LayerNorm(m.out_channels) for m in grouped)
        self.out_channels = sum(m.out_channels for m in grouped)

    @torch.no_grad()
    def sample_and_group(self, xyz: torch.Tensor, mask: torch.Tensor) -> Geometry:
        """The geometry-only part: centroids (FPS) and their neighbourhoods per scale.

        Shapes:
            - input: ``xyz`` (B, N, 3), ``mask`` (B, N) bool
            - output: ``xyz`` (B, npoint, 3), ``mask`` (B, npoint) bool and ``group<s>``
              (B, npoint, K_s) long indices into N, one per scale
        """
        idx, new_mask = farthest_point_sample(xyz, mask, self.npoint)
        new_xyz = gather_points(xyz, idx)
        groups = ball_query(self.radii, self.nsamples, xyz, mask, new_xyz)
        out = {"xyz": new_xyz, "mask": new_mask}
        out.update({f"group{s}": gidx for s, (gidx, _) in enumerate(groups)})
        return out

    def forward(
        self,
        xyz: torch.Tensor,
        feats: torch.Tensor | None,
        mask: torch.Tensor,
        geometry: Geometry | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``geometry``: :meth:`sample_and_group` of (xyz, mask) when already known (the
        geometry of the input clouds is found once per batch, off the training thread)."""
        if geometry is None:
            geometry = self.sample_and_group(xyz, mask)
        new_xyz, new_mask = geometry["xyz"], geometry["mask"]
        outs = []
        for s, (radius, mlp, norm) in enumerate(
            zip(self.radii, self.mlps, self.norms, strict=True)
        ):
            h = mlp(xyz, feats, new_xyz, geometry[f"group{s}"], radius)
            # A centroid is a point of the cloud, so its nearest neighbour (itself) is in
            # every ball, and ball_query points empty slots at it: the plain max over K is
            # the masked max. Invalid centroids pool to 0.
            pooled = h.max(dim=2).values * new_mask.unsqueeze(-1).to(h.dtype)
            outs.append(norm(pooled))
        return new_xyz, torch.cat(outs, -1), new_mask


def plan_levels(layers: Sequence[SetAbstractionMSG], xyz: torch.Tensor, mask: torch.Tensor) -> Plan:
    """The geometry of stacked set abstractions, each on the previous one's centroids:
    keys ``sa1``, ``sa2``, ... (see :meth:`SetAbstractionMSG.sample_and_group`)."""
    plan: Plan = {}
    for i, layer in enumerate(layers, 1):
        plan[f"sa{i}"] = layer.sample_and_group(xyz, mask)
        xyz, mask = plan[f"sa{i}"]["xyz"], plan[f"sa{i}"]["mask"]
    return plan


class PointNet2Encoder(nn.Module):
    """PointNet++ encoder: three multi-scale set abstractions (``sa1``, ``sa2``, ``sa3``),
    each on the previous one's centroids, with 3, 3 and 2 scales of radius 0.1-0.4 m,
    0.2-0.8 m and 0.4-0.8 m.

    Args:
        in_channels: per-point feature channels of the input cloud.
        npoints: centroids of the three levels.
        ch, ns: the width and neighbour-count scaling of the model (``ModelConfig.ch``,
            ``ModelConfig.ns``).

    Shapes:
        - input: ``xyz`` (B, N, 3), ``feats`` (B, N, in_channels), ``mask`` (B, N) bool,
          ``plan``: :meth:`plan` of (xyz, mask)
        - output: one level per set abstraction i: ``xyz`` (B, npoints[i], 3), ``feats``
          (B, npoints[i], ``sa<i>.out_channels``), ``mask`` (B, npoints[i]) bool
    """

    def __init__(
        self,
        in_channels: int,
        npoints: tuple[int, int, int],
        ch: Callable[[int], int],
        ns: Callable[[int], int],
    ) -> None:
        super().__init__()
        n1, n2, n3 = npoints
        self.sa1 = SetAbstractionMSG(
            n1,
            (0.1, 0.2, 0.4),
            (ns(16), ns(32), ns(64)),
            in_channels,
            [[ch(32), ch(32), ch(64)], [ch(64), ch(64), ch(128)], [ch(64), ch(96), ch(128)]],
        )
        self.sa2 = SetAbstractionMSG(
            n2,
            (0.2, 0.4, 0.8),
            (ns(16), ns(32), ns(64)),
            self.sa1.out_channels,
            [[ch(128), ch(128), ch(256)], [ch(128), ch(196), ch(256)], [ch(128), ch(196), ch(256)]],
        )
        self.sa3 = SetAbstractionMSG(
            n3,
            (0.4, 0.8),
            (ns(16), ns(32)),
            self.sa2.out_channels,
            [[ch(256), ch(256), ch(512)], [ch(256), ch(256), ch(512)]],
        )

    def plan(self, xyz: torch.Tensor, mask: torch.Tensor) -> Plan:
        """The three set abstractions' geometry (keys ``sa1``..``sa3``)."""
        return plan_levels((self.sa1, self.sa2, self.sa3), xyz, mask)

    def forward(
        self, xyz: torch.Tensor, feats: torch.Tensor, mask: torch.Tensor, plan: Plan
    ) -> tuple[Level, Level, Level]:
        l1 = self.sa1(xyz, feats, mask, plan["sa1"])
        l2 = self.sa2(*l1, plan["sa2"])
        l3 = self.sa3(*l2, plan["sa3"])
        return l1, l2, l3


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
        geometry: Geometry | None = None,
    ) -> torch.Tensor:
        """``geometry``: :func:`interpolation_geometry` of (dst_xyz, src_xyz, src_mask)
        when already known (it depends on the point positions only)."""
        if geometry is None:
            geometry = interpolation_geometry(dst_xyz, src_xyz, src_mask)
        idx, w = geometry["idx"], geometry["weight"]
        interp = (gather_points(src_feats, idx) * w.unsqueeze(-1)).sum(2)
        x = interp if dst_feats is None else torch.cat([dst_feats, interp], -1)
        return self.mlp(x)
