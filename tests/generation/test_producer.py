import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.data.config import GenerationConfig
from momakitchen.data.episode import SEMANTIC_CLASSES
from momakitchen.frames import transform
from momakitchen.generation.producer import configuration_episodes
from momakitchen.generation.render import render
from momakitchen.perception.camera import Intrinsics, backproject, look_at, project
from momakitchen.perception.clouds import voxel_downsample
from momakitchen.scene.configuration import sample_scene
from momakitchen.sim.world import World


@pytest.fixture(scope="module")
def scene():
    return sample_scene(12)


@pytest.fixture(scope="module")
def world(scene):
    w = World(scene.layout)
    w.load_configuration(scene.configurations[0])
    yield w
    w.close()


def test_project_backproject_round_trip():
    intr = Intrinsics.from_fov(640, 480, 45.0)
    rng = np.random.default_rng(0)
    pts = np.stack(
        [rng.uniform(-1, 1, 100), rng.uniform(-1, 1, 100), rng.uniform(0.5, 5, 100)], axis=1
    )
    uv = project(pts, intr)
    assert np.allclose(intr.fx * pts[:, 0] / pts[:, 2] + intr.cx, uv[:, 0])
    # Back-project a depth image holding one point per pixel centre.
    depth = np.zeros((480, 640), np.float32)
    col, row = 100, 200
    depth[row, col] = 2.0
    cam_pts, idx = backproject(depth, intr)
    assert idx.tolist() == [row * 640 + col]
    assert np.allclose(project(cam_pts, intr), [[col, row]])


def test_rendered_depth_backprojects_onto_the_surfaces(world):
    """Pixels back-projected from the rendered depth land where a ray through the pixel
    centre hits the scene (within 1 mm)."""
    intr = Intrinsics.for_renderer(320, 240, 45.0)
    cam = look_at(np.array([2.5, 3.0, 1.4]), np.array([2.0, 0.4, 0.8]))
    frame = render(world.client, cam, intr)
    pts_cam, idx = backproject(frame.depth, intr)
    pts = transform(cam, pts_cam)
    sel = np.random.default_rng(1).choice(len(pts), 200, replace=False)
    v, u = np.divmod(idx[sel], intr.width)
    rays = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones(len(sel))], axis=1)
    ends = transform(cam, rays * 20.0)
    starts = np.repeat(cam[:3, 3][None], len(sel), axis=0)
    hits = p.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=world.client)
    hit_pts = np.array([h[3] for h in hits])
    err = np.linalg.norm(hit_pts - pts[sel], axis=1)
    # Rays hit collision shapes, the renderer draws tessellated visual shapes: a few
    # silhouette pixels and curved surfaces differ by millimetres, the rest is exact.
    assert np.median(err) < 1e-4 and np.mean(err < 1e-3) > 0.9


def test_voxel_downsample_keeps_one_point_per_voxel():
    pts = np.array([[0.001, 0, 0], [0.004, 0, 0], [0.011, 0, 0], [0.0, 0.0, 0.05]])
    keep = voxel_downsample(pts, 0.01)
    assert keep.tolist() == [0, 2, 3]


@pytest.fixture(scope="module")
def episodes(world, scene):
    cfg = scene.configurations[2]
    config = GenerationConfig()
    return cfg, configuration_episodes(world, scene.layout, cfg, config)


def test_episodes_are_well_formed(episodes):
    cfg, (labels, eps) = episodes
    assert len(eps) == 10
    assert labels.trial_outcomes.sum() > 0
    dists = [
        np.hypot(e.base_pose[0] - cfg.target.anchor[0], e.base_pose[1] - cfg.target.anchor[1])
        for e in eps
    ]
    assert dists[-1] > dists[0], "viewpoints move away from the target"
    for e in eps:
        e.validate()
        assert e.depth.shape == (480, 640)
        assert np.all(e.floor_xyz[:, 2] < 0.02)
        assert np.all((e.floor_label >= 0) & (e.floor_label <= 1))
        # The camera sits at the robot's mount height + 0.3 m above the base origin.
        assert e.camera_to_base[2, 3] == pytest.approx(1.33)
    assert any(e.floor_label.max() > 0.5 for e in eps)


