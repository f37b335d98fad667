"""What a real robot's frame does to a perfect render: depth-sensor noise, segmenter-mask
errors, calibration errors and colour (docs/SENSORS.md gives every preset's source).

A :class:`Frame` is what :func:`momakitchen.predict` takes; :func:`corrupt_frame` turns a
rendered frame into the frame a robot with a given sensor, segmenter and calibration would
see, deterministically for a given generator. The same models serve the robustness track
(fixed, named :data:`CORRUPTIONS`) and noise-aware training (:class:`SensorAugmentation`,
a random corruption per draw). Stored data always stay clean.

Conventions: depth in metres along the optical axis, 0 = no return; camera axes OpenCV
(x right, y down, z forward); ``camera_to_base`` (4, 4) maps camera to robot base frame.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import ndimage

from momakitchen.errors import MomaError
from momakitchen.perception.camera import Intrinsics

DEPTH_KINDS = ("ideal", "structured_light", "stereo", "tof", "monocular")


@dataclass(frozen=True)
class Frame:
    """One RGB-D frame with its masks and calibration, as a robot gives it.

    Shapes: ``depth`` (H, W) float32 metres (0 or NaN = invalid); ``rgb`` (H, W, 3) uint8;
    ``target_mask`` (H, W) bool; ``obstacle_masks`` tuple of (H, W) bool;
    ``camera_to_base`` (4, 4) float64, the *calibrated* transform.
    """

    depth: np.ndarray
    rgb: np.ndarray
    target_mask: np.ndarray
    obstacle_masks: tuple[np.ndarray, ...]
    intrinsics: Intrinsics
    camera_to_base: np.ndarray


@dataclass(frozen=True)
class DepthModel:
    """A depth sensor's errors (all lengths in metres).

    Attributes:
        kind: one of :data:`DEPTH_KINDS`; selects the axial noise law below.
        axial: structured light: ``sigma = a + b * (z - z0)**2``, as ``(a, b, z0)``;
            time of flight: ``sigma = a + b * z`` as ``(a, b, 0)``.
        baseline, subpixel: active stereo: disparity ``f * baseline / z`` gets Gaussian
            noise of ``subpixel`` px RMS, so depth RMS is ``z**2 * subpixel / (f * baseline)``.
        disparity_step: stereo disparity quantisation (px; 0: none).
        lateral_px: lateral noise: each pixel reads the depth of a neighbour offset by
            a Gaussian of this many pixels (structured light's dot pattern).
        range: working range ``(min, max)``; depth outside it reads 0.
        edge_holes, flying: at depth edges, the chance a pixel reads 0 (shadow, no match)
            or a mix of the two sides (mixed pixels); ``dropout``: the chance any pixel
            reads 0.
        offset, scale: per-frame systematic error: depth ``* (1 + U(-scale, scale)) +
            U(-offset, offset)``; monocular depth draws its scale error's sign at random
            and its size as ``scale`` exactly.
        warp: monocular: amplitude of a smooth multiplicative warp over the image.
        blur_px: monocular: Gaussian blur of the depth image (soft edges), pixels.
        quantum: output resolution (1 mm: a 16-bit millimetre PNG; 0: none).
    """

    kind: str = "ideal"
    axial: tuple[float, float, float] = (0.0, 0.0, 0.0)
    baseline: float = 0.0
    subpixel: float = 0.0
    disparity_step: float = 0.0
    lateral_px: float = 0.0
    range: tuple[float, float] = (0.0, math.inf)
    edge_holes: float = 0.0
    flying: float = 0.0
    dropout: float = 0.0
    offset: float = 0.0
    scale: float = 0.0
    warp: float = 0.0
    blur_px: float = 0.0
    quantum: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in DEPTH_KINDS:
            raise MomaError(f"DepthModel.kind must be one of {DEPTH_KINDS}, got {self.kind!r}")
        for name in ("edge_holes", "flying", "dropout"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise MomaError(f"DepthModel.{name} must be in [0, 1], got {getattr(self, name)}")
        for name in ("baseline", "subpixel", "disparity_step", "lateral_px", "offset", "scale"):
            if not 0.0 <= getattr(self, name) <= 10.0:
                raise MomaError(f"DepthModel.{name} must be in [0, 10], got {getattr(self, name)}")
        for name in ("warp", "blur_px", "quantum"):
            if not 0.0 <= getattr(self, name) <= 10.0:
                raise MomaError(f"DepthModel.{name} must be in [0, 10], got {getattr(self, name)}")
        lo, hi = self.range
        if not 0.0 <= lo < hi:
            raise MomaError(f"DepthModel.range must satisfy 0 <= min < max, got {self.range}")
        if self.kind == "stereo" and (self.baseline <= 0 or self.subpixel <= 0):
            raise MomaError("a stereo DepthModel needs baseline > 0 and subpixel > 0")

    @property
    def metric(self) -> bool:
        """Whether depth is metric (False: monocular, known only up to scale)."""
        return self.kind != "monocular"


@dataclass(frozen=True)
class SensorPreset:
    """A named depth sensor: its model (``depth.metric`` False for relative depth, whose
    scale ``predict`` reads from the floor and the calibrated height), the cameras it
    stands for and where its figures come from."""

    name: str
    depth: DepthModel
    camera: str
    source: str

    @property
    def max_range(self) -> float:
        return self.depth.range[1]


# One source of truth for the sensors; docs/SENSORS.md and `robustness --list` print it.
SENSORS: dict[str, SensorPreset] = {
    p.name: p
    for p in (
        SensorPreset("ideal", DepthModel(), "a perfect render", "no error"),
        SensorPreset(
            "kinect",
            DepthModel(
                kind="structured_light",
                axial=(0.0012, 0.0019, 0.4),
                lateral_px=0.8,
                range=(0.8, 4.0),
                edge_holes=0.5,
                dropout=0.005,
                quantum=0.001,
            ),
            "Microsoft Kinect v1 / Asus Xtion (structured light)",
            "Nguyen, Izadi, Lovell 2012 (3DIMPVT): axial sigma = 1.2 mm + 1.9 mm (z - 0.4 m)^2, "
            "lateral ~0.8 px; Kinect for Windows SDK default range 0.8-4.0 m; shadow holes "
            "beside depth edges",
        ),
        SensorPreset(
            "d435",
            DepthModel(
                kind="stereo",
                baseline=0.050,
                subpixel=0.08,
                disparity_step=1.0 / 32.0,
                range=(0.3, 6.0),
                edge_holes=0.6,
                flying=0.3,
                dropout=0.01,
                quantum=0.001,
            ),
            "Intel RealSense D435 / D435i (active stereo)",
            "Intel D400 datasheet and 'Tuning depth cameras for best performance': "
            "RMS = z^2 * subpixel / (f * baseline), subpixel 0.08 px, baseline 50 mm, "
            "1/32 px disparity resolution, min range 0.3 m; holes and flying pixels at edges",
        ),
        SensorPreset(
            "azure",
            DepthModel(
                kind="tof",
                axial=(0.0015, 0.0025, 0.0),
                range=(0.5, 3.86),
                edge_holes=0.2,
                flying=0.5,
                dropout=0.005,
                offset=0.005,
                scale=0.001,
                quantum=0.001,
            ),
            "Microsoft Azure Kinect / Orbbec Femto (time of flight, NFOV unbinned)",
            "Azure Kinect DK hardware specification: NFOV unbinned 0.5-3.86 m, random error "
            "sigma <= 17 mm, systematic error < 11 mm + 0.1 % of distance; mixed (flying) "
            "pixels at depth edges",
        ),
        SensorPreset(
            "mono",
            DepthModel(kind="monocular", scale=0.06, warp=0.03, blur_px=2.0, range=(0.1, 20.0)),
            "monocular depth (Depth Anything v2, metric head) from a colour camera",
            "Yang et al. 2024 (Depth Anything V2): metric depth with a global scale error of "
            "several per cent, a smooth low-frequency warp and blurred edges; here +-6 % scale, "
            "3 % warp, 2 px blur",
        ),
    )
}


def get_sensor(name: str) -> SensorPreset:
    """A sensor preset of :data:`SENSORS`; MomaError naming the choices otherwise."""
    if name not in SENSORS:
        raise MomaError(f"unknown sensor {name!r}; sensors: {', '.join(SENSORS)}")
    return SENSORS[name]


@dataclass(frozen=True)
class MaskError:
    """A segmenter's mask errors (pixels; applied to the target and obstacle masks).

    Attributes:
        erode, dilate: boundary erosion / dilation.
        shift: the mask moved this far in a random direction.
        partial: fraction of the mask cut away on one side of a random line (0: none).
        spill: the mask leaks this far onto the background in one random direction.
    """

    erode: int = 0
    dilate: int = 0
    shift: float = 0.0
    partial: float = 0.0
    spill: int = 0

    def __post_init__(self) -> None:
        for name in ("erode", "dilate", "spill"):
            if not 0 <= getattr(self, name) <= 50:
                raise MomaError(
                    f"MaskError.{name} must be in [0, 50] px, got {getattr(self, name)}"
                )
        if not 0.0 <= self.shift <= 100.0:
            raise MomaError(f"MaskError.shift must be in [0, 100] px, got {self.shift}")
        if not 0.0 <= self.partial < 1.0:
            raise MomaError(f"MaskError.partial must be in [0, 1), got {self.partial}")


@dataclass(frozen=True)
class CalibrationError:
    """How the real camera differs from its calibration (the robot believes the
    calibrated ``camera_to_base``; the frame comes from the real camera).

    Attributes:
        height: the real camera is this much higher (m).
        pitch, roll, yaw: the real camera is turned this much (degrees) about its own x
            (positive: looks up), z (positive: clockwise as seen from behind) and y
            (positive: looks right) axes.
    """

    height: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        if not abs(self.height) <= 0.5:
            raise MomaError(f"CalibrationError.height must be within +-0.5 m, got {self.height}")
        for name in ("pitch", "roll", "yaw"):
            if not abs(getattr(self, name)) <= 30.0:
                raise MomaError(
                    f"CalibrationError.{name} must be within +-30 deg, got {getattr(self, name)}"
                )


@dataclass(frozen=True)
class ColourError:
    """Exposure gain and per-pixel noise (sigma, 0-255 scale) of the colour image; ``drop``
    replaces it by mid-grey (a robot without colour)."""

    gain: float = 1.0
    noise: float = 0.0
    drop: bool = False

    def __post_init__(self) -> None:
        if not 0.0 < self.gain <= 4.0 or not 0.0 <= self.noise <= 128.0:
            raise MomaError(
                f"ColourError needs gain in (0, 4] and noise in [0, 128], got {self.gain}, "
                f"{self.noise}"
            )


@dataclass(frozen=True)
class Corruption:
    """Everything between a render and a robot's frame: a sensor preset (:data:`SENSORS`),
    mask, calibration and colour errors."""

    sensor: str = "ideal"
    mask: MaskError = field(default_factory=MaskError)
    calibration: CalibrationError = field(default_factory=CalibrationError)
    colour: ColourError = field(default_factory=ColourError)
    description: str = ""

    def __post_init__(self) -> None:
        get_sensor(self.sensor)

    @property
    def preset(self) -> SensorPreset:
        return SENSORS[self.sensor]


def _c(description: str, **kw: Any) -> Corruption:
    return Corruption(description=description, **kw)


# The robustness track's corruptions (one source of truth: `robustness --list`, docs).
CORRUPTIONS: dict[str, Corruption] = {
    "clean": _c("the render as stored"),
    "kinect": _c("Kinect v1 depth noise, holes, 0.8-4 m", sensor="kinect"),
    "d435": _c("RealSense D435 stereo noise, quantisation, holes, flying pixels", sensor="d435"),
    "azure": _c("Azure Kinect time-of-flight noise, flying pixels, 0.5-3.86 m", sensor="azure"),
    "mono": _c("monocular depth: +-6 % scale, 3 % warp, 2 px blur", sensor="mono"),
    "height+2cm": _c("camera 2 cm higher than calibrated", calibration=CalibrationError(0.02)),
    "height-2cm": _c("camera 2 cm lower than calibrated", calibration=CalibrationError(-0.02)),
    "pitch+2": _c("camera pitched 2 deg up", calibration=CalibrationError(pitch=2.0)),
    "pitch-2": _c("camera pitched 2 deg down", calibration=CalibrationError(pitch=-2.0)),
    "roll+2": _c("camera rolled 2 deg", calibration=CalibrationError(roll=2.0)),
    "roll-2": _c("camera rolled -2 deg", calibration=CalibrationError(roll=-2.0)),
    "yaw+2": _c("camera turned 2 deg right", calibration=CalibrationError(yaw=2.0)),
    "erode5": _c("masks eroded 5 px", mask=MaskError(erode=5)),
    "dilate5": _c("masks dilated 5 px", mask=MaskError(dilate=5)),
    "shift10": _c("masks shifted 10 px", mask=MaskError(shift=10.0)),
    "partial": _c("masks with a third cut away", mask=MaskError(partial=1.0 / 3.0)),
    "spill": _c("masks spilling 8 px onto the background", mask=MaskError(spill=8)),
    "colour": _c("colour 40 % darker with noise", colour=ColourError(gain=0.6, noise=12.0)),
    "combined": _c(
        "Kinect noise and holes, masks dilated 5 px, camera pitched 2 deg up",
        sensor="kinect",
        mask=MaskError(dilate=5),
        calibration=CalibrationError(pitch=2.0),
    ),
    "combined-d435": _c(
        "D435 noise, masks shifted 5 px, camera 1 cm high and rolled 1 deg",
        sensor="d435",
        mask=MaskError(shift=5.0),
        calibration=CalibrationError(height=0.01, roll=1.0),
    ),
    "combined-mono": _c(
        "monocular depth, masks dilated 3 px, camera pitched 1 deg down",
        sensor="mono",
        mask=MaskError(dilate=3),
        calibration=CalibrationError(pitch=-1.0),
    ),
}


def get_corruption(name: str) -> Corruption:
    """A named corruption of :data:`CORRUPTIONS`; MomaError naming the choices otherwise."""
    if name not in CORRUPTIONS:
        raise MomaError(f"unknown corruption {name!r}; corruptions: {', '.join(CORRUPTIONS)}")
    return CORRUPTIONS[name]


# ------------------------------------------------------------------------------ depth
def _depth_edges(depth: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Pixels beside a depth discontinuity (a jump of over 4 % of the depth plus 2 cm to a
    4-neighbour), grown by one pixel. Shapes: (H, W) -> (H, W) bool."""
    edge = np.zeros(depth.shape, bool)
    for axis in (0, 1):
        d = np.diff(depth, axis=axis)
        near = np.minimum(
            depth[:-1] if axis == 0 else depth[:, :-1], depth[1:] if axis == 0 else depth[:, 1:]
        )
        jump = np.abs(d) > 0.04 * near + 0.02
        if axis == 0:
            edge[:-1] |= jump
            edge[1:] |= jump
        else:
            edge[:, :-1] |= jump
            edge[:, 1:] |= jump
    return ndimage.binary_dilation(edge, iterations=1) & valid


def _smooth_field(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A smooth random field in about [-1, 1] over the image: a 3 x 4 grid of uniform
    values, cubic-interpolated (the low-frequency warp of monocular depth)."""
    grid = rng.uniform(-1.0, 1.0, (3, 4))
    h, w = shape
    return np.clip(ndimage.zoom(grid, (h / 3, w / 4), order=3, mode="nearest")[:h, :w], -1, 1)


def apply_depth_model(
    depth: np.ndarray, intrinsics: Intrinsics, model: DepthModel, rng: np.random.Generator
) -> np.ndarray:
    """The depth image a sensor following ``model`` would return for the true ``depth``.

    Shapes: ``depth`` (H, W) metres (0 or NaN = no return) -> (H, W) float32 metres,
    0 where the sensor gives no return.
    """
    z = np.nan_to_num(np.asarray(depth, np.float64), nan=0.0, posinf=0.0)
    valid = z > 0
    if model.kind == "ideal":
        out = z
    else:
        h, w = z.shape
        if model.lateral_px > 0:  # read a neighbour's depth
            v, u = np.indices((h, w))
            du = np.rint(rng.normal(0.0, model.lateral_px, (h, w))).astype(np.int64)
            dv = np.rint(rng.normal(0.0, model.lateral_px, (h, w))).astype(np.int64)
            vv, uu = np.clip(v + dv, 0, h - 1), np.clip(u + du, 0, w - 1)
            z, valid = z[vv, uu], valid[vv, uu]
        if model.blur_px > 0:  # soft edges: a blur of the valid depth only
            weight = ndimage.gaussian_filter(valid.astype(np.float64), model.blur_px)
            blurred = ndimage.gaussian_filter(np.where(valid, z, 0.0), model.blur_px)
            z = np.where(valid, blurred / np.maximum(weight, 1e-9), 0.0)
        edges = _depth_edges(z, valid) if (model.edge_holes or model.flying) else None
        if model.kind == "structured_light":
            a, b, z0 = model.axial
            z = z + rng.normal(0.0, 1.0, z.shape) * (a + b * (z - z0) ** 2)
        elif model.kind == "tof":
            a, b, _ = model.axial
            z = z + rng.normal(0.0, 1.0, z.shape) * (a + b * z)
        elif model.kind == "stereo":
            fb = intrinsics.fx * model.baseline
            disparity = fb / np.where(valid, z, 1.0)
            disparity = disparity + rng.normal(0.0, model.subpixel, z.shape)
            if model.disparity_step > 0:
                disparity = np.rint(disparity / model.disparity_step) * model.disparity_step
            ok = disparity > 0
            z = np.where(ok, fb / np.where(ok, disparity, 1.0), 0.0)
            valid &= ok
        if model.kind == "monocular":
            sign = 1.0 if rng.random() < 0.5 else -1.0
            z = z * (1.0 + sign * model.scale)
        elif model.scale > 0 or model.offset > 0:
            z = z * (1.0 + rng.uniform(-model.scale, model.scale)) + rng.uniform(
                -model.offset, model.offset
            )
        if model.warp > 0:
            z = z * (1.0 + model.warp * _smooth_field(z.shape, rng))
        if edges is not None:
            if model.flying > 0:  # a mix of the nearest and farthest depth around
                lo = ndimage.minimum_filter(np.where(valid, z, np.inf), size=5)
                hi = ndimage.maximum_filter(np.where(valid, z, 0.0), size=5)
                fly = edges & (rng.random(z.shape) < model.flying) & np.isfinite(lo)
                t = rng.random(z.shape)
                z = np.where(fly, lo + t * (hi - lo), z)
            if model.edge_holes > 0:
                valid &= ~(edges & (rng.random(z.shape) < model.edge_holes))
        if model.dropout > 0:
            valid &= rng.random(z.shape) >= model.dropout
        out = np.where(valid, z, 0.0)
    lo, hi = model.range
    out = np.where((out >= lo) & (out <= hi), out, 0.0)
    if model.quantum > 0:
        out = np.rint(out / model.quantum) * model.quantum
    return out.astype(np.float32)


# ------------------------------------------------------------------------------ masks
def apply_mask_error(mask: np.ndarray, error: MaskError, rng: np.random.Generator) -> np.ndarray:
    """A segmenter's version of the true ``mask``. Shapes: (H, W) bool -> (H, W) bool."""
    m = np.asarray(mask, bool)
    if not m.any() or error == MaskError():
        return m.copy()
    if error.erode:
        m = ndimage.binary_erosion(m, iterations=error.erode)
    if error.dilate:
        m = ndimage.binary_dilation(m, iterations=error.dilate)
    if error.partial > 0 and m.any():
        v, u = np.nonzero(m)
        angle = rng.uniform(0, 2 * np.pi)
        side = (u - u.mean()) * np.cos(angle) + (v - v.mean()) * np.sin(angle)
        cut = np.quantile(side, error.partial)
        keep = side >= cut
        m = np.zeros_like(m)
        m[v[keep], u[keep]] = True
    if error.spill:
        angle = rng.uniform(0, 2 * np.pi)
        spilled = m.copy()
        for step in range(1, error.spill + 1):
            spilled |= _shifted(m, step * np.cos(angle), step * np.sin(angle))
        m = spilled
    if error.shift > 0:
        angle = rng.uniform(0, 2 * np.pi)
        m = _shifted(m, error.shift * np.cos(angle), error.shift * np.sin(angle))
    return m


def _shifted(m: np.ndarray, du: float, dv: float) -> np.ndarray:
    """``m`` moved by (du, dv) pixels (rounded), with nothing wrapping around the border."""
    out = np.zeros_like(m)
    h, w = m.shape
    iu, iv = round(du), round(dv)
    src = m[max(0, -iv) : h - max(0, iv), max(0, -iu) : w - max(0, iu)]
    out[max(0, iv) : max(0, iv) + src.shape[0], max(0, iu) : max(0, iu) + src.shape[1]] = src
    return out


# ------------------------------------------------------------------------ calibration
def _rot(axis: int, deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _turn(error: CalibrationError) -> np.ndarray:
    """The real camera's rotation in the calibrated camera's axes. (3, 3)."""
    # OpenCV axes: a positive rotation about x tilts z (forward) toward -y, i.e. up;
    # about y turns z toward +x (right); about z turns the image clockwise from behind.
    return _rot(0, error.pitch) @ _rot(1, error.yaw) @ _rot(2, error.roll)


def real_camera_to_base(calibrated: np.ndarray, error: CalibrationError) -> np.ndarray:
    """The real camera's transform, given the calibrated one and how the real camera
    differs. Shapes: (4, 4) -> (4, 4)."""
    out = np.array(calibrated, np.float64)
    out[:3, :3] = out[:3, :3] @ _turn(error)
    out[2, 3] += error.height
    return out


# -------------------------------------------------------------------------- the frame
def apply_colour_error(rgb: np.ndarray, error: ColourError, rng: np.random.Generator) -> np.ndarray:
    """Shapes: (H, W, 3) uint8 -> (H, W, 3) uint8."""
    if error.drop:
        return np.full_like(rgb, 128)
    if error.gain == 1.0 and error.noise == 0.0:
        return rgb
    out = rgb.astype(np.float32) * error.gain
    if error.noise:
        out += rng.normal(0.0, error.noise, out.shape).astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def corrupt_frame(frame: Frame, corruption: Corruption, rng: np.random.Generator) -> Frame:
    """The frame a robot would get: ``frame`` is a perfect render whose
    ``camera_to_base`` is the true camera pose; the result carries the sensor's depth,
    the segmenter's masks, the colour camera's image and the *calibrated* transform (the
    true one with the calibration error undone: :func:`real_camera_to_base` inverted).
    Deterministic for a given ``rng`` state."""
    cal = corruption.calibration
    calibrated = np.array(frame.camera_to_base, np.float64)
    if cal != CalibrationError():
        # real = calibrated (+) error, so calibrated = real (-) error
        calibrated[:3, :3] = calibrated[:3, :3] @ _turn(cal).T
        calibrated[2, 3] -= cal.height
    depth = apply_depth_model(frame.depth, frame.intrinsics, corruption.preset.depth, rng)
    target = apply_mask_error(frame.target_mask, corruption.mask, rng)
    obstacles = tuple(apply_mask_error(m, corruption.mask, rng) for m in frame.obstacle_masks)
    rgb = apply_colour_error(frame.rgb, corruption.colour, rng)
    return replace(
        frame,
        depth=depth,
        rgb=rgb,
        target_mask=target,
        obstacle_masks=obstacles,
        camera_to_base=calibrated,
    )


# --------------------------------------------------------------------------- training
@dataclass(frozen=True)
class SensorAugmentation:
    """Random corruptions for noise-aware training: each draw picks a sensor (``ideal``
    with probability ``p_ideal``, else uniformly from ``sensors``), with probability
    ``p_calibration`` calibration errors uniform within the bounds, and with probability
    ``p_mask`` one mask error.

    Attributes:
        sensors: presets drawn from.
        p_ideal: chance of a perfect depth image.
        p_calibration: chance of a calibration error (else the calibration is exact).
        height: camera height error bound (m); ``angle``: pitch and roll bound (deg);
        yaw: yaw bound (deg).
        p_mask: chance of a mask error; ``erode``/``dilate``/``spill``: their px bounds;
            ``shift``: px bound.
        p_colour: chance of a colour error.
    """

    sensors: tuple[str, ...] = ("kinect", "d435", "azure", "mono")
    p_ideal: float = 0.25
    p_calibration: float = 1.0
    height: float = 0.03
    angle: float = 3.0
    yaw: float = 1.0
    p_mask: float = 0.6
    erode: int = 6
    dilate: int = 6
    shift: float = 12.0
    spill: int = 10
    p_colour: float = 0.3

    def __post_init__(self) -> None:
        for name in self.sensors:
            get_sensor(name)
        for name in ("p_ideal", "p_calibration", "p_mask", "p_colour"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise MomaError(
                    f"SensorAugmentation.{name} must be in [0, 1], got {getattr(self, name)}"
                )
        if not (0 <= self.height <= 0.2 and 0 <= self.angle <= 10 and 0 <= self.yaw <= 10):
            raise MomaError(
                "SensorAugmentation needs height in [0, 0.2] m and angle, yaw in [0, 10] deg, "
                f"got {self.height}, {self.angle}, {self.yaw}"
            )
        for name in ("erode", "dilate", "spill"):
            if not 1 <= getattr(self, name) <= 50:
                raise MomaError(
                    f"SensorAugmentation.{name} must be in [1, 50] px, got {getattr(self, name)}"
                )
        if not 0 <= self.shift <= 100:
            raise MomaError(f"SensorAugmentation.shift must be in [0, 100] px, got {self.shift}")

    def draw(self, rng: np.random.Generator) -> Corruption:
        """One random corruption."""
        sensor = "ideal"
        if self.sensors and rng.random() >= self.p_ideal:
            sensor = self.sensors[int(rng.integers(len(self.sensors)))]
        cal = CalibrationError(
            height=float(rng.uniform(-self.height, self.height)),
            pitch=float(rng.uniform(-self.angle, self.angle)),
            roll=float(rng.uniform(-self.angle, self.angle)),
            yaw=float(rng.uniform(-self.yaw, self.yaw)),
        )
        # Drawn only when it can matter, so that p_calibration = 1 gives the same draws
        # as before it existed (the archived noise-trained runs).
        if self.p_calibration < 1.0 and rng.random() >= self.p_calibration:
            cal = CalibrationError()
        mask = MaskError()
        if rng.random() < self.p_mask:
            kind = int(rng.integers(5))
            mask = [
                MaskError(erode=int(rng.integers(1, self.erode + 1))),
                MaskError(dilate=int(rng.integers(1, self.dilate + 1))),
                MaskError(shift=float(rng.uniform(0, self.shift))),
                MaskError(partial=float(rng.uniform(0.1, 0.5))),
                MaskError(spill=int(rng.integers(1, self.spill + 1))),
            ][kind]
        colour = ColourError()
        if rng.random() < self.p_colour:
            colour = ColourError(gain=float(rng.uniform(0.5, 1.5)), noise=float(rng.uniform(0, 15)))
        return Corruption(sensor=sensor, mask=mask, calibration=cal, colour=colour)


def corruption_rng(seed: int, ids: Sequence[int], name: str) -> np.random.Generator:
    """The generator of one corruption of one episode: the same every run."""
    return np.random.default_rng([seed, *(int(i) for i in ids), zlib.crc32(name.encode())])


def target_range(frame: Any) -> float:
    """The target's distance from the camera along the optical axis (m): the median
    depth of its pixels in the clean render (inf without any)."""
    d = frame.depth[frame.target_mask]
    d = d[np.isfinite(d) & (d > 0)]
    return float(np.median(d)) if len(d) else float("inf")
