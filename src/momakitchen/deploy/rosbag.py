""":func:`momakitchen.predict` on the frames of a recorded ROS 2 bag, and the fusion of
their maps in the odometry frame.

The reading is split by responsibility, and every name stays importable from here:

- :mod:`momakitchen.deploy.bagread`: opening a bag, its message types, header stamps;
- :mod:`momakitchen.deploy.bagimages`: decoding images (depth, colour, masks);
- :mod:`momakitchen.deploy.bagtf`: the TF tree and lookups at a stamp;
- :mod:`momakitchen.deploy.bagchecks`: the checks of every selected frame;
- :mod:`momakitchen.deploy.bagframes`: selecting, pairing and yielding the frames;
- :mod:`momakitchen.deploy.bagoutputs`: ``predict --bag``'s output directory.

Reading needs the ``robot`` extra (``rosbags``).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from momakitchen.deploy.bagframes import BagFrame, BagFrames, BagTopics, read_bag_frames
from momakitchen.deploy.bagimages import (
    DEPTH_ENCODINGS,
    MASK_ENCODINGS,
    RGB_ENCODINGS,
    colour_rgb,
    depth_metres,
    image_array,
    mask_image,
)
from momakitchen.deploy.bagread import (
    CAMERA_INFO,
    COMPRESSED,
    IMAGE,
    TF_MESSAGE,
    TF_TOPICS,
    check_bag_path,
    typestore,
)
from momakitchen.deploy.bagtf import (
    TF_EDGE_TOLERANCE,
    TransformBuffer,
    planar_pose,
    transform_matrix,
)
from momakitchen.errors import MomaError

if TYPE_CHECKING:
    from momakitchen.deploy.fusion import FusedGoal, MapFusion
    from momakitchen.models.inference import Prediction

__all__ = [
    "CAMERA_INFO",
    "COMPRESSED",
    "DEPTH_ENCODINGS",
    "IMAGE",
    "MASK_ENCODINGS",
    "RGB_ENCODINGS",
    "TF_EDGE_TOLERANCE",
    "TF_MESSAGE",
    "TF_TOPICS",
    "BagFrame",
    "BagFrames",
    "BagTopics",
    "TransformBuffer",
    "check_bag_path",
    "colour_rgb",
    "depth_metres",
    "fuse_frames",
    "image_array",
    "mask_image",
    "planar_pose",
    "predict_bag",
    "predict_frames",
    "read_bag_frames",
    "transform_matrix",
    "typestore",
]


def predict_frames(
    frames: Iterable[BagFrame],
    robot: Any = "panda",
    *,
    target_mask: Any = None,
    checkpoint: Any = None,
    **predict_options: Any,
) -> Iterator[tuple[BagFrame, Prediction]]:
    """:func:`momakitchen.predict` on each frame, as the frames come.

    ``target_mask`` (one (H, W) mask or mask file) serves every frame that has no mask of
    its own (a mask topic's, or :class:`BagFrames`' ``target_mask``); ``checkpoint`` and the
    mask are loaded here, once, before the first frame is read; ``predict_options``
    (``top_k``, ``mc_samples``, ...) go to :func:`momakitchen.predict` unchanged.
    """
    from momakitchen.deploy.predict import load_mask, predict
    from momakitchen.train.checkpoint import LoadedRun, default_checkpoint, load_checkpoint

    mask = load_mask(target_mask, "target mask") if target_mask is not None else None
    run = (
        checkpoint
        if isinstance(checkpoint, LoadedRun)
        else load_checkpoint(Path(checkpoint) if checkpoint is not None else default_checkpoint())
    )

    def each() -> Iterator[tuple[BagFrame, Prediction]]:
        for f in frames:
            target = f.target_mask if f.target_mask is not None else mask
            if target is None:
                raise MomaError(f"depth frame {f.index} has no target mask")
            try:
                pred = predict(
                    f.depth,
                    f.intrinsics,
                    f.camera_to_base,
                    target,
                    robot,
                    rgb=f.rgb,
                    obstacle_masks=f.obstacle_masks,
                    checkpoint=run,
                    **predict_options,
                )
            except MomaError as exc:
                raise MomaError(f"depth frame {f.index} at t={f.stamp:.3f} s: {exc}") from None
            yield f, pred

    return each()


def predict_bag(
    path: str | Path,
    topics: BagTopics,
    robot: Any = "panda",
    *,
    time: float | None = None,
    every: int | None = None,
    target_mask: Any = None,
    checkpoint: Any = None,
    **predict_options: Any,
) -> list[tuple[BagFrame, Prediction]]:
    """:func:`momakitchen.predict` on the selected depth frames of a bag: ``(frame,
    prediction)`` pairs in the bag's order.

    The target mask comes from ``topics.target_mask`` (a segmenter's image topic, paired
    by time) or ``target_mask`` (one (H, W) mask or mask file for every frame), not both.
    Every frame is checked before the first prediction. Other arguments as for
    :class:`BagFrames` and :func:`predict_frames`.
    """
    if (topics.target_mask is None) == (target_mask is None):
        raise MomaError("give the target mask either as a mask topic or as a mask, not both")
    with BagFrames(path, topics, time=time, every=every, target_mask=target_mask) as frames:
        preds = predict_frames(frames, robot, checkpoint=checkpoint, **predict_options)
        return sorted(preds, key=lambda fp: fp[0].index)


def fuse_frames(
    pairs: Iterable[tuple[BagFrame, Prediction]],
    *,
    cell: float = 0.05,
    pick_radius: float = 0.0,
) -> tuple[MapFusion, FusedGoal | None]:
    """Fuse the maps of ``(frame, prediction)`` pairs in the odometry frame.

    Each frame needs its ``odom_pose`` (read with ``BagTopics(odom_frame=...)``, which
    refuses odometry that jumps between consecutive frames further than a base drives:
    ``BagTopics.max_odom_speed``, 2 m/s, plus 0.5 m). Returns
    the :class:`~momakitchen.deploy.fusion.MapFusion` (its ``fused()`` cells are (M, 2)
    odometry-frame xy with (M,) affordance and uncertainty) and its goal: ``pose`` =
    (x, y, yaw) in the odometry frame facing the target, or None when no cell qualifies.
    ``pick_radius`` ranks the cells as :func:`momakitchen.predict` ranks poses.
    """
    from momakitchen.deploy.fusion import MapFusion

    fusion = MapFusion(cell=cell)
    for frame, pred in pairs:
        if frame.odom_pose is None:
            raise MomaError(
                f"depth frame {frame.index} has no odometry pose: read the bag with "
                "BagTopics(odom_frame=...)"
            )
        fusion.add(pred, frame.odom_pose)
    return fusion, fusion.goal(pick_radius=pick_radius)
