"""The checks every selected frame of a bag passes before the model runs on any of them.

:class:`~momakitchen.deploy.bagframes.BagFrames` runs these on each frame it selects, on
the decoded images, so that a bad frame late in a recording (an empty mask, a dropped
depth image, a resized stream, a camera info without a focal length) is a one-line error
naming its topic and frame before the first prediction, not after hours of them. They
repeat, on decoded arrays, what :func:`momakitchen.predict` would refuse later.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from momakitchen.deploy.predict import MILLIMETRE_HINT
from momakitchen.errors import MomaError


def intrinsics_of(info: Any, topic: str) -> tuple[float, float, float, float]:
    """``(fx, fy, cx, cy)`` from a ``sensor_msgs/CameraInfo``'s ``K`` (row-major 3x3)."""
    k = np.asarray(info.k, np.float64).reshape(-1)
    if k.shape != (9,) or not np.isfinite(k).all():
        raise MomaError(f"camera info on {topic!r} has a K that is not 9 finite numbers ({k})")
    if not (k[0] > 0 and k[4] > 0):
        raise MomaError(f"camera info on {topic!r} has no focal length (K={k.tolist()})")
    return float(k[0]), float(k[4]), float(k[2]), float(k[5])


def check_frame_images(
    parts: Mapping[str, np.ndarray],
    sources: Mapping[str, str],
    info_shape: tuple[int, int],
    info_topic: str,
) -> None:
    """Check one frame's decoded images against each other and its camera info.

    Args:
        parts: role -> array: ``"depth"`` (H, W) float metres (0 or NaN invalid), ``"rgb"``
            (H, W, 3) uint8, ``"target mask"`` and ``"obstacle mask i"`` (H, W) bool.
        sources: role -> where it came from, as errors name it (``"on '/topic'"``).
        info_shape: (height, width) the camera info states; (0, 0): unstated.
        info_topic: the camera info's topic.
    """
    depth = parts["depth"]
    h, w = depth.shape
    if info_shape not in ((h, w), (0, 0)):
        raise MomaError(
            f"camera info on {info_topic!r} is for {info_shape[1]}x{info_shape[0]} images "
            f"but the depth image {sources['depth']} is {w}x{h}"
        )
    for role, array in parts.items():
        if array.shape[:2] != (h, w):
            name = "colour image" if role == "rgb" else role
            raise MomaError(
                f"the {name} {sources[role]} is {array.shape[1]}x{array.shape[0]}, "
                f"the depth image {w}x{h}"
            )
    valid = np.isfinite(depth) & (depth > 0)
    if not valid.any():
        raise MomaError(f"the depth image {sources['depth']} has no valid pixel (all 0 or NaN)")
    typical = float(np.median(depth[valid]))
    if typical > MILLIMETRE_HINT:  # no indoor scene is tens of metres deep
        raise MomaError(
            f"the depth image {sources['depth']} looks like millimetres (median {typical:g}) "
            "published as 32FC1 metres"
        )
    target = parts.get("target mask")
    if target is not None:
        n = int(target.sum())
        if n == 0:
            raise MomaError(f"the target mask {sources['target mask']} is empty (0 pixels)")
        if not (target & valid).any():
            raise MomaError(
                f"the target mask {sources['target mask']} has {n} pixels but none with a "
                "valid depth (the target may be beyond the depth sensor's range)"
            )
