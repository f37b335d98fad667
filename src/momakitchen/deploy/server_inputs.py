"""The inputs of ``momakitchen serve``'s ``POST /predict``: uploaded arrays and images
checked from their headers before they are decoded, and every field checked and turned
into :func:`momakitchen.predict`'s arguments (MomaError naming the bad field or value,
which the server answers as a 4xx)."""

from __future__ import annotations

import io
import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from momakitchen.errors import MomaError

MAX_PIXELS = 4096 * 4096  # per image; a 16 Mpx frame takes about 2 GB to predict
MAX_OBSTACLE_MASKS = 16
# Parts of one form: every field once and 16 obstacle masks make 36, so more is not a frame
# (and each part costs the parser work before any field is checked).
MAX_FIELDS = 64
MAX_TEXT_BYTES = 4096  # one text field: 16 numbers of camera_to_base are ~300 bytes
REQUIRED = ("depth", "target_mask", "intrinsics", "camera_to_base")
FILES = ("depth", "target_mask", "rgb", "obstacle_mask")
# name -> (type, least, greatest); the top_k and pick_radius ranges are predict's own
NUMBERS: dict[str, tuple[type, float, float]] = {
    "top_k": (int, 1, 50),
    "mc_samples": (int, 0, 64),
    "pick_radius": (float, 0.0, 1.0),
    "min_spread": (float, 0.0, 5.0),
}
TEXT = (
    "intrinsics",
    "camera_to_base",
    "robot",
    "reach",
    "mount_height",
    "dof",
    "suction",
    "finger_force",
    "shoulder_rise",
    "shoulder_offset",
    "floor_points",
    "opens",
)
# With reach and mount_height, optional: the rest of a robot given by its numbers.
ROBOT_NUMBERS = ("dof", "finger_force", "shoulder_rise", "shoulder_offset")
FIELDS = (*FILES, *NUMBERS, *TEXT)


def _npy_header(data: bytes, name: str) -> tuple[tuple[int, ...], np.dtype, int]:
    """Shape, dtype and data offset of an uploaded ``.npy``, from its header only."""
    fmt = np.lib.format
    f = io.BytesIO(data)
    try:
        version = fmt.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(f)
        elif version == (2, 0):
            shape, _, dtype = fmt.read_array_header_2_0(f)
        else:  # 3.0 only adds UTF-8 field names, i.e. structured arrays
            raise ValueError(f"unsupported .npy format version {version}")
    except (ValueError, OSError, EOFError, SyntaxError) as exc:
        raise MomaError(f"field {name!r} is not a readable .npy array ({exc})") from None
    if dtype.kind not in "biuf" or dtype.fields is not None or dtype.subdtype is not None:
        raise MomaError(
            f"field {name!r} is a .npy of dtype {str(dtype)[:60]}: give a bool, integer or "
            "float array"
        )
    return tuple(shape), dtype, f.tell()


def array_header(data: bytes, name: str) -> tuple[tuple[int, ...], str]:
    """The shape ((H, W) or (H, W, C)) and format (``"npy"`` or ``"image"``) of an uploaded
    ``.npy``, PNG or JPEG file, read from its header without decoding it; MomaError names
    a file that is unreadable, of another kind, not numbers, or over :data:`MAX_PIXELS`."""
    if data.startswith(b"\x93NUMPY"):
        shape, dtype, offset = _npy_header(data, name)
        kind = "npy"
    elif data.startswith((b"\x89PNG", b"\xff\xd8")):
        from PIL import Image, UnidentifiedImageError

        try:
            with warnings.catch_warnings():  # the size is checked below, against a lower limit
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                with Image.open(io.BytesIO(data)) as img:  # reads the header only
                    w, h = img.size
                    shape = (h, w) if len(img.getbands()) == 1 else (h, w, len(img.getbands()))
        except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError) as exc:
            raise MomaError(f"field {name!r} is not a readable image ({exc})") from None
        except ValueError as exc:
            raise MomaError(f"field {name!r} is not a readable image ({exc})") from None
        kind = "image"
    else:
        raise MomaError(f"field {name!r} must be a PNG, JPEG or .npy file")
    if len(shape) not in (2, 3) or (len(shape) == 3 and not 1 <= shape[2] <= 4):
        raise MomaError(f"field {name!r} must be an (H, W) or (H, W, C) image, got {shape}")
    h, w = shape[:2]
    if h * w > MAX_PIXELS:
        raise MomaError(
            f"field {name!r} is {w}x{h} = {h * w} pixels, over the limit of {MAX_PIXELS} "
            "(4096x4096)"
        )
    if kind == "npy" and len(data) < offset + math.prod(shape) * dtype.itemsize:
        raise MomaError(
            f"field {name!r} is a truncated .npy: its header says {shape} {dtype}, "
            f"{offset + math.prod(shape) * dtype.itemsize} bytes; the upload has {len(data)}"
        )
    return shape, kind


