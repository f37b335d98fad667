"""place: both classical methods on a real generated frame (poses on free floor, within
reach, on the camera's side), bit-for-bit determinism, one-line errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from placement_helpers import frame_of

from momakitchen.errors import MomaError
from momakitchen.perception.inputs import load_frame
from momakitchen.placement import CLASSICAL_METHODS, METHODS, ReachabilityMap, place
from momakitchen.placement.body import placement_robot
from momakitchen.placement.observed import camera_side, free_floor, grasp_approaches, observe
from momakitchen.placement.ring import BAND, ring_standoff, shoulder_distance
from momakitchen.sim import reachability


def test_the_registry_is_the_one_list_of_methods():
    assert CLASSICAL_METHODS == tuple(METHODS) == ("ring", "reachability")


def _seen(inputs):
    frame = load_frame(
        inputs["depth"],
        inputs["intrinsics"],
        inputs["camera_to_base"],
        inputs["target_mask"],
        inputs["obstacle_masks"],
    )
    return observe(frame)


@pytest.mark.parametrize("method", CLASSICAL_METHODS)
def test_poses_stand_on_free_floor_within_reach(episodes, coarse_maps, method):
    for ep in episodes:
        inputs = frame_of(ep)
        pred = place(method, **inputs)
        seen = _seen(inputs)
        body = placement_robot(ep.robot, inputs["mount_height"])
        n = len(pred.floor_xyz)
        np.testing.assert_array_equal(pred.floor_xyz, seen.floor_xyz)
        np.testing.assert_array_equal(pred.target_xyz, seen.target_xyz)
        assert (pred.model, pred.robot) == (method, ep.robot)
        assert pred.affordance.shape == pred.uncertainty.shape == (n,)
        assert (pred.uncertainty == 0).all() and (pred.pose_uncertainty == 0).all()
        assert ((pred.affordance >= 0) & (pred.affordance <= 1)).all()
        k = len(pred.poses)
        assert 1 <= k <= 5 and pred.poses.shape == (k, 3) and not pred.warnings
        assert (pred.pose_scores > 0).all()
        assert pred.pose_scores[0] == pred.affordance.max()
        xy = pred.poses[:, :2]
        gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))
        assert gaps[np.triu_indices(k, 1)].min() >= 0.2  # min_spread
        to = pred.target_xyz[:2] - xy
        np.testing.assert_allclose(np.cos(pred.poses[:, 2] - np.arctan2(to[:, 1], to[:, 0])), 1)
        # every pose is a floor point of the frame, free for the base
        index = [int(np.flatnonzero((seen.floor_xyz[:, :2] == p).all(1))[0]) for p in xy]
        assert free_floor(seen, body.footprint, body.mount_height)[index].all()
        assert not free_floor(seen, body.footprint, body.mount_height).all()  # it decides
        assert camera_side(seen)[index].all()
        assert not camera_side(seen).all()  # it decides
        dist = np.hypot(to[:, 0], to[:, 1])
        if method == "ring":
            standoff = ring_standoff(body, float(pred.target_xyz[2]))
            assert abs(dist[0] - standoff) < 2 * BAND
            assert (shoulder_distance(body, dist, pred.target_xyz[2]) <= body.reach).all()
        else:
            reach = ReachabilityMap.for_robot(ep.robot, inputs["mount_height"])
            ok = [reach.reachable_from(xy, pred.target_xyz, a) for a in grasp_approaches(seen)]
            assert np.any(ok, axis=0).all()
            _ik_reaches(ep.robot, inputs["mount_height"], pred.poses[0], pred.target_xyz, seen)


def _ik_reaches(robot, mount, pose, target, seen):
    """IK reaches the target from the best pose by one of the frame's approaches."""
    from momakitchen.bullet import connect_direct, p
    from momakitchen.robots.robot import Robot
    from momakitchen.sim.sampling import approach_quaternion

    client = connect_direct()
    try:
        arm = Robot(client, robot, pose, mount_height=mount)
        u = np.array([math.cos(pose[2]), math.sin(pose[2])])
        radial = (target[:2] - pose[:2]) / np.linalg.norm(target[:2] - pose[:2])
        solved = []
        for a in grasp_approaches(seen):
            a = np.array([u[0], u[1], 0.0]) if a is None else a
            quat = approach_quaternion(a, radial)
            solved.append(arm.solve_ik(target, quat, seed=arm.home).success)
        assert any(solved)
    finally:
        p.disconnect(client)


def test_place_is_deterministic(episodes, coarse_maps, monkeypatch, tmp_path):
    ep = episodes[-1]
    inputs = frame_of(ep)
    for method in CLASSICAL_METHODS:
        a = place(method, **inputs)
        # the map again from the disk cache, not memory
        monkeypatch.setattr(reachability, "_SAMPLED", {})
        monkeypatch.setattr(reachability, "_MAPS", {})
        b = place(method, **inputs)
        for field in ("floor_xyz", "affordance", "uncertainty", "poses", "pose_scores"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
        assert a.to_dict() == b.to_dict()
    # files in, as predict takes them: the same answer
    np.save(tmp_path / "depth.npy", inputs["depth"])
    np.save(tmp_path / "target.npy", inputs["target_mask"])
    np.savetxt(tmp_path / "tf.txt", inputs["camera_to_base"])
    from_files = place(
        "ring",
        **{
            **inputs,
            "depth": tmp_path / "depth.npy",
            "target_mask": tmp_path / "target.npy",
            "camera_to_base": tmp_path / "tf.txt",
        },
    )
    np.testing.assert_array_equal(from_files.poses, place("ring", **inputs).poses)


def test_ring_takes_a_robot_by_its_numbers(episodes):
    inputs = {**frame_of(episodes[-1]), "mount_height": None}
    pred = place("ring", **{**inputs, "robot": {"reach": 0.8, "mount_height": 1.0}}, top_k=2)
    assert (pred.robot, pred.model) == ("custom", "ring") and pred.poses.shape == (2, 3)


def _one_line_error(match, *args, **kwargs):
    with pytest.raises(MomaError, match=match) as info:
        place(*args, **kwargs)
    assert "\n" not in str(info.value)


def test_bad_input_is_a_one_line_error(episodes):
    inputs = frame_of(episodes[-1])
    _one_line_error(r"'rings'.*known: ring, reachability", "rings", **inputs)
    _one_line_error("top_k", "ring", **inputs, top_k=0)
    _one_line_error("pick_radius", "ring", **inputs, pick_radius=2.0)
    numbers = {**inputs, "robot": {"reach": 0.8, "mount_height": 1.0}, "mount_height": None}
    _one_line_error("needs a registered robot", "reachability", **numbers)
    _one_line_error("carries its own mount height", "ring", **{**numbers, "mount_height": 1.0})
    _one_line_error("nosuchbot", "ring", **{**inputs, "robot": "nosuchbot"})
    _one_line_error("mount", "ring", **{**inputs, "mount_height": 3.0})
    empty = np.zeros_like(inputs["target_mask"])
    _one_line_error("target mask is empty", "ring", **{**inputs, "target_mask": empty})
    _one_line_error("does not match", "ring", **{**inputs, "target_mask": empty[1:]})
    _one_line_error("millimetres", "ring", **{**inputs, "depth": inputs["depth"] * 1000})
