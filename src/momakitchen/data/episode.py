"""The episode record: one first-person view of a configuration with everything a model,
an evaluation or a rebuild of the world needs. Produced by
:func:`momakitchen.generation.producer.configuration_episodes`, stored by the dataset
writer, read back by the dataset reader and the torch Dataset.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

# Per-pixel semantic classes of ``Episode.semantic`` (stored as uint8).
SEMANTIC_CLASSES = ("other", "target", "obstacle", "furniture", "object", "floor", "wall", "robot")


@dataclass(frozen=True)
class ConfigurationLabels:
    """Configuration-level data shared by its episodes (world frame).

    Shapes: ``trial_positions`` (P, 2) float64 world xy of the trial grid;
    ``trial_yaws`` (P,) float64; ``trial_stages`` (P,) uint8 (0 = success, see
    ``momakitchen.sim.trials.Stage``); ``trial_moved`` (P,) float32. ``mount_height``: the
    arm's mount height in metres where the configuration drew one (None: the robot's own).
    """

    scene_id: int
    config_index: int
    robot: str
    target: str  # category, with the part for articulated targets ("fridge/door")
    anchor: tuple[float, float, float]  # world grasp point of the target at rest
    trial_positions: np.ndarray
    trial_yaws: np.ndarray
    trial_stages: np.ndarray
    trial_moved: np.ndarray
    mount_height: float | None = None

    @property
    def trial_outcomes(self) -> np.ndarray:
        return (self.trial_stages == 0).astype(np.uint8)

    @property
    def feasible(self) -> bool:
        """Whether some trial of the grid succeeded (else no base position is known to
        work: the configuration stays in the data, flagged)."""
        return bool(np.any(self.trial_stages == 0))


@dataclass(frozen=True)
class Episode:
    """One first-person RGB-D view and its point clouds.

    Frames: ``camera_pose`` is camera-to-world (OpenCV camera axes: x right, y down,
    z forward); ``base_pose`` is the viewpoint robot's base ``(x, y, yaw)`` in the world;
    ``camera_to_base`` (4, 4) maps camera coordinates to that base frame (x forward,
    y left, z up, z = 0 on the floor). Point clouds are in the base frame.

    Shapes (H x W image, Ng global points, Nf floor points):
      ``rgb`` (H, W, 3) uint8; ``depth`` (H, W) float32 metres along the optical axis
      (0 = no return); ``semantic`` (H, W) uint8 indices into ``SEMANTIC_CLASSES``;
      ``intrinsics`` (4,) float64 ``fx, fy, cx, cy``;
      ``global_xyz`` (Ng, 3) float32; ``global_rgb`` (Ng, 3) uint8;
      ``global_align`` (Ng,) int8 in {-1 obstacle, 0 other, +1 target};
      ``floor_xyz`` (Nf, 3) float32 with z ~ 0; ``floor_label`` (Nf,) float32 in [0, 1].
    """

    scene_id: int
    config_index: int
    episode_index: int
    robot: str
    descriptor: np.ndarray  # (D,) float32, momakitchen.robots.robot_descriptor
    rgb: np.ndarray
    depth: np.ndarray
    semantic: np.ndarray
    intrinsics: np.ndarray
    camera_pose: np.ndarray
    base_pose: tuple[float, float, float]
    camera_to_base: np.ndarray
    global_xyz: np.ndarray
    global_rgb: np.ndarray
    global_align: np.ndarray
    floor_xyz: np.ndarray
    floor_label: np.ndarray

    def validate(self) -> None:
        """Check shapes, dtypes and ranges; raise MomaError naming the bad field."""
        h, w = self.depth.shape if self.depth.ndim == 2 else (-1, -1)
        checks = {
            "rgb": self.rgb.shape == (h, w, 3) and self.rgb.dtype == np.uint8,
            "depth": self.depth.ndim == 2 and bool(np.all(np.isfinite(self.depth))),
            "semantic": self.semantic.shape == (h, w),
            "intrinsics": self.intrinsics.shape == (4,),
            "camera_pose": self.camera_pose.shape == (4, 4),
            "camera_to_base": self.camera_to_base.shape == (4, 4),
            "global_xyz": self.global_xyz.ndim == 2 and self.global_xyz.shape[1:] == (3,),
            "global_rgb": self.global_rgb.shape == self.global_xyz.shape,
            "global_align": self.global_align.shape == self.global_xyz.shape[:1]
            and set(np.unique(self.global_align)) <= {-1, 0, 1},
            "floor_xyz": self.floor_xyz.ndim == 2 and self.floor_xyz.shape[1:] == (3,),
            "floor_label": self.floor_label.shape == self.floor_xyz.shape[:1]
            and bool(np.all((self.floor_label >= 0) & (self.floor_label <= 1))),
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise MomaError(
                f"episode {self.scene_id}/{self.config_index}/{self.episode_index}:"
                f" malformed field(s) {bad}"
            )


def stored_frame(arrays: Mapping[str, np.ndarray]) -> Any:
    """An episode's render as a :class:`~momakitchen.perception.sensors.Frame` (the true
    camera pose; target and obstacle masks from the semantic image), from its stored
    ``depth``, ``rgb``, ``semantic``, ``intrinsics`` and ``camera_to_base``."""
    from momakitchen.perception.camera import Intrinsics
    from momakitchen.perception.sensors import Frame

    sem = arrays["semantic"]
    fx, fy, cx, cy = (float(v) for v in arrays["intrinsics"])
    return Frame(
        depth=np.asarray(arrays["depth"], np.float32),
        rgb=arrays["rgb"],
        target_mask=sem == SEMANTIC_CLASSES.index("target"),
        obstacle_masks=(sem == SEMANTIC_CLASSES.index("obstacle"),),
        intrinsics=Intrinsics(fx, fy, cx, cy, int(sem.shape[1]), int(sem.shape[0])),
        camera_to_base=np.asarray(arrays["camera_to_base"], np.float64),
    )


def episode_frame(episode: Episode) -> Any:
    """A stored :class:`Episode`'s render as a
    :class:`~momakitchen.perception.sensors.Frame` (:func:`stored_frame`)."""
    names = ("depth", "rgb", "semantic", "intrinsics", "camera_to_base")
    return stored_frame({n: getattr(episode, n) for n in names})
