"""The floor plane from the frame itself, with the calibrated extrinsics only as a prior.

A camera that is 2 cm higher, or pitched 2 degrees more, than its calibration says moves
or tilts the whole floor in the base frame; noisy depth scatters it by centimetres at 3 m.
:func:`fit_floor` finds the dominant near-horizontal plane near the calibrated floor
(RANSAC, then a least-squares refinement on its inliers), :class:`FloorCorrection` moves
the points so that this plane is z = 0 (rotating about the camera, which is where a
calibration error turns the view), and :func:`floor_tolerance` says how far from the
plane a point may be and still be floor, from the noise measured on the plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.frames import transform


@dataclass(frozen=True)
class FloorFitConfig:
    """How the floor plane is searched for (metres, degrees).

    Attributes:
        band: candidates are points within this height of the calibrated floor (z = 0).
        max_tilt: the plane may tilt at most this much from the calibrated floor.
        max_height: the camera's height above the plane may differ at most this much from
            its calibrated height (metric depth).
        tol, tol_range: RANSAC inlier tolerance ``tol + tol_range * r**2`` at range r (m):
            depth noise grows with the square of the range for most sensors.
        iterations: RANSAC hypotheses (drawn from a generator seeded with 0: the same
            frame always gives the same plane).
        sample: candidates RANSAC scores each hypothesis on.
        min_inliers: fewer inliers than this: no floor plane found.
    """

    band: float = 0.3
    max_tilt: float = 8.0
    max_height: float = 0.25
    tol: float = 0.012
    tol_range: float = 0.003
    iterations: int = 200
    sample: int = 3000
    min_inliers: int = 150

    def __post_init__(self) -> None:
        if not 0.02 <= self.band <= 1.0:
            raise MomaError(f"FloorFitConfig.band must be in [0.02, 1] m, got {self.band}")
        if not 0.0 < self.max_tilt <= 30.0:
            raise MomaError(f"FloorFitConfig.max_tilt must be in (0, 30] deg, got {self.max_tilt}")
        if not 0.0 < self.max_height <= 1.0:
            raise MomaError(f"FloorFitConfig.max_height must be in (0, 1] m, got {self.max_height}")
        if not (0 < self.tol <= 0.2 and 0 <= self.tol_range <= 0.1):
            raise MomaError(
                f"FloorFitConfig needs tol in (0, 0.2] and tol_range in [0, 0.1], got "
                f"{self.tol}, {self.tol_range}"
            )
        if self.iterations < 1 or self.sample < 10 or self.min_inliers < 3:
            raise MomaError("FloorFitConfig needs iterations >= 1, sample >= 10, min_inliers >= 3")


@dataclass(frozen=True)
class FloorCorrection:
    """The correction applied to a frame's base-frame points so the measured floor is
    z = 0: ``corrected = rotation @ (scale * (p - camera) + camera - camera) + new_camera``,
    i.e. a scaling and rotation about the camera centre and a change of its height.

    Attributes:
        height: how much higher (m) the camera is than calibrated (metric depth; 0 for
            relative depth, where the calibrated height fixes the scale instead).
        pitch: rotation (deg) about the base y axis that levelled the floor (positive:
            the floor ahead was measured too high, i.e. the camera looks more down than
            calibrated).
        roll: rotation (deg) about the base x axis.
        scale: factor applied to the depth (1 for metric depth).
        inliers: floor points that support the plane (of at most ``REFINE_POINTS``
            candidates sampled); ``residual``: their RMS distance (m).
        rotation: (3, 3); camera: (3,) calibrated camera position; ``new_camera`` (3,).
    """

    height: float
    pitch: float
    roll: float
    scale: float
    inliers: int
    residual: float
    rotation: np.ndarray
    camera: np.ndarray
    new_camera: np.ndarray

    @property
    def matrix(self) -> np.ndarray:
        """The correction as a (4, 4) affine matrix (a rotation and a uniform scale)."""
        m = np.eye(4)
        m[:3, :3] = self.rotation * self.scale
        m[:3, 3] = self.new_camera - m[:3, :3] @ self.camera
        return m

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Corrected points. Shapes: (N, 3) -> (N, 3)."""
        return transform(self.matrix, points)

    def to_dict(self) -> dict[str, Any]:
        # (+ 0.0: no "-0.0" for a correction that rounds to nothing)
        return {
            "height_m": round(self.height, 4) + 0.0,
            "pitch_deg": round(self.pitch, 3) + 0.0,
            "roll_deg": round(self.roll, 3) + 0.0,
            "depth_scale": round(self.scale, 4),
            "floor_inliers": int(self.inliers),
            "floor_residual_m": round(self.residual, 4),
        }