def test_target_channel_covers_the_target(episodes):
    cfg, (_, eps) = episodes
    for e in eps:
        assert (e.semantic == SEMANTIC_CLASSES.index("target")).sum() >= 20
        tgt = e.global_xyz[e.global_align == 1]
        assert len(tgt) > 0
        # Target points lie on the target: near the grasp point, in the base frame.
        world_to_base = np.linalg.inv(_base(e.base_pose))
        anchor = transform(world_to_base, np.array([cfg.target.anchor]))[0]
        assert np.median(np.linalg.norm(tgt - anchor, axis=1)) < 0.2


def _base(pose):
    from momakitchen.frames import base_to_world

    return base_to_world(pose)


def test_every_view_sees_floor_near_a_success(episodes):
    """Feasible configuration: each view's floor cloud comes within 10 cm of a successful
    trial position, and the target sits high in the image (the floor in front of it is
    in view)."""
    from momakitchen.generation.producer import sees_near

    _, (labels, eps) = episodes
    successes = labels.trial_positions[labels.trial_stages == 0]
    assert len(successes) > 0
    for e in eps:
        assert sees_near(e.floor_xyz, e.base_pose, successes, 0.10)
        rows = np.nonzero(e.semantic == SEMANTIC_CLASSES.index("target"))[0]
        assert np.median(rows) < 0.35 * e.depth.shape[0]


def test_look_toward_puts_the_target_on_the_requested_row():
    from momakitchen.perception.camera import look_toward

    intr = Intrinsics.from_fov(640, 480, 45.0)
    target = np.array([1.0, 2.0, 0.9])
    for row in (0.15, 0.5, 0.8):
        cam = look_toward(np.array([3.0, 4.0, 1.3]), target, intr, row)
        u, v = project(transform(np.linalg.inv(cam), target[None]), intr)[0]
        assert u == pytest.approx(intr.cx, abs=1e-6)
        assert v == pytest.approx(row * intr.height, abs=1e-6)


def test_views_stay_within_a_sensors_working_range(world, scene):
    """``generate --sensor kinect``: every camera within the range of the target (the views
    would otherwise reach 3.8 m ahead and 1.5 m aside)."""
    import dataclasses

    from momakitchen.generation.producer import sample_views

    cfg = scene.configurations[2]
    base = GenerationConfig()
    config = dataclasses.replace(
        base, views=dataclasses.replace(base.views, episodes=4, max_distance=2.5, coverage_radius=0)
    )
    views = sample_views(world, scene.layout, cfg, config)
    assert len(views) == 4
    anchor = np.asarray(cfg.target.anchor)
    for v in views:
        assert np.linalg.norm(v.camera_to_world[:3, 3] - anchor) <= 2.5 + 1e-9


def test_view_distance_bounds():
    from momakitchen.data.config import ViewConfig
    from momakitchen.errors import MomaError

    with pytest.raises(MomaError, match=r"views\.max_distance must be 0"):
        ViewConfig(max_distance=0.5)
    with pytest.raises(MomaError, match=r"views\.distance must be \(0, 0\) \(off\) or"):
        ViewConfig(distance=(0.2, 6.0))
    with pytest.raises(MomaError, match=r"views\.max_angle must be in \[0, 90\]"):
        ViewConfig(distance=(1.0, 6.0), max_angle=120.0)
    # off by default, and then left out of a dataset's manifest (its bytes stay)
    assert "distance" not in GenerationConfig().to_dict()["views"]


