import math

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.metrics import (
    METRIC_NAMES,
    breakdown,
    episode_metrics,
    format_table,
    map_metrics,
)


def test_hand_computed_single_episode():
    p = np.array([0.2, 0.4, 0.0, 1.0])
    g = np.array([0.0, 0.5, 0.5, 1.0])
    m = episode_metrics(p, g)
    assert m["mae"] == pytest.approx((0.2 + 0.1 + 0.5 + 0.0) / 4)
    assert m["mse"] == pytest.approx((0.04 + 0.01 + 0.25) / 4)
    assert m["rmse"] == pytest.approx(math.sqrt(0.3 / 4))
    logs = [
        (math.log(1.2) - 0.0) ** 2,
        (math.log(1.4) - math.log(1.5)) ** 2,
        (0.0 - math.log(1.5)) ** 2,
        0.0,
    ]
    assert m["logmse"] == pytest.approx(sum(logs) / 4)
    # Pearson by hand: means 0.4 and 0.5
    pc = p - 0.4
    gc = g - 0.5
    pcc = (pc * gc).sum() / math.sqrt((pc**2).sum() * (gc**2).sum())
    assert m["pcc"] == pytest.approx(pcc)
    # SIM: p/1.6, g/2.0, sum of minima
    sim = min(0.2 / 1.6, 0.0) + min(0.4 / 1.6, 0.25) + min(0.0, 0.25) + min(1 / 1.6, 0.5)
    assert m["sim"] == pytest.approx(sim)
    assert m["sim"] == pytest.approx(0.75)
    norms = math.sqrt(0.04 + 0.16 + 1) * math.sqrt(0.25 + 0.25 + 1)
    cos = (0.2 * 0 + 0.4 * 0.5 + 0 + 1.0) / norms
    assert m["cos"] == pytest.approx(cos)
    assert m["ciou"] == pytest.approx((0.0 + 0.4 + 0.0 + 1.0) / (0.2 + 0.5 + 0.5 + 1.0))


def test_constant_and_all_zero_maps_score_zero_not_nan():
    zero = np.zeros(5)
    const = np.full(5, 0.3)
    ramp = np.linspace(0, 1, 5)
    a = episode_metrics(const, ramp)  # constant prediction
    assert a["pcc"] == 0.0
    assert a["cos"] > 0  # cosine is defined for a constant non-zero map
    b = episode_metrics(ramp, zero)  # all-zero ground truth
    assert b["pcc"] == 0.0 and b["cos"] == 0.0 and b["sim"] == 0.0
    assert b["ciou"] == 0.0  # sum(min) = 0 over sum(max) > 0
    assert b["mse"] == pytest.approx(np.mean(ramp**2))
    c = episode_metrics(zero, zero)  # both zero: undefined PCC, cos and cIoU score 0
    assert c["pcc"] == 0.0 and c["cos"] == 0.0 and c["ciou"] == 0.0 and c["sim"] == 0.0
    assert c["mae"] == 0.0 and c["mse"] == 0.0 and c["logmse"] == 0.0
    for m in (a, b, c):
        assert all(np.isfinite(v) for v in m.values())
    # a map that is constant in value but computed with rounding (0.1 * 3 things)
    d = episode_metrics(np.array([0.1, 0.1, 0.1]) * 3, ramp[:3])
    assert d["pcc"] == 0.0


def test_sim_epsilon_as_in_reference():
    p = np.array([1e-13, 0.0])
    g = np.array([1.0, 0.0])
    m = episode_metrics(p, g)
    # p normalised with 1e-12 added to its sum: 1e-13 / 1.1e-12
    assert m["sim"] == pytest.approx(1e-13 / (1e-13 + 1e-12))


def test_map_metrics_averages_per_episode_and_rmse_is_sqrt_of_mean_mse():
    preds = [np.array([0.0, 1.0]), np.array([0.5, 0.5, 0.5])]
    gts = [np.array([0.0, 0.0]), np.array([0.5, 0.5, 1.0])]
    m = map_metrics(preds, gts)
    assert tuple(m) == METRIC_NAMES
    mse1, mse2 = 0.5, 0.25 / 3
    assert m["mse"] == pytest.approx((mse1 + mse2) / 2)
    assert m["rmse"] == pytest.approx(math.sqrt((mse1 + mse2) / 2))
    assert m["rmse"] != pytest.approx((math.sqrt(mse1) + math.sqrt(mse2)) / 2)
    assert m["mae"] == pytest.approx((0.5 + 0.5 / 3) / 2)
    # episode 1: gt all zero -> pcc 0; episode 2: pred constant -> pcc 0
    assert m["pcc"] == 0.0
    assert m["ciou"] == pytest.approx((0.0 + 1.5 / 2.0) / 2)


def test_perfect_prediction():
    g = [np.array([0.1, 0.9, 0.0]), np.array([1.0, 0.2])]
    m = map_metrics(g, [x.copy() for x in g])
    assert m["mse"] == 0 and m["mae"] == 0 and m["rmse"] == 0 and m["logmse"] == 0
    for k in ("pcc", "sim", "cos", "ciou"):
        assert m[k] == pytest.approx(1.0)


def test_errors():
    with pytest.raises(MomaError, match="3 values but the map has 2"):
        map_metrics([np.zeros(3)], [np.zeros(2)])
    with pytest.raises(MomaError, match="no episodes"):
        map_metrics([], [])
    with pytest.raises(MomaError, match="NaN"):
        map_metrics([np.array([np.nan])], [np.zeros(1)])
    with pytest.raises(MomaError, match="one key per episode"):
        breakdown([np.zeros(1)], [np.zeros(1)], [])


def test_breakdown_groups_and_table():
    preds = [np.array([0.0, 1.0]), np.array([0.5, 0.5]), np.array([1.0, 0.0])]
    gts = [np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([0.0, 1.0])]
    by = breakdown(preds, gts, ["panda", "ur5e", "panda"])
    assert list(by) == ["panda", "ur5e"]
    assert by["panda"]["episodes"] == 2 and by["ur5e"]["episodes"] == 1
    assert by["panda"]["mse"] == pytest.approx(0.5)
    assert by["ur5e"]["mse"] == pytest.approx(0.25)
    assert by["panda"]["pcc"] == pytest.approx(0.0)  # +1 and -1 average to 0
    table = format_table({"NavAff": by["ur5e"], "PointNet++": by["panda"]})
    lines = table.splitlines()
    assert lines[0].startswith("| Method | RMSE ↓ | logMSE ↓ | PCC ↑ | SIM ↑")
    assert len(lines) == 4
    assert "**0.5000**" in lines[2]  # NavAff has the best (lowest) RMSE