def decode_array(data: bytes, name: str) -> tuple[np.ndarray, str]:
    """An array and its format (``"npy"`` or ``"image"``) from an uploaded ``.npy``, PNG
    or JPEG file, after :func:`array_header`'s checks."""
    kind = array_header(data, name)[1]
    if kind == "npy":
        try:
            return np.load(io.BytesIO(data), allow_pickle=False), "npy"
        except (ValueError, OSError, EOFError) as exc:
            raise MomaError(f"field {name!r} is not a readable .npy array ({exc})") from None
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data)) as img:
                return np.array(img), "image"
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError) as exc:
        raise MomaError(f"field {name!r} is not a readable image ({exc})") from None
    except ValueError as exc:
        raise MomaError(f"field {name!r} is not a readable image ({exc})") from None


def _numbers(text: str, name: str, count: int) -> list[float]:
    words = text.replace(",", " ").split()
    try:
        values = [float(v) for v in words]
    except ValueError:
        raise MomaError(f"field {name!r} must be {count} numbers, got {text[:80]!r}") from None
    if len(values) != count:
        raise MomaError(
            f"field {name!r} must be {count} finite numbers, got {len(values)}: {text[:80]!r}"
        )
    for word, value in zip(words, values, strict=True):
        if not math.isfinite(value):
            raise MomaError(
                f"field {name!r} must be {count} finite numbers, got {word[:20]!r} in {text[:80]!r}"
            )
    return values


def _option(name: str, text: str) -> int | float:
    """A numeric option's value, checked against :data:`NUMBERS`."""
    kind, lo, hi = NUMBERS[name]
    try:
        value: int | float = kind(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and lo <= value <= hi):
        what = "an integer" if kind is int else "a finite number (m)"
        raise MomaError(f"field {name!r} must be {what} in [{lo:g}, {hi:g}], got {text[:40]!r}")
    return value


