"""What the classical methods read from a frame: free floor for the base's box, the
camera's side of the target, the approach the target's surface suggests."""

from __future__ import annotations

import numpy as np

from momakitchen.placement.observed import (
    ObservedFrame,
    camera_side,
    free_floor,
    grasp_approaches,
    target_normal,
)


def _frame(floor, points, target_points, camera=(0.0, 0.0, 1.0)):
    t = np.asarray(target_points, float)
    return ObservedFrame(
        floor_xyz=np.column_stack([np.asarray(floor, float), np.zeros(len(floor))]),
        points=np.asarray(points, float).reshape(-1, 3),
        target_points=t,
        target_xyz=np.median(t, axis=0),
        camera_xyz=np.asarray(camera, float),
        correction=None,  # type: ignore[arg-type]
    )


def test_free_floor_is_the_base_box_facing_the_target():
    target = [[3.0, 0.0, 0.9]]
    floor = [[2.0, 0.0], [2.0, 1.0], [1.0, 0.0]]
    # 0.3 m ahead of the first point: inside a 0.55 m long box (half 0.275 + 0.02 margin)
    # only if the box faces the target; 0.3 m to its side: outside a 0.45 m wide box.
    ahead = [[2.29, 0.0, 0.5]]
    assert list(free_floor(_frame(floor, ahead, target), (0.55, 0.45), 1.0)) == [
        False,
        True,
        True,
    ]
    side = [[2.0, 0.3, 0.5]]
    assert free_floor(_frame(floor, side, target), (0.55, 0.45), 1.0).all()
    # above the mount the base stands clear of it (a wall cabinet)
    assert free_floor(_frame(floor, [[2.2, 0.0, 1.5]], target), (0.55, 0.45), 1.0).all()


def test_camera_side_is_the_half_plane_facing_the_camera():
    frame = _frame([[1.0, 0.0], [2.5, 2.0], [3.5, 0.0]], [], [[3.0, 0.0, 0.9]])
    assert list(camera_side(frame)) == [True, True, False]


def test_the_targets_surface_gives_the_approach():
    rng = np.random.default_rng(0)
    u, v = rng.uniform(-0.15, 0.15, (2, 200))
    # a door front facing the camera at 45 degrees: approached against its normal
    n = np.array([-1.0, -1.0, 0.0]) / np.sqrt(2)
    side = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    front = np.array([2.0, 2.0, 0.8]) + u[:, None] * side + v[:, None] * [0, 0, 1]
    frame = _frame([[0.0, 0.0]], [], front)
    np.testing.assert_allclose(target_normal(frame), n, atol=1e-9)
    (a,) = grasp_approaches(frame)
    np.testing.assert_allclose(a, -n, atol=1e-9)
    # a board lying flat: from above
    top = np.array([2.0, 0.0, 0.9]) + np.column_stack([u, v, np.zeros(200)])
    (a,) = grasp_approaches(_frame([[0.0, 0.0]], [], top))
    np.testing.assert_allclose(a, [0, 0, -1])
    # a blob (a mug): horizontal from the base, or from above
    blob = np.array([2.0, 0.0, 0.9]) + rng.normal(0, 0.04, (200, 3))
    side_on, above = grasp_approaches(_frame([[0.0, 0.0]], [], blob))
    assert side_on is None and above is not None
    np.testing.assert_allclose(above, [0, 0, -1])


def test_isolated_points_above_the_floor_are_no_obstacle(monkeypatch):
    import momakitchen.perception.footprint as observed

    monkeypatch.setattr(observed, "OBSTACLE_NEIGHBOURS", 3)
    # a chair leg: a column of points 2 cm apart; a stray point (far floor noise, a
    # flying pixel) on its own
    leg = [[2.0, 0.0, z] for z in np.arange(0.04, 0.4, 0.02)]
    stray = [[1.0, 1.0, 0.06]]
    kept = observed.supported(np.array(leg + stray))
    # the leg stays (its two ends, with fewer neighbours, may go)
    assert len(kept) >= len(leg) - 2 and (kept[:, :2] == [2.0, 0.0]).all()
    assert not (kept[:, :2] == [1.0, 1.0]).all(axis=1).any()
    # two stray points together are still too few
    assert len(observed.supported(np.array([[0.0, 0.0, 0.1], [0.0, 0.03, 0.1]]))) == 0
