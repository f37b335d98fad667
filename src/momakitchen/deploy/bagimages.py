"""Decoding a bag's images: ``sensor_msgs/Image`` (any ``step``, either byte order) and
``sensor_msgs/CompressedImage`` (JPEG, PNG, or a 16UC1 ``compressedDepth`` PNG) into the
arrays :func:`momakitchen.predict` takes: depth in metres, RGB, boolean masks."""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from momakitchen.deploy.bagread import COMPRESSED
from momakitchen.errors import MomaError

DEPTH_ENCODINGS = ("16UC1", "mono16", "32FC1")
RGB_ENCODINGS = ("rgb8", "bgr8", "rgba8", "bgra8", "mono8")
MASK_ENCODINGS = ("mono8", "8UC1", "mono16", "16UC1")


def image_array(msg: Any, topic: str) -> np.ndarray:
    """The pixels of a ``sensor_msgs/Image`` as (H, W) or (H, W, C), honouring ``step``
    (row padding) and ``is_bigendian``."""
    enc = msg.encoding
    layouts = {
        "rgb8": (np.uint8, 3),
        "bgr8": (np.uint8, 3),
        "rgba8": (np.uint8, 4),
        "bgra8": (np.uint8, 4),
        "mono8": (np.uint8, 1),
        "8UC1": (np.uint8, 1),
        "mono16": (np.uint16, 1),
        "16UC1": (np.uint16, 1),
        "32FC1": (np.float32, 1),
    }
    if enc not in layouts:
        raise MomaError(f"topic {topic!r}: unknown image encoding {enc!r}")
    dtype, channels = layouts[enc]
    h, w = int(msg.height), int(msg.width)
    item = np.dtype(dtype).itemsize
    row = w * channels * item
    data = np.asarray(msg.data, np.uint8).reshape(-1)
    if h == 0 or w == 0 or msg.step < row or data.size < msg.step * (h - 1) + row:
        raise MomaError(
            f"topic {topic!r}: image data of {data.size} bytes does not hold {w}x{h} "
            f"{enc} pixels with step {msg.step}"
        )
    rows = np.lib.stride_tricks.as_strided(data, (h, row), (msg.step, 1))
    stored = np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<")
    pixels = np.ascontiguousarray(rows).view(stored)
    pixels = pixels.reshape(h, w, channels).astype(dtype)
    return pixels[..., 0] if channels == 1 else pixels


def compressed_array(msg: Any, topic: str) -> np.ndarray:
    """Decode a ``CompressedImage`` (JPEG / PNG, or a 16UC1 ``compressedDepth`` PNG)."""
    from PIL import Image, UnidentifiedImageError

    fmt = str(msg.format)
    data = bytes(np.asarray(msg.data, np.uint8))
    if "compresseddepth" in fmt.lower().replace(" ", ""):
        if not fmt.lower().startswith(("16uc1", "mono16")) or "png" not in fmt.lower():
            raise MomaError(
                f"topic {topic!r}: compressed depth format {fmt!r} is not supported "
                "(use raw 16UC1 / 32FC1 images or '16UC1; compressedDepth png')"
            )
        data = data[12:]  # compressed_depth_image_transport's config header
    try:
        with Image.open(io.BytesIO(data)) as img:
            if img.format not in ("JPEG", "PNG"):
                raise MomaError(f"topic {topic!r}: compressed image is {img.format}, not JPEG/PNG")
            if img.mode in ("RGBA", "P", "LA", "CMYK", "YCbCr"):
                return np.array(img.convert("RGB"))
            return np.array(img)
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError) as exc:
        raise MomaError(
            f"topic {topic!r}: cannot decode compressed image (format {fmt!r}): {exc}"
        ) from None


def depth_metres(msg: Any, msgtype: str, topic: str) -> np.ndarray:
    """(H, W) float32 metres from a depth message; 0 and NaN are invalid."""
    if msgtype == COMPRESSED:
        img = compressed_array(msg, topic)
        if img.dtype not in (np.uint16, np.int32) or img.ndim != 2:
            raise MomaError(f"topic {topic!r}: a compressed depth image must be a 16-bit PNG")
        return img.astype(np.float32) / 1000.0
    if msg.encoding not in DEPTH_ENCODINGS:
        raise MomaError(
            f"depth topic {topic!r} has encoding {msg.encoding!r}; expected 16UC1 "
            "(millimetres, 0 = invalid) or 32FC1 (metres, NaN = invalid)"
        )
    img = image_array(msg, topic)
    return img.astype(np.float32) / (1000.0 if img.dtype == np.uint16 else 1.0)


def colour_rgb(msg: Any, msgtype: str, topic: str) -> np.ndarray:
    """(H, W, 3) uint8 RGB from a colour message (rgb8, bgr8, rgba8, bgra8, mono8, JPEG,
    PNG)."""
    if msgtype == COMPRESSED:
        img = compressed_array(msg, topic)
        if img.dtype != np.uint8:
            raise MomaError(f"topic {topic!r}: compressed colour image is not 8-bit")
        return np.ascontiguousarray(np.stack([img] * 3, -1) if img.ndim == 2 else img[..., :3])
    if msg.encoding not in RGB_ENCODINGS:
        raise MomaError(
            f"colour topic {topic!r} has encoding {msg.encoding!r}; expected one of "
            f"{', '.join(RGB_ENCODINGS)} or a CompressedImage"
        )
    img = image_array(msg, topic)
    if img.ndim == 2:
        return np.ascontiguousarray(np.stack([img] * 3, -1))
    if msg.encoding.startswith("bgr"):
        img = img[..., 2::-1]
    return np.ascontiguousarray(img[..., :3])


def mask_image(msg: Any, msgtype: str, topic: str) -> np.ndarray:
    """(H, W) bool from a mask message (mono8 / 8UC1 / mono16 / 16UC1 or a PNG; non-zero =
    inside)."""
    if msgtype == COMPRESSED:
        img = compressed_array(msg, topic)
    elif msg.encoding not in MASK_ENCODINGS:
        raise MomaError(
            f"mask topic {topic!r} has encoding {msg.encoding!r}; expected one of "
            f"{', '.join(MASK_ENCODINGS)}"
        )
    else:
        img = image_array(msg, topic)
    return (img.max(-1) if img.ndim == 3 else img) != 0
