"""Base motion: free space, shortest paths, odometry drift and the final stop."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import base_fits, sample_scene
from momakitchen.sim.motion import BaseState, FreeSpace, MotionConfig, drive, stop_and_face


@pytest.fixture(scope="module")
def space():
    scene = sample_scene(7)
    cfg = scene.configurations[0]
    spec = get_robot_spec(cfg.robot)
    return scene, cfg, FreeSpace(scene.layout, cfg, spec.footprint, MotionConfig())


def _front(cfg, free: FreeSpace) -> tuple[float, float]:
    """A free cell 0.6-0.9 m in front of the target."""
    ax, ay = cfg.target.anchor[:2]
    d = np.hypot(*(free.cells - (ax, ay)).T)
    ok = free.free & (d > 0.6) & (d < 0.9) & (free.cells[:, 1] > ay)
    return tuple(free.cells[np.flatnonzero(ok)[0]])


def test_free_space_is_the_floor_plan(space):
    scene, cfg, free = space
    spec = get_robot_spec(cfg.robot)
    np.testing.assert_array_equal(
        free.free, base_fits(scene.layout, cfg, free.cells, spec.footprint)
    )
    assert 0.2 < free.free.mean() < 0.95  # furniture along the wall blocks part of it
    assert not free.is_free(cfg.target.anchor[0], 0.05)  # against the wall, under the counter


def test_paths_stay_on_free_cells_and_are_at_least_straight(space):
    scene, cfg, free = space
    start = (scene.layout.room.width / 2, scene.layout.room.depth - 0.6)
    assert free.is_free(*start)
    goal = _front(cfg, free)
    path = free.plan(start, goal)
    assert path is not None
    assert all(free.is_free(x, y) for x, y in path)
    steps = np.hypot(*np.diff(path, axis=0).T)
    assert steps.max() <= math.sqrt(2) * free.step + 1e-9
    length = float(steps.sum())
    straight = math.dist(start, goal)
    shortest = free.shortest(start)[free.index(*goal)]
    # Cell to cell, the ends off the grid by up to half a cell each; clearance costs only
    # lengthen the planned path.
    assert straight - free.step <= shortest <= length + free.step
    assert free.plan(start, (cfg.target.anchor[0], 0.05)) is None  # a blocked goal
    assert not free.reachable(start)(cfg.target.anchor[0], 0.05)


def test_drive_without_drift_ends_where_odometry_says(space):
    scene, cfg, free = space
    start_xy = (scene.layout.room.width / 2, scene.layout.room.depth - 0.6)
    goal = _front(cfg, free)
    anchor = cfg.target.anchor[:2]
    exact = MotionConfig(drift_along=0.0, drift_across=0.0, drift_yaw=0.0)
    yaw = math.atan2(anchor[1] - start_xy[1], anchor[0] - start_xy[0])
    state = BaseState((*start_xy, yaw), (*start_xy, yaw))
    poses, ok = drive(state, free.plan(start_xy, goal), anchor, exact, np.random.default_rng(0))
    assert ok
    np.testing.assert_allclose(state.true, state.odom, atol=1e-9)
    np.testing.assert_allclose(state.odom[:2], goal, atol=1e-9)
    assert state.driven == pytest.approx(
        sum(math.dist(a[:2], b[:2]) for a, b in itertools.pairwise(poses))
    )


def test_drift_moves_the_truth_not_the_belief_and_is_seeded(space):
    scene, cfg, free = space
    start_xy = (scene.layout.room.width / 2, scene.layout.room.depth - 0.6)
    goal = _front(cfg, free)
    anchor = cfg.target.anchor[:2]
    ends = []
    for seed in (0, 0, 1):
        state = BaseState((*start_xy, 0.0), (*start_xy, 0.0))
        drive(state, free.plan(start_xy, goal), anchor, MotionConfig(), np.random.default_rng(seed))
        np.testing.assert_allclose(state.odom[:2], goal, atol=1e-9)
        ends.append(state.true)
    assert ends[0] == ends[1]  # the same seed, the same drift
    assert ends[0] != ends[2]
    err = math.dist(ends[0][:2], goal)
    assert 1e-4 < err < 0.3  # a few per cent of a few metres


def test_drive_stops_before_a_collision(space):
    scene, cfg, _free = space
    start_xy = (scene.layout.room.width / 2, scene.layout.room.depth - 0.6)
    path = np.array([start_xy, (start_xy[0], start_xy[1] - 1.0)])
    state = BaseState((*start_xy, 0.0), (*start_xy, 0.0))
    wall = start_xy[1] - 0.5
    poses, ok = drive(
        state,
        path,
        cfg.target.anchor[:2],
        MotionConfig(),
        np.random.default_rng(0),
        check=lambda p: p[1] > wall,
    )
    assert not ok
    assert all(p[1] > wall for p in poses)
    assert state.true == poses[-1]


def test_stop_and_face():
    state = BaseState((1.0, 1.0, 0.3), (1.0, 1.0, 0.3))
    x, y, yaw = stop_and_face(state, (1.0, 2.0), 0.0, 0.0, (1.0, -1.0, 1.0))
    assert (x, y) == (1.0, 1.0) and yaw == pytest.approx(math.pi / 2)
    x, y, yaw = stop_and_face(state, (1.0, 2.0), 0.03, 2.0, (1.0, -1.0, 1.0))
    assert (x, y) == pytest.approx((1.03, 0.97))
    assert yaw == pytest.approx(math.pi / 2 + math.radians(2.0))


@pytest.mark.parametrize(
    ("field", "value"), [("stop_xy", -0.01), ("speed", 0.0), ("drift_yaw", float("nan"))]
)
def test_motion_config_names_the_bad_value(field, value):
    with pytest.raises(MomaError, match=f"MotionConfig.{field}"):
        MotionConfig(**{field: value})
