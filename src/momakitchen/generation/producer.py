"""The dataset producer: trials, first-person views, point clouds and labels of a scene.

For each configuration: run the trials (sparse labels), then place the viewing robot at
10 viewpoints in front of the target (alternately left and right of it, lateral offset
0-1.5 m, forward distance 1.5-3.8 m, increasing), render RGB, depth and segmentation from
its head camera (the configuration's mount height + 0.3 m, looking at the target), and
keep a viewpoint only if the target is visible. Each view becomes an
:class:`~momakitchen.data.episode.Episode`: point clouds in the viewpoint's base frame, the
visual-alignment channel from the segmentation, and the floor points with their dense
affordance labels.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from momakitchen.bullet import p
from momakitchen.data.config import GenerationConfig, ViewConfig
from momakitchen.data.coverage import sees_near
from momakitchen.data.episode import SEMANTIC_CLASSES, ConfigurationLabels, Episode
from momakitchen.data.generator import PRODUCERS, Producer
from momakitchen.data.manifest import KITCHEN
from momakitchen.frames import base_to_world, float3
from momakitchen.generation.render import Render, render
from momakitchen.perception.camera import look_toward
from momakitchen.perception.clouds import frame_clouds
from momakitchen.robots import get_robot_spec
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.scene.configuration import Configuration, sample_scene
from momakitchen.scene.geometry import box_corners, corners_of, overlap_matrix
from momakitchen.scene.layout import Layout, scene_rng
from momakitchen.sim.labels import Labels, floor_affordance, label_configuration
from momakitchen.sim.world import World

VIEW_STREAM = 3  # seed stream of the viewpoints (layout 0, configurations 1, colours 2)
_CLASS = {name: i for i, name in enumerate(SEMANTIC_CLASSES)}


def semantic_map(world: World, body: np.ndarray, link: np.ndarray) -> np.ndarray:
    """Per-pixel semantic class (uint8 indices into SEMANTIC_CLASSES) from segmentation.

    The target is the rigid object, or the moving part of an articulated unit (the link
    of the opened joint and the links attached below it, e.g. its handle).
    """
    out = np.zeros(body.shape, np.uint8)
    kind_class = {
        "furniture": "furniture",
        "appliance": "furniture",
        "rigid": "object",
        "obstacle": "obstacle",
    }
    for info in world.bodies.values():
        sel = body == info.body_id
        if not sel.any():
            continue
        if info.kind == "structure":
            out[sel] = _CLASS["floor" if info.uid == "floor" else "wall"]
        else:
            out[sel] = _CLASS[kind_class[info.kind]]
    t = world.target
    if t.is_articulated:
        parts = target_links(world)
        out[(body == t.body_id) & np.isin(link, parts)] = _CLASS["target"]
    else:
        out[body == t.body_id] = _CLASS["target"]
    return out


def target_links(world: World) -> list[int]:
    """Link indices of the target's moving part (the opened joint's link and its
    descendants)."""
    t = world.target
    c = world.client
    parents = {
        j: p.getJointInfo(t.body_id, j, physicsClientId=c)[16]
        for j in range(p.getNumJoints(t.body_id, physicsClientId=c))
    }
    links = []
    for j in parents:
        k = j
        while k >= 0 and k != t.joint_index:
            k = parents[k]
        if k == t.joint_index:
            links.append(j)
    return links


def _view_candidates(
    rng: np.random.Generator,
    anchor: np.ndarray,
    k: int,
    n: int,
    views: ViewConfig,
    span: tuple[float, float] | None = None,
) -> tuple[float, float]:
    """(lateral, forward) offsets for view ``k`` of ``n``: alternating sides, forward
    distance (or, with ``views.distance``, the distance, over ``span`` if given) stratified
    so that it increases with ``k``."""
    side = 1.0 if k % 2 == 0 else -1.0
    if views.distance[1] > 0:
        lo, hi = span or views.distance
        dist = lo + (hi - lo) * (k + rng.uniform()) / n
        angle = math.radians(rng.uniform(0.0, views.max_angle))
        return side * dist * math.sin(angle), dist * math.cos(angle)
    lo, hi = views.forward
    forward = lo + (hi - lo) * (k + rng.uniform()) / n
    lateral = side * rng.uniform(*views.lateral)
    return lateral, forward


FAR_CELL = 0.1  # m: spacing of the candidate far viewpoints


def _clear(fp: np.ndarray, blocked: np.ndarray, room) -> np.ndarray:
    """(N,) whether each base footprint (N, 4, 2) lies inside the room, 2 cm from its walls,
    clear of ``blocked`` (K, 4, 2)."""
    return (
        (fp.min(axis=(1, 2)) >= 0.02)
        & (fp[..., 0].max(axis=1) <= room.width - 0.02)
        & (fp[..., 1].max(axis=1) <= room.depth - 0.02)
        & ~overlap_matrix(fp, blocked).any(axis=1)
    )


def _blocked(layout: Layout, cfg: Configuration) -> np.ndarray:
    return corners_of(layout.footprints(0.02) + [o.footprint(0.02) for o in cfg.obstacles])


def far_view_points(
    layout: Layout,
    cfg: Configuration,
    views: ViewConfig,
    footprint: tuple[float, float],
    height: float,
) -> np.ndarray:
    """Floor points (M, 2), nearest first, where a view of ``cfg`` can stand
    ``views.far_from`` to ``views.distance[1]`` m from the target, within
    ``views.max_angle`` of its front, the viewing base (``footprint``, facing the target)
    in the room and clear of furniture and obstacles, and its camera (at ``height``) within
    ``views.max_distance`` of the target: ``views.far_share``'s "where the room holds
    such a viewpoint" (empty where it holds none). A grid of ``FAR_CELL``."""
    anchor = np.asarray(cfg.target.anchor, float)
    room = layout.room
    gx, gy = np.meshgrid(
        np.arange(0.0, room.width, FAR_CELL), np.arange(0.0, room.depth, FAR_CELL), indexing="ij"
    )
    pts = np.stack([gx.ravel(), gy.ravel()], 1)
    rel = pts - anchor[:2]
    dist = np.hypot(rel[:, 0], rel[:, 1])
    angle = np.degrees(np.arctan2(np.abs(rel[:, 0]), rel[:, 1]))  # from the front, +y
    ok = (dist >= views.far_from) & (dist <= views.distance[1]) & (angle <= views.max_angle)
    if views.max_distance:
        ok &= dist**2 + (height - anchor[2]) ** 2 <= views.max_distance**2
    pts, dist = pts[ok], dist[ok]
    if len(pts):
        yaws = np.arctan2(anchor[1] - pts[:, 1], anchor[0] - pts[:, 0])
        fp = box_corners(pts[:, 0], pts[:, 1], yaws, *footprint)
        keep = _clear(fp, _blocked(layout, cfg), room)
        pts, dist = pts[keep], dist[keep]
    return pts[np.argsort(dist, kind="stable")]


