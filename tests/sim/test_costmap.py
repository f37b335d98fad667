"""The free space's layers: the static one (room and furniture), and obstacles added as
points are observed, blocking what the floor plan blocks."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import _facing_bases, base_fits, sample_scene
from momakitchen.scene.geometry import corners_of
from momakitchen.sim.motion import FreeSpace, MotionConfig


@pytest.fixture(scope="module")
def scene():
    scene = sample_scene(7)
    cfg = scene.configurations[0]
    assert len(cfg.obstacles) == 2  # a chair and a bin in front of the target
    return scene, cfg, get_robot_spec(cfg.robot).footprint


def _on(footprint, spacing: float = 0.01) -> np.ndarray:
    """Points (K, 2) covering a footprint, its edges included, ``spacing`` apart."""
    u = np.linspace(-0.5, 0.5, int(np.ceil(footprint.length / spacing)) + 1) * footprint.length
    v = np.linspace(-0.5, 0.5, int(np.ceil(footprint.width / spacing)) + 1) * footprint.width
    gu, gv = (a.ravel() for a in np.meshgrid(u, v))
    c, s = np.cos(footprint.yaw), np.sin(footprint.yaw)
    return np.stack([footprint.x + c * gu - s * gv, footprint.y + s * gu + c * gv], 1)


def _points(cfg) -> np.ndarray:
    return np.concatenate([_on(o.footprint()) for o in cfg.obstacles])


def _near_obstacles(cfg, cells: np.ndarray, radius: float = 1.0) -> np.ndarray:
    xy = np.array([(o.footprint().x, o.footprint().y) for o in cfg.obstacles])
    return (np.hypot(*(cells[:, None] - xy[None]).transpose(2, 0, 1)) < radius).any(1)


def test_default_is_the_floor_plan_with_its_obstacles(scene):
    scene, cfg, footprint = scene
    motion = MotionConfig()
    free = FreeSpace(scene.layout, cfg, footprint, motion)
    # As built before there were layers: the furniture's and the obstacles' boxes.
    blocked = corners_of(scene.layout.footprints() + [o.footprint() for o in cfg.obstacles])
    anchor = cfg.target.anchor

    def fits(size):
        return _facing_bases(free.cells, anchor, size, blocked, scene.layout.room)[1]

    grow = 2 * motion.clearance
    np.testing.assert_array_equal(free.free, fits(footprint))
    roomy = fits((footprint[0] + grow, footprint[1] + grow))
    np.testing.assert_array_equal(free.cost, np.where(roomy, 1.0, motion.clearance_cost))
    np.testing.assert_array_equal(
        free.free, base_fits(scene.layout, cfg, free.cells, footprint, include_obstacles=True)
    )
    again = FreeSpace(scene.layout, cfg, footprint, motion, obstacles=True)
    for name in ("plan", "length"):
        a, b = free._graphs[name], again._graphs[name]
        for part in ("indptr", "indices", "data"):
            np.testing.assert_array_equal(getattr(a, part), getattr(b, part))
    assert not free.observed.any()


def test_the_static_layer_is_free_where_an_obstacle_stands(scene):
    scene, cfg, footprint = scene
    full = FreeSpace(scene.layout, cfg, footprint, MotionConfig())
    static = FreeSpace(scene.layout, cfg, footprint, MotionConfig(), obstacles=False)
    np.testing.assert_array_equal(
        static.free, base_fits(scene.layout, cfg, static.cells, footprint, include_obstacles=False)
    )
    assert not (full.free & ~static.free).any()  # obstacles only take free cells away
    for o in cfg.obstacles:
        fp = o.footprint()
        assert not full.is_free(fp.x, fp.y)
        around = np.hypot(*(static.cells - (fp.x, fp.y)).T) < 0.5
        assert (static.free & ~full.free & around).sum() > 10
    chair = cfg.obstacles[0].footprint()  # away from the counter
    assert static.is_free(chair.x, chair.y)
    assert (full.cost >= static.cost).all() and (full.cost > static.cost).any()


def test_observed_points_block_what_the_obstacles_block(scene):
    scene, cfg, footprint = scene
    full = FreeSpace(scene.layout, cfg, footprint, MotionConfig())
    space = FreeSpace(scene.layout, cfg, footprint, MotionConfig(), obstacles=False)
    before = space.free.copy()
    plan_graph = space._graphs["plan"]
    points = _points(cfg)
    assert space.observe(points) is True
    near = _near_obstacles(cfg, space.cells)
    assert near.sum() > 500
    assert (space.free[near] == full.free[near]).mean() >= 0.95
    assert (space.cost[near] == full.cost[near]).mean() >= 0.95
    assert not (space.free & ~before).any()  # observing never frees a cell
    assert space.observed.any() and not (space.observed & space.free).any()
    # Observed again (or a subset, or nothing): nothing changes, nothing is rebuilt.
    plan_graph = space._graphs["plan"]
    free, cost = space.free.copy(), space.cost.copy()
    assert space.observe(points) is False
    assert space.observe(points[::7]) is False
    assert space.observe(np.zeros((0, 2))) is False
    assert space.observe(np.full((3, 2), np.nan)) is False
    assert space._graphs["plan"] is plan_graph
    np.testing.assert_array_equal(space.free, free)
    np.testing.assert_array_equal(space.cost, cost)


def test_a_point_blocks_the_cells_whose_box_holds_it(scene):
    scene, cfg, footprint = scene
    space = FreeSpace(scene.layout, cfg, footprint, MotionConfig(), obstacles=False)
    before = space.free.copy()
    point = np.array([scene.layout.room.width / 2, scene.layout.room.depth - 1.2])
    assert space.observe(point[None])
    blocked = before & ~space.free
    # The exact test: a box centred on each cell, facing the target, holds the point.
    fps, _ = _facing_bases(
        space.cells, cfg.target.anchor, footprint, np.zeros((0, 4, 2)), scene.layout.room
    )
    e = fps[:, 1:3] - fps[:, 0:2]  # two edges per box; the point is inside all four sides
    side = np.einsum("nkd,nkd->nk", point - fps[:, 0:2], e)
    far = np.einsum("nkd,nkd->nk", e, e)
    inside = ((side > 0) & (side < far)).all(1)
    np.testing.assert_array_equal(blocked, before & inside)
    assert blocked.sum() > 50  # a 0.55 x 0.45 m box holds ~100 cells of 5 cm


def test_planning_after_observing_avoids_the_obstacle(scene):
    scene, cfg, footprint = scene
    full = FreeSpace(scene.layout, cfg, footprint, MotionConfig())
    space = FreeSpace(scene.layout, cfg, footprint, MotionConfig(), obstacles=False)
    start = (scene.layout.room.width / 2, scene.layout.room.depth - 0.6)
    reach = full.reachable(start)
    near = _near_obstacles(cfg, full.cells, 1.5)
    # A goal the floor plan reaches, whose path on the static layer alone runs through
    # an obstacle.
    for i in np.flatnonzero(full.free & near):
        goal = tuple(full.cells[i])
        blind = space.plan(start, goal) if reach(*goal) else None
        if blind is not None and not all(full.is_free(x, y) for x, y in blind):
            break
    else:
        pytest.fail("no goal whose static-layer path crosses an obstacle")
    components = space.components
    assert space.observe(_points(cfg))
    assert space.components is not components  # made again from the new graph
    path = space.plan(start, goal)
    assert path is not None
    assert all(space.is_free(x, y) for x, y in path)
    assert base_fits(scene.layout, cfg, path, footprint).all()  # clear of the obstacles
    assert len(path) >= len(blind)
