import math

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.frames import world_to_base
from momakitchen.sim.config import DenseMapConfig
from momakitchen.sim.labels import dense_map


def test_dense_map_hand_computed():
    pos = np.array([[0.0, 0.0], [0.1, 0.0]])
    out = np.array([1, 0])
    cfg = DenseMapConfig(theta=0.15, k=2, sigma=0.05)
    q = np.array([[0.0, 0.0], [0.05, 0.0], [0.03, 0.0], [1.0, 1.0]])
    v = dense_map(pos, out, q, cfg)
    w0, w1 = math.exp(-(0.03**2) / (2 * 0.05**2)), math.exp(-(0.07**2) / (2 * 0.05**2))
    expected0 = 1 / (1 + math.exp(-(0.1**2) / (2 * 0.05**2)))
    assert v[0] == pytest.approx(expected0, rel=1e-6)
    assert v[1] == pytest.approx(0.5, rel=1e-6)  # equidistant
    assert v[2] == pytest.approx(w0 / (w0 + w1), rel=1e-6)
    assert v[3] == 0.0  # no trial within theta
    assert v.dtype == np.float32


def test_dense_map_threshold_excludes_far_trials():
    pos = np.array([[0.0, 0.0], [0.5, 0.0]])
    v = dense_map(pos, np.array([0, 1]), np.array([[0.1, 0.0]]), DenseMapConfig(theta=0.2))
    assert v[0] == 0.0  # the successful trial is beyond theta


def test_dense_map_range_and_shapes():
    rng = np.random.default_rng(0)
    pos = rng.uniform(-1, 1, (50, 2))
    v = dense_map(pos, rng.integers(0, 2, 50), rng.uniform(-1, 1, (400, 2)))
    assert v.shape == (400,) and np.all((v >= 0) & (v <= 1))
    assert dense_map(pos[:0], np.zeros(0), rng.uniform(size=(5, 2))).tolist() == [0.0] * 5
    with pytest.raises(MomaError, match="3 outcomes"):
        dense_map(pos, np.zeros(3), pos)
    with pytest.raises(MomaError, match="theta"):
        DenseMapConfig(theta=-1)


def test_world_to_base():
    pts = np.array([[2.0, 1.0], [1.0, 2.0]])
    b = world_to_base(pts, (1.0, 1.0, math.pi / 2))  # robot at (1, 1) facing +y
    assert np.allclose(b, [[0.0, -1.0], [1.0, 0.0]])