Clouds = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class View:
    """A kept viewpoint: the viewing robot's base pose ``(x, y, yaw)`` in the world, the
    camera-to-world transform (4, 4), the render, its semantic map (H, W) uint8 and the
    frame's clouds in the base frame (as :func:`frame_clouds` returns them)."""

    base: tuple[float, float, float]
    camera_to_world: np.ndarray
    frame: Render
    semantic: np.ndarray
    clouds: Clouds


def _clouds(view_base, camera_to_world, frame: Render, sem: np.ndarray, config) -> Clouds:
    camera_to_base = np.linalg.inv(base_to_world(view_base)) @ camera_to_world
    align_px = np.where(
        sem == _CLASS["target"], 1, np.where(sem == _CLASS["obstacle"], -1, 0)
    ).astype(np.int8)
    return frame_clouds(
        frame.depth,
        frame.rgb,
        align_px,
        config.camera.intrinsics,
        camera_to_base,
        config.cloud,
        config.camera.max_depth,
    )


def sample_views(
    world: World,
    layout: Layout,
    cfg: Configuration,
    config: GenerationConfig,
    successes: np.ndarray | None = None,
) -> list[View]:
    """Viewpoints of ``cfg`` where the target is visible, in order of increasing distance.

    A viewpoint must leave the viewing robot's footprint inside the room and clear of
    furniture and obstacles. Where the room is too shallow for the nominal distances, the
    forward range shrinks to what fits. With ``views.far_share``, the last views stand
    among :func:`far_view_points` where there are any. The head camera turns toward the
    target with the target high in the image (``views.target_row``). With ``successes``
    (S, 2), the world positions of successful trials, a view must also see floor within
    ``views.coverage_radius`` of one of them; after a view that does not, later attempts
    stand farther back.
    """
    spec = get_robot_spec(cfg.robot)
    views, cam = config.views, config.camera
    rng = scene_rng(cfg.scene_id, VIEW_STREAM, cfg.index)
    anchor = np.asarray(cfg.target.anchor, float)
    blocked = _blocked(layout, cfg)
    room = layout.room
    intr = cam.intrinsics
    height = cfg.mount + cam.above_mount  # the head camera rides on the arm's pillar
    goals = np.zeros((0, 2)) if successes is None else np.asarray(successes).reshape(-1, 2)
    check = len(goals) > 0 and views.coverage_radius > 0
    n = views.episodes
    far = np.zeros((0, 2))
    if views.far_share > 0:
        far = far_view_points(layout, cfg, views, spec.footprint, height)
    n_far = math.ceil(views.far_share * n - 1e-9) if len(far) else 0
    out = []
    for k in range(n):
        farther = False
        j = k - (n - n_far)  # this view's place among the far ones (< 0: not one)
        # its distance stratum of the far points (nearest first)
        stratum = ((j * len(far)) // n_far, -(-(j + 1) * len(far) // n_far)) if j >= 0 else None
        for attempt in range(views.max_tries):
            if stratum and attempt < views.max_tries // 2:
                # A far viewpoint: first from its stratum, then from any far point.
                lo, hi = stratum if attempt < views.max_tries // 4 else (0, len(far))
                x, y = (float(v) for v in far[rng.integers(lo, hi)])
            else:
                if j < 0 and n_far:  # stratified below far_from
                    span = (views.distance[0], views.far_from)
                    lateral, forward = _view_candidates(rng, anchor, k, n - n_far, views, span)
                else:
                    lateral, forward = _view_candidates(rng, anchor, k, n, views)
                if views.distance[1] > 0:
                    # By distance: farther back along the same direction. Later attempts
                    # come closer (the room may not hold the distance), slowly at first:
                    # each also turns another way, and a room too shallow ahead may be
                    # wide enough aside.
                    scale = rng.uniform(1.0, views.distance[1] / np.hypot(lateral, forward))
                    scale = scale if farther else 1.0
                    scale *= 1.0 - 0.5 * (attempt / views.max_tries) ** 2
                    lateral, forward = lateral * scale, forward * scale
                else:
                    if farther:  # the last view missed the successes: stand farther back
                        forward = rng.uniform(forward, views.forward[1])
                    # Later attempts come closer: the room may be shallower than the range.
                    forward *= 1.0 - 0.5 * attempt / views.max_tries
                if views.max_distance:  # within the sensor's working range of the target
                    reach2 = views.max_distance**2 - lateral**2 - (height - anchor[2]) ** 2
                    if reach2 < 0.5**2:
                        continue
                    forward = min(forward, float(np.sqrt(reach2)))
                x, y = anchor[0] + lateral, anchor[1] + forward
            yaw = float(np.arctan2(anchor[1] - y, anchor[0] - x))
            fp = box_corners(x, y, yaw, *spec.footprint)
            if not _clear(fp, blocked, room)[0]:
                continue
            base = (float(x), float(y), yaw)
            camera = look_toward(np.array([x, y, height]), anchor, intr, views.target_row)
            frame = render(world.client, camera, intr, cam.near, cam.far)
            sem = semantic_map(world, frame.body, frame.link)
            if int((sem == _CLASS["target"]).sum()) < views.min_target_pixels:
                continue
            clouds = _clouds(base, camera, frame, sem, config)
            if check and not sees_near(clouds[3], base, goals, views.coverage_radius):
                farther = True
                continue
            out.append(View(base, camera, frame, sem, clouds))
            break
    return out


def make_episode(
    layout: Layout,
    cfg: Configuration,
    labels: Labels,
    index: int,
    view: View,
    config: GenerationConfig,
) -> Episode:
    """Build the episode record of one view (clouds in the viewpoint's base frame)."""
    base, camera_to_world, frame = view.base, view.camera_to_world, view.frame
    camera_to_base = np.linalg.inv(base_to_world(base)) @ camera_to_world
    g_xyz, g_rgb, align, f_pts = view.clouds
    # Dense labels in the viewpoint's base frame, 0 where the base would not fit.
    f_label = floor_affordance(labels, layout, cfg, f_pts[:, :2], base, config.dense)
    spec = get_robot_spec(cfg.robot)
    return Episode(
        scene_id=cfg.scene_id,
        config_index=cfg.index,
        episode_index=index,
        robot=cfg.robot,
        descriptor=np.asarray(robot_descriptor(spec, cfg.mount_height), np.float32),
        rgb=frame.rgb,
        depth=frame.depth,
        semantic=view.semantic,
        intrinsics=config.camera.intrinsics.as_array(),
        camera_pose=camera_to_world,
        base_pose=float3(base),
        camera_to_base=camera_to_base,
        global_xyz=g_xyz.astype(np.float32),
        global_rgb=g_rgb,
        global_align=align,
        floor_xyz=f_pts.astype(np.float32),
        floor_label=f_label,
    )


def configuration_labels(labels: Labels) -> ConfigurationLabels:
    return ConfigurationLabels(
        scene_id=labels.scene_id,
        config_index=labels.config_index,
        robot=labels.robot,
        target=labels.target,
        anchor=float3(labels.anchor),
        trial_positions=labels.positions,
        trial_yaws=labels.yaws,
        trial_stages=labels.stages,
        trial_moved=labels.moved,
        mount_height=labels.mount_height,
    )


def configuration_episodes(
    world: World, layout: Layout, cfg: Configuration, config: GenerationConfig
) -> tuple[ConfigurationLabels, list[Episode]]:
    """Trials, then the first-person episodes of one configuration."""
    labels = label_configuration(
        world, cfg, trial_config=config.trial, grid_spacing=config.scene.grid_spacing
    )
    world.load_configuration(cfg)  # undo whatever the trials moved
    successes = labels.positions[labels.stages == 0]
    views = sample_views(world, layout, cfg, config, successes)
    episodes = [make_episode(layout, cfg, labels, i, v, config) for i, v in enumerate(views)]
    return configuration_labels(labels), episodes


def scene_records(
    scene_id: int,
    config: GenerationConfig | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[tuple[ConfigurationLabels, list[Episode]]]:
    """All configurations of scene ``scene_id`` with their episodes (deterministic).

    ``progress(done, total)``, if given, is called after each configuration (the
    generator's progress bar; it does not change the records)."""
    config = config or GenerationConfig()
    scene = sample_scene(scene_id, config.scene)
    records = []
    for cfg in scene.configurations:
        # A fresh world per configuration (~0.1 s): physics results depend, in the last
        # bits, on the order bodies were added and removed; this way they depend only on
        # (scene_id, configuration index, config).
        with World(scene.layout) as world:
            records.append(configuration_episodes(world, scene.layout, cfg, config))
        if progress is not None:
            progress(len(records), len(scene.configurations))
    return records


PRODUCERS.register(Producer(KITCHEN, scene_records, GenerationConfig))