def check_fields(
    files: Mapping[str, list[bytes]], text: Mapping[str, str]
) -> tuple[dict[str, Any], bool]:
    """Every check of a request that needs no decoding: the field names and counts, the
    numbers, and each file's header (:func:`array_header`: format, dtype, size, the depth
    image's size). Returns the keyword arguments of :func:`momakitchen.predict` other
    than the arrays, and whether the answer includes the floor points. MomaError names a
    bad field."""
    unknown = sorted((set(files) | set(text)) - set(FIELDS))
    if unknown:
        raise MomaError(f"unknown field {unknown[0]!r}; the fields are {', '.join(FIELDS)}")
    for name in REQUIRED:
        if name not in files and name not in text:
            raise MomaError(f"missing field {name!r}")
    for name in files:
        if name not in FILES:
            raise MomaError(f"field {name!r} must be text, not a file")
    for name in FILES:
        if name in text:
            raise MomaError(f"field {name!r} must be a file upload")
        if name != "obstacle_mask" and len(files.get(name, [])) > 1:
            raise MomaError(f"field {name!r} is given more than once")
    if len(files.get("obstacle_mask", [])) > MAX_OBSTACLE_MASKS:
        raise MomaError(
            f"field 'obstacle_mask' is given {len(files['obstacle_mask'])} times, more than "
            f"{MAX_OBSTACLE_MASKS}: merge some of the masks"
        )
    size = array_header(files["depth"][0], "depth")[0][:2]
    for name, data in _images(files):
        if name != "depth":
            shape = array_header(data, name)[0]
            if shape[:2] != size:
                raise MomaError(
                    f"field {name!r} is {shape[1]}x{shape[0]}: it does not match the depth "
                    f"image ({size[1]}x{size[0]})"
                )
    kwargs: dict[str, Any] = {
        "intrinsics": _numbers(text["intrinsics"], "intrinsics", 4),
        "camera_to_base": np.reshape(
            _numbers(text["camera_to_base"], "camera_to_base", 16), (4, 4)
        ),
    }
    if "robot" in text:
        if "reach" in text:
            raise MomaError("give either 'robot' or 'reach' and 'mount_height', not both")
        kwargs["robot"] = text["robot"]
        if "mount_height" in text:  # a registered robot at a drawn mount height
            from momakitchen.robots.spec import mount_height_problem

            mount = _numbers(text["mount_height"], "mount_height", 1)[0]
            problem = mount_height_problem(mount)
            if problem:
                raise MomaError(f"field {problem}")
            kwargs["mount_height"] = mount
    elif "reach" in text and "mount_height" in text:
        robot: dict[str, Any] = {
            "reach": _numbers(text["reach"], "reach", 1)[0],
            "mount_height": _numbers(text["mount_height"], "mount_height", 1)[0],
        }
        for name in ROBOT_NUMBERS:
            if name in text:
                robot[name] = _numbers(text[name], name, 1)[0]
        if "suction" in text:
            if text["suction"] not in ("0", "1"):
                raise MomaError(f"suction must be 0 or 1, got {text['suction'][:20]!r}")
            robot["suction"] = text["suction"] == "1"
        kwargs["robot"] = robot
    else:
        raise MomaError("missing field 'robot' (or both 'reach' and 'mount_height')")
    for name in NUMBERS:
        if name in text:
            kwargs[name] = _option(name, text[name])
    opens = text.get("opens", "0")
    if opens not in ("0", "1"):
        raise MomaError(f"field 'opens' must be 0 or 1, got {opens[:40]!r}")
    kwargs["opens"] = opens == "1"
    floor = text.get("floor_points", "1")
    if floor not in ("0", "1"):
        raise MomaError(f"field 'floor_points' must be 0 or 1, got {floor[:40]!r}")
    return kwargs, floor == "1"


def _images(files: Mapping[str, list[bytes]]) -> list[tuple[str, bytes]]:
    """The uploaded files with the names errors give them."""
    out = [(name, files[name][0]) for name in ("depth", "target_mask", "rgb") if name in files]
    return out + [(f"obstacle_mask {i}", b) for i, b in enumerate(files.get("obstacle_mask", []))]


def predict_arguments(
    files: Mapping[str, list[bytes]], text: Mapping[str, str]
) -> tuple[dict[str, Any], bool]:
    """The keyword arguments of :func:`momakitchen.predict` from a request's fields, and
    whether the answer includes the floor points (:func:`check_fields`, then the images
    decoded). MomaError names a bad field."""
    from momakitchen.deploy.predict import load_depth

    kwargs, floor = check_fields(files, text)
    depth, kind = decode_array(files["depth"][0], "depth")
    if kind == "image":
        if depth.dtype != np.uint16:
            raise MomaError(f"depth PNG must be 16-bit (millimetres), got {depth.dtype}")
        depth = depth.astype(np.float32) / 1000.0
    kwargs["depth"] = load_depth(depth)
    kwargs["target_mask"] = _finite(decode_array(files["target_mask"][0], "target_mask")[0])
    kwargs["obstacle_masks"] = [
        _finite(decode_array(b, f"obstacle_mask {i}")[0], f"obstacle_mask {i}")
        for i, b in enumerate(files.get("obstacle_mask", []))
    ]
    if "rgb" in files:
        kwargs["rgb"] = _finite(decode_array(files["rgb"][0], "rgb")[0], "rgb")
    return kwargs, floor


def _finite(array: np.ndarray, name: str = "target_mask") -> np.ndarray:
    """``array`` if it holds no NaN or infinity (a float colour image or mask full of NaN
    would become some colour or mask silently); MomaError naming the field otherwise. The
    depth is not checked: there NaN means no reading."""
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        bad = array[~np.isfinite(array)]
        raise MomaError(
            f"field {name!r} holds {bad.size} non-finite values (e.g. {bad.flat[0]}): "
            "give finite numbers"
        )
    return array


# ---------------------------------------------------------------------------- the app
