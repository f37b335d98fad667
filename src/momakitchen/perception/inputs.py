"""What one RGB-D frame's prediction reads, loaded and checked: depth, masks, RGB, the
camera's intrinsics and pose, and the robot (a registered name or a descriptor).

Shared by the learned path (:func:`momakitchen.predict`) and the classical base placement
methods (:func:`momakitchen.placement.place`), so that both take the same inputs, in
the same forms, and refuse the same bad ones with the same one-line messages.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.fileio import existing_file
from momakitchen.perception.camera import Intrinsics

# A median depth above this (m) is millimetres passed as metres.
MILLIMETRE_HINT = 30.0


# ------------------------------------------------------------------------------ inputs
def load_depth(depth: np.ndarray | str | os.PathLike) -> np.ndarray:
    """Depth in metres (H, W) float32 from an array, a ``.npy`` file (metres) or a 16-bit
    PNG (millimetres). Invalid pixels stay 0 or NaN (they are skipped later)."""
    if isinstance(depth, (str, os.PathLike)):
        path = existing_file(depth, "depth file")
        if path.suffix.lower() == ".npy":
            depth = _load_npy(path, "depth")
        elif path.suffix.lower() == ".png":
            img = _load_png(path, "depth")
            if img.dtype != np.uint16:
                raise MomaError(
                    f"depth PNG {str(path)!r} must be 16-bit (millimetres), got {img.dtype}"
                )
            depth = img.astype(np.float32) / 1000.0
        else:
            raise MomaError(f"depth file {str(path)!r}: use .npy (metres) or 16-bit .png (mm)")
    arr = np.asarray(depth, dtype=np.float32)
    if arr.ndim != 2:
        raise MomaError(f"depth must be an (H, W) image, got shape {arr.shape}")
    return arr


def load_mask(mask: np.ndarray | str | os.PathLike, name: str) -> np.ndarray:
    """A boolean (H, W) mask from an array, ``.npy`` or image file (non-zero = inside)."""
    if isinstance(mask, (str, os.PathLike)):
        path = existing_file(mask, f"{name} file")
        mask = _load_npy(path, name) if path.suffix.lower() == ".npy" else _load_png(path, name)
    arr = np.asarray(mask)
    if arr.ndim == 3:  # an RGB(A) mask image
        arr = arr[..., :3].max(-1)
    if arr.ndim != 2:
        raise MomaError(f"{name} must be an (H, W) mask, got shape {arr.shape}")
    return arr != 0


def load_rgb(rgb: np.ndarray | str | os.PathLike) -> np.ndarray:
    if isinstance(rgb, (str, os.PathLike)):
        path = existing_file(rgb, "rgb file")
        rgb = _load_npy(path, "rgb") if path.suffix.lower() == ".npy" else _load_png(path, "rgb")
    arr = np.asarray(rgb)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise MomaError(f"rgb must be an (H, W, 3) image, got shape {arr.shape}")
    if arr.dtype != np.uint8:
        arr = np.clip(np.asarray(arr, np.float64) * (255 if arr.max() <= 1.0 else 1), 0, 255)
        arr = arr.round().astype(np.uint8)
    return np.ascontiguousarray(arr[..., :3])


def _load_npy(path: Path, name: str) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError) as exc:
        raise MomaError(f"{name} file {str(path)!r} is not a readable .npy array ({exc})") from exc


def _load_png(path: Path, name: str) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            return np.array(img)
    except (UnidentifiedImageError, OSError) as exc:
        raise MomaError(f"{name} file {str(path)!r} is not a readable image ({exc})") from exc


def load_intrinsics(
    intrinsics: Sequence[float] | Intrinsics, shape: tuple[int, int], image: str = "depth image"
) -> Intrinsics:
    """Pinhole intrinsics ``(fx, fy, cx, cy)`` in pixels (or an ``Intrinsics``) for an image
    of ``shape`` (H, W); ``image`` names that image in errors."""
    h, w = shape
    if isinstance(intrinsics, Intrinsics):
        intr = intrinsics
    else:
        k = np.asarray(intrinsics, np.float64).reshape(-1)
        if k.shape != (4,):
            raise MomaError(f"intrinsics must be fx, fy, cx, cy; got {k.size} numbers")
        intr = Intrinsics(float(k[0]), float(k[1]), float(k[2]), float(k[3]), w, h)
    if (intr.height, intr.width) != (h, w):
        raise MomaError(
            f"intrinsics are for {intr.width}x{intr.height} images but the {image} is {w}x{h}"
        )
    return intr


def load_extrinsics(tf: np.ndarray | str | os.PathLike) -> np.ndarray:
    """A rigid camera-to-base transform (4, 4) from an array, ``.npy`` or text file (OpenCV
    camera axes: x right, y down, z forward)."""
    if isinstance(tf, (str, os.PathLike)):
        path = existing_file(tf, "extrinsics file")
        try:
            tf = (
                _load_npy(path, "extrinsics")
                if path.suffix.lower() == ".npy"
                else np.loadtxt(path, dtype=np.float64)
            )
        except ValueError as exc:
            raise MomaError(f"extrinsics file {str(path)!r}: {exc}") from exc
    m = np.asarray(tf, dtype=np.float64)
    if m.shape != (4, 4) or not np.isfinite(m).all():
        raise MomaError(f"extrinsics must be a finite 4x4 matrix, got shape {m.shape}")
    r = m[:3, :3]
    if (
        np.abs(r.T @ r - np.eye(3)).max() > 1e-3
        or abs(np.linalg.det(r) - 1) > 1e-3
        or np.abs(m[3] - [0, 0, 0, 1]).max() > 1e-9
    ):
        raise MomaError(
            "extrinsics are not a rigid transform (rotation must be orthonormal "
            "with determinant 1, last row 0 0 0 1)"
        )
    return m


def robot_input(
    robot: str | tuple[str, float] | Sequence[float] | Mapping[str, float],
) -> tuple[str, np.ndarray]:
    """A robot name from the registry, or a descriptor: ``{"reach", "mount_height"}`` (plus
    optional ``"dof"`` (6), ``"suction"`` (False), ``"finger_force"`` (N per finger, 40),
    ``"shoulder_rise"`` (m above the mount, 0.25) and ``"shoulder_offset"`` (m off the first
    joint's axis, 0)) or the descriptor vector (of the current layout, or of an older one,
    whose missing columns then take those defaults), or ``(name, mount_height)``: a
    registered robot at another mount (m). Returns the name ("custom" for a descriptor)
    and the descriptor, shape ``(DESCRIPTOR_DIM,)``."""
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import (
        DEFAULT_FINGER_FORCE,
        DEFAULT_SHOULDER_OFFSET,
        DEFAULT_SHOULDER_RISE,
        DESCRIPTOR_DIM,
        FORCE_RANGE,
        descriptor_dim,
        descriptor_values,
        get_robot_spec,
    )

    if isinstance(robot, str):
        return robot, np.asarray(robot_descriptor(get_robot_spec(robot)), np.float32)
    if isinstance(robot, tuple) and len(robot) == 2 and isinstance(robot[0], str):
        from momakitchen.robots.urdf import mounted

        spec = get_robot_spec(robot[0])
        mount = float(mounted(spec, float(robot[1])).mount_height)  # checks the range
        return robot[0], np.asarray(robot_descriptor(spec, mount), np.float32)
    if isinstance(robot, Mapping):
        missing = {"reach", "mount_height"} - set(robot)
        if missing:
            raise MomaError(f"robot descriptor needs {sorted(missing)}")
        lo_f, hi_f = FORCE_RANGE
        for key, lo, hi, unit in (
            ("reach", 0.2, 3.0, "m"),
            ("mount_height", 0.0, 3.0, "m"),
            ("dof", 3, 10, "joints"),
            ("finger_force", lo_f, hi_f, "N"),
            ("shoulder_rise", 0.0, 1.0, "m"),
            ("shoulder_offset", 0.0, 0.5, "m"),
        ):
            if key not in robot:
                continue
            value = float(robot[key])
            if not (np.isfinite(value) and lo <= value <= hi):  # named here, not as a vector
                raise MomaError(f"robot {key} must be in [{lo:g}, {hi:g}] {unit}, got {robot[key]}")
        vec = list(
            descriptor_values(
                robot["reach"],
                robot["mount_height"],
                float(robot.get("dof", 6)),
                bool(robot.get("suction", False)),
                float(robot.get("finger_force", DEFAULT_FINGER_FORCE)),
                float(robot.get("shoulder_rise", DEFAULT_SHOULDER_RISE)),
                float(robot.get("shoulder_offset", DEFAULT_SHOULDER_OFFSET)),
            )
        )
    else:
        vec = list(robot)
        if len(vec) in (descriptor_dim(1), descriptor_dim(2)):  # an older vector
            values = np.asarray(vec, np.float64)
            if np.isfinite(values).all():
                reach, mount, dof_7, suction = values[:4]
                grip = values[4] * 100 if len(vec) > 4 else DEFAULT_FINGER_FORCE
                vec = list(descriptor_values(reach, mount, dof_7 * 7.0, bool(suction >= 0.5), grip))
    d = np.asarray(vec, np.float32)
    if (
        d.shape != (DESCRIPTOR_DIM,)
        or not np.isfinite(d).all()
        or not (0.2 <= d[0] <= 3.0 and 0 <= d[1] <= 3.0)
    ):
        raise MomaError(
            f"robot descriptor must be {DESCRIPTOR_DIM} finite numbers with reach "
            f"in [0.2, 3] m and mount height in [0, 3] m, got {vec}"
        )
    return "custom", d


@dataclass(frozen=True)
class FrameArrays:
    """One frame's inputs, loaded and checked (:func:`load_frame`).

    Shapes: ``depth`` (H, W) float32 metres; ``valid`` (H, W) bool (finite and > 0);
    ``camera_to_base`` (4, 4); ``target_mask`` and each of ``obstacle_masks`` (H, W)
    bool; ``rgb`` (H, W, 3) uint8 (mid-grey when none was given).
    """

    depth: np.ndarray
    valid: np.ndarray
    intrinsics: Intrinsics
    camera_to_base: np.ndarray
    target_mask: np.ndarray
    obstacle_masks: tuple[np.ndarray, ...]
    rgb: np.ndarray


def load_frame(
    depth: np.ndarray | str | os.PathLike,
    intrinsics: Sequence[float] | Intrinsics,
    camera_to_base: np.ndarray | str | os.PathLike,
    target_mask: np.ndarray | str | os.PathLike,
    obstacle_masks: Sequence[np.ndarray | str | os.PathLike] = (),
    rgb: np.ndarray | str | os.PathLike | None = None,
) -> FrameArrays:
    """A frame's inputs in the forms :func:`momakitchen.predict` takes them, loaded and
    checked: every image the depth's size, at least one valid depth pixel, depth in
    metres (MomaError names the problem)."""
    d = load_depth(depth)
    h, w = d.shape
    intr = load_intrinsics(intrinsics, (h, w))
    tf = load_extrinsics(camera_to_base)
    masks = {"target mask": load_mask(target_mask, "target mask")}
    for i, m in enumerate(obstacle_masks):
        masks[f"obstacle mask {i}"] = load_mask(m, f"obstacle mask {i}")
    image = load_rgb(rgb) if rgb is not None else np.full((h, w, 3), 128, np.uint8)
    for name, m in [*masks.items(), ("rgb", image[..., 0])]:
        if m.shape != (h, w):
            raise MomaError(f"{name} shape {m.shape} does not match the depth image {(h, w)}")
    valid = np.isfinite(d) & (d > 0)
    if not valid.any():
        raise MomaError("the depth image has no valid pixel (all 0 or NaN)")
    typical = float(np.median(d[valid]))
    if typical > MILLIMETRE_HINT:  # no indoor scene is tens of metres deep
        raise MomaError(
            f"the depth looks like millimetres (median {typical:g}): give metres, or a "
            "16-bit PNG in millimetres"
        )
    target = masks.pop("target mask")
    return FrameArrays(d, valid, intr, tf, target, tuple(masks.values()), image)