def test_views_by_distance_stand_as_far_and_as_turned_as_asked():
    """``views.distance``: the k-th view's distance stratified over the range, increasing
    with k, its direction within ``max_angle`` of the target's front."""
    from momakitchen.data.config import ViewConfig
    from momakitchen.generation.producer import _view_candidates

    views = ViewConfig(episodes=10, distance=(0.75, 6.0), max_angle=45.0)
    rng = np.random.default_rng(0)
    anchor = np.zeros(3)
    for k in range(10):
        for _ in range(20):
            lateral, forward = _view_candidates(rng, anchor, k, 10, views)
            dist = np.hypot(lateral, forward)
            assert 0.75 + 0.525 * k - 1e-9 <= dist <= 0.75 + 0.525 * (k + 1) + 1e-9
            assert forward > 0 and abs(lateral) <= forward + 1e-9  # within 45 degrees
            assert np.sign(lateral) in (0.0, 1.0 if k % 2 == 0 else -1.0)


def test_far_share_bounds():
    from momakitchen.data.config import ViewConfig
    from momakitchen.errors import MomaError

    with pytest.raises(MomaError, match=r"views\.far_share must be in \[0, 1\], got 1\.5"):
        ViewConfig(distance=(0.75, 6.0), far_share=1.5)
    with pytest.raises(MomaError, match=r"views\.far_share needs views\.distance on"):
        ViewConfig(far_share=0.4)  # placed by forward / lateral: no distance to share
    with pytest.raises(MomaError, match=r"far_from 7\.0, distance \(0\.75, 6\.0\)"):
        ViewConfig(distance=(0.75, 6.0), far_share=0.4, far_from=7.0)
    # off by default, and then left out of a dataset's manifest (its bytes stay)
    views = GenerationConfig().to_dict()["views"]
    assert "far_share" not in views and "far_from" not in views


def test_far_view_points_stand_where_asked(scene):
    from momakitchen.data.config import ViewConfig
    from momakitchen.generation.producer import far_view_points
    from momakitchen.scene.configuration import base_fits

    views = ViewConfig(distance=(0.75, 6.0), max_angle=45.0, far_share=0.4)
    cfg = scene.configurations[0]
    footprint = (0.6, 0.5)
    pts = far_view_points(scene.layout, cfg, views, footprint, 1.5)
    assert len(pts) > 10
    rel = pts - np.asarray(cfg.target.anchor)[:2]
    dist = np.hypot(rel[:, 0], rel[:, 1])
    assert dist.min() >= 3.8 and dist.max() <= 6.0
    assert np.all(np.diff(dist) >= 0)  # nearest first
    assert np.all(np.abs(rel[:, 0]) <= rel[:, 1] + 1e-9)  # within 45 degrees of the front
    assert base_fits(scene.layout, cfg, pts, footprint).all()  # the plan's own rule agrees
    # a sensor that sees 4 m leaves only the points within its range
    near = far_view_points(
        scene.layout, cfg, replace_views(views, max_distance=4.0), footprint, 1.5
    )
    assert 0 < len(near) < len(pts)
    # none where the room is not that deep
    assert (
        len(far_view_points(scene.layout, cfg, replace_views(views, far_from=5.9), footprint, 1.5))
        == 0
    )


def replace_views(views, **changes):
    import dataclasses

    return dataclasses.replace(views, **changes)


def test_far_share_puts_the_last_views_far_where_the_room_allows(world, scene):
    """``views.far_share``: 2 of 5 views 3.8 m or more away (the last two), the others
    below 3.8 m; with 0.8, 4 of 5."""
    import dataclasses

    from momakitchen.data.config import ViewConfig
    from momakitchen.generation.producer import sample_views

    cfg = scene.configurations[0]
    anchor = np.asarray(cfg.target.anchor)[:2]
    base = GenerationConfig()

    def distances(**far) -> np.ndarray:
        views = ViewConfig(episodes=5, distance=(0.75, 6.0), coverage_radius=0, **far)
        out = sample_views(world, scene.layout, cfg, dataclasses.replace(base, views=views))
        assert len(out) == 5
        return np.array([np.hypot(*(np.asarray(v.base[:2]) - anchor)) for v in out])

    far = distances(far_share=0.4)
    assert np.all(far[:3] < 3.8) and np.all(far[3:] >= 3.8)
    assert np.all(np.diff(far[:3]) > 0)  # the near ones stratified, increasing
    assert (distances(far_share=0.8) >= 3.8).sum() == 4
