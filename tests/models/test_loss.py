import math

import pytest
import torch

from momakitchen.models.loss import WeightedMSELoss


def test_weighted_mse_hand_values():
    pred = torch.tensor([[0.5, 0.2, 0.9, 0.4]])
    label = torch.tensor([[1.0, 0.0, 0.0, 0.7]])
    mask = torch.tensor([[True, True, True, False]])
    crit = WeightedMSELoss(lambda_zero=0.7, prob=1.0)
    plain = (0.25 + 0.04 + 0.81) / 3
    weighted = (0.25 + 0.7 * 0.04 + 0.7 * 0.81) / 3
    crit.train()
    out = crit(pred, label, mask)
    assert out["loss"].item() == pytest.approx(weighted, rel=1e-6)
    assert out["mse"].item() == pytest.approx(plain, rel=1e-6)
    crit.eval()  # eval: plain masked MSE
    assert crit(pred, label, mask)["loss"].item() == pytest.approx(plain, rel=1e-6)
    never = WeightedMSELoss(lambda_zero=0.7, prob=0.0).train()
    assert never(pred, label, mask)["loss"].item() == pytest.approx(plain, rel=1e-6)


def test_weighting_is_applied_about_half_the_time():
    pred = torch.full((1, 3), 0.5)
    label = torch.tensor([[0.0, 0.0, 1.0]])
    mask = torch.ones(1, 3, dtype=torch.bool)
    crit = WeightedMSELoss(0.7, 0.5).train()
    torch.manual_seed(0)
    losses = [crit(pred, label, mask)["loss"].item() for _ in range(400)]
    weighted = sum(abs(v - (0.7 * 0.25 * 2 + 0.25) / 3) < 1e-6 for v in losses)
    assert 150 < weighted < 250
    assert all(abs(v - 0.25) < 1e-6 or abs(v - 0.2) < 1e-6 for v in losses)


def test_map_kl_hand_values_padding_and_empty_maps():
    from momakitchen.models.loss import map_kl

    label = torch.tensor([[0.0, 1.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    mask = torch.tensor([[True, True, True, False], [True, True, True, True]])
    # Episode 0: label (0, .5, .5) on its real points; the all-zero episode 1 is left out.
    pred = torch.tensor([[0.2, 0.2, 0.6, 9.0], [0.3, 0.1, 0.2, 0.4]])
    expected = 0.5 * math.log(0.5 / 0.2) + 0.5 * math.log(0.5 / 0.6)
    assert map_kl(pred, label, mask).item() == pytest.approx(expected, rel=1e-4)
    assert map_kl(label, label, mask).item() == pytest.approx(0.0, abs=1e-6)
    assert map_kl(pred, torch.zeros_like(label), mask).item() == 0.0
    crit = WeightedMSELoss(prob=0.0, kl_weight=0.5)
    plain = WeightedMSELoss(prob=0.0)
    gap = crit(pred, label, mask)["loss"] - plain(pred, label, mask)["loss"]
    assert gap.item() == pytest.approx(0.5 * expected, rel=1e-4)


def test_peak_kl_hand_values_padding_and_empty_maps():
    from momakitchen.models.loss import peak_kl

    label = torch.tensor([[0.0, 1.0, 0.5, 0.0], [0.0, 0.0, 0.0, 0.0]])
    mask = torch.tensor([[True, True, True, False], [True, True, True, True]])
    pred = torch.tensor([[0.2, 0.3, 0.6, 9.0], [0.3, 0.1, 0.2, 0.4]])
    t = 0.5
    q = torch.softmax(torch.tensor([0.0, 1.0, 0.5]) / t, 0)
    p = torch.softmax(torch.tensor([0.2, 0.3, 0.6]) / t, 0)
    expected = float((q * (q.log() - p.log())).sum())
    # The padded point (pred 9.0) and the all-zero episode 1 do not count.
    assert peak_kl(pred, label, mask, t).item() == pytest.approx(expected, rel=1e-5)
    assert peak_kl(label, label, mask, t).item() == pytest.approx(0.0, abs=1e-6)
    assert peak_kl(pred, torch.zeros_like(label), mask).item() == 0.0
    # Ranking the best point first lowers it: the term is about order at the top.
    swapped = torch.tensor([[0.2, 0.6, 0.3, 9.0], [0.3, 0.1, 0.2, 0.4]])
    assert peak_kl(swapped, label, mask, t) < peak_kl(pred, label, mask, t)
    crit = WeightedMSELoss(prob=0.0, peak_weight=0.2, peak_temperature=t)
    gap = crit(pred, label, mask)["loss"] - WeightedMSELoss(prob=0.0)(pred, label, mask)["loss"]
    assert gap.item() == pytest.approx(0.2 * expected, rel=1e-5)
    g = pred.clone().requires_grad_(True)
    peak_kl(g, label, mask, t).backward()
    assert torch.isfinite(g.grad).all() and g.grad[0, 3] == 0 and (g.grad[1] == 0).all()