REFINE_POINTS = 20000
MIN_TOL = 0.002  # m: the refinement's inlier band never narrows below this
# The floor is most of what lies near the calibrated floor height: a plane that explains
# less than this share of those points is a tilted floor, a wall or clutter, not it.
MIN_SHARE = 0.2
# (m, deg) corrections smaller than both are not applied
NEGLIGIBLE = (1e-4, 0.005)


def _tolerance(ranges: np.ndarray, cfg: FloorFitConfig) -> np.ndarray:
    return cfg.tol + cfg.tol_range * ranges**2


def _plane(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (up) and offsets of planes through point triples. Shapes: (K, 3, 3)
    -> (K, 3), (K,) with ``n . x + d = 0``."""
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = n / np.maximum(norm, 1e-12)
    n = np.where(n[:, 2:3] < 0, -n, n)
    return n, -np.einsum("kj,kj->k", n, p[:, 0])


def _refine(pts: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, float]:
    """Weighted least-squares plane z = a x + b y + c (near-horizontal): its unit normal
    (up) and offset d of ``n . x + d = 0``."""
    a = np.column_stack([pts[:, 0], pts[:, 1], np.ones(len(pts))]) * w[:, None]
    coef = np.linalg.lstsq(a, pts[:, 2] * w, rcond=None)[0]
    n = np.array([-coef[0], -coef[1], 1.0])
    scale = np.linalg.norm(n)
    return n / scale, float(-coef[2] / scale)


def _levelling(n: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``n`` to +z (Rodrigues). (3,) -> (3, 3)."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(n, z)
    s, c = np.linalg.norm(axis), float(n @ z)
    if s < 1e-12:
        return np.eye(3)
    k = axis / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * kx + (1 - c) * kx @ kx


def fit_floor(
    points: np.ndarray,
    camera: np.ndarray,
    config: FloorFitConfig | None = None,
    metric: bool = True,
    ranges: np.ndarray | None = None,
) -> FloorCorrection:
    """Find the floor in a frame's points and the correction that puts it at z = 0.

    Args:
        points: (N, 3) the frame's points in the calibrated base frame.
        camera: (3,) the calibrated camera position in that frame.
        metric: depth is metric (the camera height is corrected); False: depth is known
            only up to scale (monocular), and the calibrated height fixes the scale.
        ranges: (N,) each point's range for the noise-scaled tolerance (a pixel's depth);
            None: its distance from the camera.

    Raises MomaError naming what was found when no plane near the calibrated floor has
    enough support (wrong extrinsics, a frame without floor).
    """
    cfg = config or FloorFitConfig()
    cam = np.asarray(camera, np.float64)
    pts = np.asarray(points, np.float64)
    height = float(cam[2])
    # Relative depth can put the floor anywhere along the rays: search a band that grows
    # with the scale error it allows (+-30 % of the camera height).
    band = cfg.band if metric else max(cfg.band, 0.3 * height)
    if ranges is None:
        ranges = np.linalg.norm(pts - cam, axis=1)
    idx = np.flatnonzero(np.abs(pts[:, 2]) < band)
    if len(idx) < cfg.min_inliers:
        raise MomaError(
            f"no floor plane found: {len(idx)} points lie within {band * 100:.0f} cm of the "
            "calibrated floor height (need a view of the floor; check the extrinsics)",
            cause="no_floor",
        )
    rng = np.random.default_rng(0)
    # A fixed-size sample of the candidates is plenty for three parameters, and fast.
    if len(idx) > REFINE_POINTS:
        idx = np.sort(idx[rng.choice(len(idx), REFINE_POINTS, replace=False)])
    cand, cand_r = pts[idx], np.asarray(ranges, np.float64)[idx]
    pick = rng.choice(len(cand), min(cfg.sample, len(cand)), replace=False)
    sub = cand[pick]
    tol_sub = _tolerance(cand_r[pick], cfg)
    normals, offsets = _plane(sub[rng.integers(0, len(sub), (cfg.iterations, 3))])
    tilt_ok = normals[:, 2] >= math.cos(math.radians(cfg.max_tilt))
    cam_h = normals @ cam + offsets  # camera height above each plane
    if metric:
        h_ok = np.abs(cam_h - height) <= cfg.max_height
    else:
        h_ok = (cam_h > 0.5 * height) & (cam_h < 1.5 * height)
    ok = tilt_ok & h_ok
    if not ok.any():
        raise MomaError(
            "no floor plane found: no plane through the points near the calibrated floor is "
            f"within {cfg.max_tilt:g} deg and {cfg.max_height * 100:g} cm of it; check the "
            "extrinsics",
            cause="no_floor",
        )
    dist = np.abs(sub @ normals[ok].T + offsets[ok])  # (S, K)
    score = (dist <= tol_sub[:, None]).sum(0)
    best = int(np.flatnonzero(ok)[int(np.argmax(score))])
    n, d = normals[best], float(offsets[best])
    shape = _tolerance(cand_r, cfg)  # the expected noise shape
    tol = shape
    previous = None
    for _ in range(8):
        # Least squares on the inliers, weighted by the expected noise; then the inlier
        # band shrinks to three robust standard deviations of the measured residuals
        # (a perfect floor: a couple of millimetres, so object bottoms and plinths drop
        # out), never wider than RANSAC's; until the inliers no longer change.
        inl = np.abs(cand @ n + d) <= tol
        if inl.sum() < cfg.min_inliers or (previous is not None and (inl == previous).all()):
            break
        previous = inl
        n, d = _refine(cand[inl], 1.0 / shape[inl])
        res = np.abs(cand[inl] @ n + d) / shape[inl]
        tol = np.clip(3.0 * 1.4826 * float(np.median(res)) * shape, MIN_TOL, shape)
    inl = np.abs(cand @ n + d) <= tol
    need = max(cfg.min_inliers, int(MIN_SHARE * len(cand)))
    if inl.sum() < need:
        raise MomaError(
            f"no floor plane found: the best plane near the calibrated floor has "
            f"{int(inl.sum())} supporting points of {len(cand)} (need {need}); check the "
            "extrinsics",
            cause="no_floor",
        )
    tilt = math.degrees(math.acos(min(1.0, float(n[2]))))
    cam_height = float(n @ cam + d)
    if tilt > cfg.max_tilt or (metric and abs(cam_height - height) > cfg.max_height):
        raise MomaError(
            f"no floor plane found within {cfg.max_tilt:g} deg and {cfg.max_height * 100:g} cm "
            f"of the calibrated floor (best: tilted {tilt:.1f} deg, camera "
            f"{cam_height:.3f} m above it against {height:.3f} m calibrated); check the "
            "extrinsics",
            cause="no_floor",
        )
    scale = 1.0 if metric else height / cam_height
    new_height = cam_height if metric else height
    rot = _levelling(n)
    if metric and abs(cam_height - height) < NEGLIGIBLE[0] and tilt < NEGLIGIBLE[1]:
        # below what the floor can tell: the calibration stands (a perfect render is
        # then read exactly as the data were made)
        n, new_height, rot = np.array([0.0, 0.0, 1.0]), height, np.eye(3)
    residual = float(np.sqrt(np.mean((cand[inl] @ n + d) ** 2))) * scale
    return FloorCorrection(
        height=new_height - height,
        pitch=math.degrees(math.atan2(-n[0], n[2])),
        roll=math.degrees(math.atan2(n[1], n[2])),
        scale=scale,
        inliers=int(inl.sum()),
        residual=residual,
        rotation=rot,
        camera=cam,
        new_camera=np.array([cam[0], cam[1], new_height]),
    )


def floor_tolerance(
    heights: np.ndarray,
    ranges: np.ndarray,
    base: float,
    bin_width: float = 0.5,
    most: float = 0.08,
) -> np.ndarray:
    """How far from z = 0 each point (of corrected ``heights`` z, at ``ranges``: depths)
    may be and still count as floor: three times the floor's measured noise at its range,
    never less than ``base`` nor more than ``most`` (m). The noise is measured below the
    plane only (a robust spread of the depths of the points under it, per range bin):
    objects add points above the floor, never below, so what lies under the plane is
    floor noise alone.

    Shapes: ``heights`` (N,), ``ranges`` (N,) -> (N,) metres.
    """
    z = np.asarray(heights, np.float64)
    if len(z) == 0:
        return np.zeros(0)
    bins = np.floor(np.asarray(ranges, np.float64) / bin_width).astype(np.int64)
    below = z < 0
    sigma = np.zeros(int(bins.max()) + 1)
    counts = np.bincount(bins[below], minlength=len(sigma))
    for b in np.flatnonzero(counts >= 20):
        sigma[b] = 1.4826 * float(np.median(-z[below & (bins == b)]))
    # A bin without enough floor takes the noise of the nearest measured range below it.
    sigma = np.maximum.accumulate(sigma)
    return np.clip(3.0 * sigma[bins], base, max(base, most))
