"""The ring rule: its standoff from the robot's numbers, and its band on a synthetic floor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.placement.body import PlacementRobot, placement_robot
from momakitchen.placement.observed import ObservedFrame
from momakitchen.placement.ring import BAND, CLEARANCE, COMFORT, ring_map, ring_standoff


def _robot(reach=0.85, mount=1.03, shoulder=1.36):
    return PlacementRobot("custom", reach, mount, shoulder, 0.15, (0.55, 0.45))


def test_the_standoff_puts_the_target_at_a_share_of_the_reach_from_the_shoulder():
    robot = _robot()
    for z in (0.9, 1.2, 1.5):
        standoff = ring_standoff(robot, z)
        from_shoulder = math.hypot(standoff - 0.15, z - 1.36)
        assert from_shoulder == pytest.approx(COMFORT * 0.85)
    # a target too far below the shoulder: as close as the base's front edge allows
    assert ring_standoff(robot, 0.2) == pytest.approx(0.55 / 2 + CLEARANCE)
    # a longer arm stands farther back; at the shoulder's height the farthest
    assert ring_standoff(_robot(reach=1.3), 1.0) > ring_standoff(robot, 1.0)
    assert ring_standoff(robot, 1.36) == pytest.approx(0.15 + COMFORT * 0.85)


def test_registered_robots_give_their_own_numbers():
    panda = placement_robot("panda")
    assert (panda.reach, panda.mount_height, panda.mount_offset_x) == (0.85, 1.03, 0.15)
    assert panda.shoulder_height == pytest.approx(1.03 + 0.333, abs=0.01)
    low = placement_robot("panda", 0.6)
    assert low.mount_height == 0.6
    assert low.shoulder_height == pytest.approx(panda.shoulder_height - 0.43)
    with pytest.raises(MomaError, match="reach"):
        PlacementRobot("x", 0.0, 1.0, 1.2, 0.15, (0.5, 0.4))


def test_the_band_on_free_floor_on_the_camera_side():
    robot = _robot()
    xs, ys = np.meshgrid(np.arange(-1.0, 3.0, 0.05), np.arange(-2.0, 2.0, 0.05))
    floor = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    target = np.array([2.0, 0.0, 1.2])
    # a chair-like block of points between the camera and the target, off its axis
    block = np.stack(np.meshgrid([1.4, 1.45, 1.5], [0.5, 0.55, 0.6], [0.1, 0.4]), -1)
    frame = ObservedFrame(
        floor_xyz=floor,
        points=block.reshape(-1, 3),
        target_points=target[None] + [[0, 0, 0], [0, 0.05, 0]],
        target_xyz=target,
        camera_xyz=np.array([0.0, 0.0, 1.2]),
        correction=None,  # type: ignore[arg-type]  # not read by the map
    )
    score, warnings = ring_map(frame, robot)
    assert not warnings and ((score >= 0) & (score <= 1)).all()
    d = np.hypot(*(floor[:, :2] - target[:2]).T)
    best = np.argmax(score)
    assert abs(d[best] - ring_standoff(robot, 1.2)) < 0.05 and score[best] > 0.95
    assert (score[floor[:, 0] > 2.0] == 0).all()  # behind the target
    near_block = np.hypot(floor[:, 0] - 1.45, floor[:, 1] - 0.55) < 0.2
    assert (score[near_block] == 0).all()  # the base would stand on the block
    clear = np.hypot(floor[:, 0] - 1.45, floor[:, 1] - 0.55) > 0.45  # a box's half-diagonal
    band = (np.abs(d - ring_standoff(robot, 1.2)) < BAND) & (floor[:, 0] < 1.9) & clear
    assert (score[band] > 0.5).all()
