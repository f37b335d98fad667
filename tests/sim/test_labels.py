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


def test_map_is_zero_where_the_base_would_not_fit():
    """The floor-plan check never calls a base position free where PyBullet finds the
    base colliding, and the map is 0 there even next to successful trials."""
    from momakitchen.robots import get_robot_spec
    from momakitchen.scene.configuration import base_fits, sample_scene
    from momakitchen.scene.geometry import semicircle_grid
    from momakitchen.sim.labels import Labels, floor_affordance
    from momakitchen.sim.trials import TrialRunner
    from momakitchen.sim.world import World

    scene = sample_scene(2001)
    cfg = scene.configurations[3]
    spec = get_robot_spec(cfg.robot)
    grid = semicircle_grid(cfg.target.anchor[:2], spec.reach, 0.1)
    fits = base_fits(scene.layout, cfg, grid, spec.footprint)
    with World(scene.layout) as world:
        world.load_configuration(cfg)
        runner = TrialRunner(world, cfg.robot)
        free = np.array([runner.base_free(x, y) for x, y in grid])
        runner.close()
    assert not (fits & ~free).any()  # conservative: never free where physics collides
    assert (fits == free).mean() > 0.85 and (~fits).any() and fits.any()
    # Every trial a success: the map is still 0 wherever the base does not fit.
    labels = Labels(
        cfg.scene_id, cfg.index, cfg.robot, "t", cfg.target.anchor, 0.1, grid,
        np.zeros(len(grid)), np.zeros(len(grid), np.uint8), np.zeros(len(grid), np.float32), {},
    )  # fmt: skip
    base = (0.0, 0.0, 0.0)  # the world frame as the viewpoint's base frame
    values = floor_affordance(labels, scene.layout, cfg, grid, base)
    assert np.all(values[~fits] == 0) and np.all(values[fits] > 0.99)


def test_map_is_zero_beyond_the_sampling_area():
    """The trials cover the half-disc of the robot's reach: a floor point just beyond it,
    next to successful trials, is not claimed (the interpolation alone gives it 1)."""
    from momakitchen.robots import get_robot_spec
    from momakitchen.scene.configuration import base_fits, sample_scene
    from momakitchen.scene.geometry import semicircle_grid
    from momakitchen.sim.labels import Labels, dense_map, floor_affordance

    scene = sample_scene(2001)
    cfg = scene.configurations[3]
    spec = get_robot_spec(cfg.robot)
    anchor = np.asarray(cfg.target.anchor[:2])
    grid = semicircle_grid(tuple(anchor), spec.reach, 0.1)
    labels = Labels(
        cfg.scene_id, cfg.index, cfg.robot, "t", cfg.target.anchor, 0.1, grid,
        np.zeros(len(grid)), np.zeros(len(grid), np.uint8), np.zeros(len(grid), np.float32), {},
    )  # fmt: skip
    # Points 8 cm beyond the outermost trials, on the rays through them.
    ray = grid - anchor
    dist = np.hypot(ray[:, 0], ray[:, 1])
    outer = grid[dist > spec.reach - 0.1]
    beyond = (
        anchor
        + (outer - anchor)
        * ((np.hypot(*(outer - anchor).T) + 0.08) / np.hypot(*(outer - anchor).T))[:, None]
    )
    beyond = beyond[base_fits(scene.layout, cfg, beyond, spec.footprint)]
    assert len(beyond) >= 3
    assert np.all(dense_map(grid, labels.outcomes, beyond) > 0.99)
    assert np.all(floor_affordance(labels, scene.layout, cfg, beyond, (0.0, 0.0, 0.0)) == 0)
    # Inside the area the map stays as the trials say.
    inside = grid[base_fits(scene.layout, cfg, grid, spec.footprint)]
    assert np.all(floor_affordance(labels, scene.layout, cfg, inside, (0.0, 0.0, 0.0)) > 0.99)
