import numpy as np
import torch

from momakitchen.models.pointnet2 import (
    ball_query,
    farthest_point_sample,
    square_distance,
    three_nn_weights,
)


def _reference_fps(points: np.ndarray, m: int) -> list[int]:
    """Textbook farthest point sampling (a loop over points), starting at index 0."""
    chosen = [0]
    dist = np.full(len(points), np.inf)
    for _ in range(m - 1):
        dist = np.minimum(dist, ((points - points[chosen[-1]]) ** 2).sum(1))
        chosen.append(int(np.argmax(dist)))
    return chosen


def test_fps_matches_reference_and_skips_padding():
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1, 1, (50, 3)).astype(np.float32)
    xyz = torch.zeros(1, 80, 3)
    mask = torch.zeros(1, 80, dtype=torch.bool)
    # Real points scattered among padding; padding placed far away (would be chosen if used).
    slots = np.sort(rng.choice(80, 50, replace=False))
    xyz[0, slots] = torch.from_numpy(pts)
    xyz[0, ~torch.isin(torch.arange(80), torch.from_numpy(slots))] = 100.0
    mask[0, slots] = True
    idx, valid = farthest_point_sample(xyz, mask, 10)
    assert valid.all()
    assert mask[0, idx[0]].all()
    expected = slots[_reference_fps(pts, 10)]
    assert idx[0].tolist() == expected.tolist()


def test_fps_with_too_few_real_points_repeats_real_points_and_flags_them():
    xyz = torch.randn(2, 20, 3)
    mask = torch.zeros(2, 20, dtype=torch.bool)
    mask[0, :3] = True
    mask[1, :20] = True
    idx, valid = farthest_point_sample(xyz, mask, 8)
    assert valid[0].tolist() == [True] * 3 + [False] * 5
    assert valid[1].all()
    assert set(idx[0].tolist()) == {0, 1, 2}
    assert len(set(idx[1].tolist())) == 8


def test_ball_query_radius_nearest_and_mask():
    xyz = torch.tensor([[[0.0, 0, 0], [0.05, 0, 0], [0.3, 0, 0], [0.01, 0, 0], [0.02, 0, 0]]])
    mask = torch.tensor([[True, True, True, True, False]])  # the point at 0.02 is padding
    centers = torch.tensor([[[0.0, 0, 0]]])
    ((idx, gmask),) = ball_query(0.1, 4, xyz, mask, centers)
    assert idx.shape == (1, 1, 4)
    assert gmask[0, 0].tolist() == [True, True, True, False]
    assert idx[0, 0, :3].tolist() == [0, 3, 1]
    assert 4 not in idx[0, 0].tolist()  # padding never grouped
    # several scales share one top-k and each is a prefix of the nearest neighbours
    groups = ball_query((0.02, 0.5), (2, 4), xyz, mask, centers)
    assert groups[0][1][0, 0].tolist() == [True, True]
    assert groups[1][1][0, 0].tolist() == [True, True, True, True]


def test_three_nn_weights_ignore_padding_and_sum_to_one():
    src = torch.tensor([[[0.0, 0, 0], [1.0, 0, 0], [0.1, 0, 0], [2.0, 0, 0]]])
    src_mask = torch.tensor([[True, True, False, True]])
    dst = torch.tensor([[[0.2, 0, 0]]])
    idx, w = three_nn_weights(dst, src, src_mask)
    assert 2 not in idx[0, 0].tolist()
    assert torch.allclose(w.sum(-1), torch.ones(1, 1))
    d = torch.tensor([0.2, 0.8, 1.8]) ** 2
    expected = (1 / d) / (1 / d).sum()
    assert torch.allclose(w[0, 0], expected, atol=1e-4)


def test_square_distance_matches_cdist():
    a, b = torch.randn(2, 7, 3), torch.randn(2, 5, 3)
    assert torch.allclose(square_distance(a, b), torch.cdist(a, b) ** 2, atol=1e-5)


def test_kdtree_and_topk_neighbour_search_agree(monkeypatch):
    import momakitchen.models.pointnet2 as pn

    g = torch.Generator().manual_seed(1)
    xyz = torch.rand(2, 60, 3, generator=g)
    mask = torch.ones(2, 60, dtype=torch.bool)
    mask[1, 40:] = False
    centers = torch.rand(2, 7, 3, generator=g)
    kd = pn.ball_query((0.2, 0.4), (4, 8), xyz, mask, centers)
    kd_w = pn.three_nn_weights(centers, xyz, mask)

    real_knn = pn._knn

    def topk_knn(points, m, queries, k):
        # Force the device-agnostic top-k branch on CPU tensors.
        d2 = pn.square_distance(queries, points)
        d2.masked_fill_(~m.unsqueeze(1), pn._BIG)
        return torch.topk(d2, k, dim=-1, largest=False, sorted=True)

    monkeypatch.setattr(pn, "_knn", topk_knn)
    tk = pn.ball_query((0.2, 0.4), (4, 8), xyz, mask, centers)
    tk_w = pn.three_nn_weights(centers, xyz, mask)
    monkeypatch.setattr(pn, "_knn", real_knn)
    for (ia, ma), (ib, mb) in zip(kd, tk, strict=True):
        assert torch.equal(ma, mb)
        assert torch.equal(torch.where(ma, ia, -1), torch.where(mb, ib, -1))
    assert torch.equal(kd_w[0], tk_w[0])
    assert torch.allclose(kd_w[1], tk_w[1], atol=1e-4)


