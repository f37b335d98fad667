"""Fusing looks in the odometry frame: frames, weights, the goal, when to look again."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momakitchen.deploy.fusion import FusedGoal, LookPolicy, MapFusion
from momakitchen.errors import MomaError
from momakitchen.models.inference import map_prediction


def _look(points, values, target=(3.0, 0.0, 0.8), std=None):
    xyz = np.column_stack([np.asarray(points, float), np.zeros(len(points))])
    values = np.asarray(values, float)
    std = np.zeros(len(values)) if std is None else np.asarray(std, float)
    return map_prediction(
        xyz, values, std, np.asarray(target, float), "panda", "navaff", top_k=1, min_spread=0.2
    )


def test_a_look_lands_in_the_odometry_frame():
    fusion = MapFusion(cell=0.1)
    # Seen from a base at (1, 2) turned 90 deg left: base x is odometry +y.
    fusion.add(
        _look([[2.0, 0.0], [1.0, 0.5]], [0.9, 0.2], target=(3.0, 0.0, 0.8)), (1, 2, math.pi / 2)
    )
    goal = fusion.goal()
    assert goal is not None
    assert goal.pose[:2] == pytest.approx((1.05, 4.05))  # (1, 4)'s cell centre
    np.testing.assert_allclose(fusion.target_xy, (1.0, 5.0), atol=1e-12)
    assert goal.pose[2] == pytest.approx(math.atan2(5.0 - 4.05, 1.0 - 1.05))
    assert fusion.last_target_distance == pytest.approx(3.0)


def test_a_closer_look_outweighs_a_farther_one():
    fusion = MapFusion(cell=0.1)
    cell = [[3.0, 0.0]]
    fusion.add(_look(cell, [0.9]), (0.0, 0.0, 0.0))  # 3 m away: weight 1/9
    fusion.add(_look([[1.0, 0.0]], [0.1]), (2.0, 0.0, 0.0))  # the same cell, 1 m away: 1
    _, value, _ = fusion.fused()
    assert value[0] == pytest.approx((0.9 / 9 + 0.1) / (1 / 9 + 1))
    assert fusion.looks == 2


def test_goal_is_the_best_reachable_cell():
    fusion = MapFusion(cell=0.1)
    fusion.add(_look([[1.0, 0.0], [1.0, 1.0], [2.0, 0.0]], [0.9, 0.8, 0.1]), (0.0, 0.0, 0.0))
    assert fusion.goal().pose[:2] == pytest.approx((1.05, 0.05))
    blocked = fusion.goal(reachable=lambda x, y: y > 0.5)
    assert blocked.pose[:2] == pytest.approx((1.05, 1.05))
    assert fusion.goal(reachable=lambda x, y: False) is None
    assert MapFusion().goal() is None


def test_look_again_by_policy():
    fusion = MapFusion()
    fusion.add(_look([[1.0, 0.0]], [0.5], target=(5.0, 0.0, 0.8), std=[0.2]), (0.0, 0.0, 0.0))
    goal = FusedGoal((1.0, 0.0, 0.0), 0.5, 0.2)
    assert not LookPolicy("single").look_again(fusion, (0.0, 0.0), goal)
    assert not LookPolicy("relook", relook_distance=0.5).look_again(fusion, (0.0, 0.0), goal)
    assert LookPolicy("relook", relook_distance=1.5).look_again(fusion, (0.0, 0.0), goal)
    assert LookPolicy("uncertain").look_again(fusion, (0.0, 0.0), goal)  # std 0.2, 5 m
    sure = FusedGoal((1.0, 0.0, 0.0), 0.5, 0.01)
    assert LookPolicy("uncertain").look_again(fusion, (0.0, 0.0), sure)  # still 5 m away
    near = MapFusion()
    near.add(_look([[1.0, 0.0]], [0.5], target=(2.0, 0.0, 0.8)), (0.0, 0.0, 0.0))
    assert not LookPolicy("uncertain").look_again(near, (0.0, 0.0), sure)
    assert not LookPolicy("uncertain", max_looks=1).look_again(fusion, (0.0, 0.0), goal)


def test_bad_input_is_named():
    with pytest.raises(MomaError, match="odom_pose"):
        MapFusion().add(_look([[1.0, 0.0]], [0.5]), (0.0, float("nan"), 0.0))
    with pytest.raises(MomaError, match="not finite"):
        MapFusion().add(_look([[1.0, 0.0]], [float("nan")]), (0.0, 0.0, 0.0))
    with pytest.raises(MomaError, match="unknown policy 'sometimes'"):
        LookPolicy("sometimes")
    with pytest.raises(MomaError, match="max_looks"):
        LookPolicy(max_looks=0)
    with pytest.raises(MomaError, match=r"MapFusion\.cell"):
        MapFusion(cell=0.0)