def test_grouped_mlp_equals_gathering_relative_positions_first():
    from momakitchen.models.pointnet2 import GroupedMLP, gather_points

    torch.manual_seed(0)
    mlp = GroupedMLP(5, [8, 6])
    xyz, feats = torch.randn(2, 30, 3), torch.randn(2, 30, 5)
    centers = xyz[:, :4]
    idx = torch.randint(0, 30, (2, 4, 7))
    radius = 0.3
    fast = mlp(xyz, feats, centers, idx, radius)
    rel = (gather_points(xyz, idx) - centers.unsqueeze(2)) / radius
    naive_in = torch.cat([rel, gather_points(feats, idx)], -1)
    naive = torch.relu(mlp.first(naive_in))
    naive = mlp.rest(naive)
    assert torch.allclose(fast, naive, atol=1e-5)
    assert (fast >= 0).all()


def test_group_all_ignores_padding():
    from momakitchen.models.pointnet2 import SetAbstractionAll

    torch.manual_seed(0)
    layer = SetAbstractionAll(2, [8, 8])
    xyz, feats = torch.randn(1, 10, 3), torch.randn(1, 10, 2)
    mask = torch.ones(1, 10, dtype=torch.bool)
    padded_mask = torch.cat([mask, torch.zeros(1, 5, dtype=torch.bool)], 1)
    out = layer(xyz, feats, mask)
    out_padded = layer(
        torch.cat([xyz, torch.full((1, 5, 3), 50.0)], 1),
        torch.cat([feats, torch.full((1, 5, 2), 50.0)], 1),
        padded_mask,
    )
    assert out.shape == (1, 8)
    assert torch.allclose(out, out_padded)


def test_set_abstraction_pools_like_a_masked_max_over_each_ball():
    """SA pools with a plain max over K because empty slots repeat the centroid itself;
    it must equal the masked max over the real neighbours within the radius (centroids of
    a cloud with too few real points pool to 0)."""
    from momakitchen.models.pointnet2 import SetAbstractionMSG, ball_query, gather_points

    torch.manual_seed(0)
    sa = SetAbstractionMSG(16, (0.05, 0.3), (4, 8), 5, [[8, 8], [8, 16]])
    xyz = torch.rand(2, 40, 3)
    feats = torch.randn(2, 40, 5)
    mask = torch.ones(2, 40, dtype=torch.bool)
    mask[1, 10:] = False  # 10 real points for 16 centroids
    new_xyz, out, new_mask = sa(xyz, feats, mask)
    assert not new_mask[1].all()
    idx, valid = farthest_point_sample(xyz, mask, 16)
    centers = gather_points(xyz, idx)
    groups = ball_query(sa.radii, sa.nsamples, xyz, mask, centers)
    ref = []
    for (gidx, gmask), radius, mlp, norm in zip(groups, sa.radii, sa.mlps, sa.norms, strict=True):
        h = mlp(xyz, feats, centers, gidx, radius)
        keep = gmask & valid.unsqueeze(-1)
        pooled = h.masked_fill(~keep.unsqueeze(-1), float("-inf")).amax(2)
        ref.append(norm(torch.where(keep.any(-1, keepdim=True), pooled, torch.zeros_like(pooled))))
    assert torch.allclose(out, torch.cat(ref, -1), atol=1e-6)
    assert torch.equal(new_xyz, centers)


def test_pointnet2_encoder_levels_follow_the_plan():
    from momakitchen.models.pointnet2 import PointNet2Encoder

    torch.manual_seed(0)
    enc = PointNet2Encoder(4, (32, 16, 8), lambda c: max(4, c // 16), lambda n: max(2, n // 8))
    xyz, feats = torch.rand(2, 60, 3), torch.randn(2, 60, 4)
    mask = torch.ones(2, 60, dtype=torch.bool)
    mask[1, 40:] = False
    plan = enc.plan(xyz, mask)
    assert sorted(plan) == ["sa1", "sa2", "sa3"]
    levels = enc(xyz, feats, mask, plan)
    for (x, f, m), n, sa in zip(levels, (32, 16, 8), (enc.sa1, enc.sa2, enc.sa3), strict=True):
        assert x.shape == (2, n, 3) and f.shape == (2, n, sa.out_channels) and m.shape == (2, n)
    # The plan is what the layers would find themselves.
    x1, f1, m1 = enc.sa1(xyz, feats, mask)
    assert torch.equal(levels[0][1], f1)
    assert torch.equal(enc.sa2(x1, f1, m1)[1], levels[1][1])
