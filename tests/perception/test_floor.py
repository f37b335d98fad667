"""Floor-plane inference: a calibration error is found and undone, noise is measured."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.frames import transform
from momakitchen.perception.camera import look_at
from momakitchen.perception.floor import FloorFitConfig, fit_floor, floor_tolerance
from momakitchen.perception.sensors import CalibrationError, real_camera_to_base

CAM = np.array([0.0, 0.0, 1.3])


def _room(rng: np.random.Generator, noise: float = 0.0) -> np.ndarray:
    """A floor ahead of the camera, a counter front and a few boxes near the floor."""
    floor = np.column_stack(
        [rng.uniform(0.8, 4, 20000), rng.uniform(-1.5, 1.5, 20000), np.zeros(20000)]
    )
    wall = np.column_stack(
        [np.full(8000, 4.0), rng.uniform(-1.5, 1.5, 8000), rng.uniform(0, 0.9, 8000)]
    )
    boxes = np.column_stack(
        [rng.uniform(2, 3, 2000), rng.uniform(-1, 1, 2000), rng.uniform(0.005, 0.15, 2000)]
    )
    pts = np.vstack([floor, wall, boxes])
    r = np.linalg.norm(pts - CAM, axis=1)
    return pts + rng.normal(0, 1, pts.shape) * (noise * r[:, None] ** 2)


def _turn(pts: np.ndarray, pitch_deg: float, roll_deg: float, height: float) -> np.ndarray:
    """The points as a camera with a calibration error would place them (rotated about
    the camera, shifted in height)."""
    p, r = np.radians(pitch_deg), np.radians(roll_deg)
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    return (pts - CAM) @ (rx @ ry).T + CAM + [0, 0, height]


@pytest.mark.parametrize(
    ("pitch", "roll", "height"), [(0, 0, 0), (2, 0, 0), (-2, 1, 0.02), (0, -2, -0.03)]
)
def test_a_calibration_error_is_found_and_undone(pitch, roll, height):
    rng = np.random.default_rng(0)
    true = _room(rng)
    seen = _turn(true, pitch, roll, height)
    corr = fit_floor(seen, CAM)
    fixed = corr.apply(seen)
    floor = np.abs(true[:, 2]) < 1e-9
    assert np.abs(fixed[floor, 2]).max() < 1e-5  # the floor is z = 0 again
    np.testing.assert_allclose(fixed[:, 2], true[:, 2], atol=1e-5)  # every height right
    # and every point where it was, but for a turn about the vertical, which a floor
    # cannot show (a roll of the tilted camera has a part of it)
    np.testing.assert_allclose(fixed[:, :2], true[:, :2], atol=1e-5 if roll == 0 else 5e-3)
    assert corr.height == pytest.approx(-height, abs=1e-4)  # seen higher: camera lower
    assert corr.scale == 1.0 and corr.inliers > 1000


@pytest.mark.parametrize(
    ("error", "turn"), [("pitch", 0.0), ("roll", 3.0 * np.sin(np.radians(32)))]
)
def test_a_camera_roll_is_partly_a_turn_no_floor_shows(error, turn):
    """A camera looking 32 degrees down rolls about a tilted axis: of a 3 degree roll
    error, 3 sin(32 deg) degrees are a turn about the vertical that the floor fit cannot
    undo (docs/SENSORS.md); a pitch error is undone whole."""
    down = np.radians(32)
    calibrated = look_at(CAM, CAM + np.array([np.cos(down), 0.0, -np.sin(down)]))
    real = real_camera_to_base(calibrated, CalibrationError(**{error: 3.0}))
    seen_from_true = calibrated @ np.linalg.inv(real)  # where the robot believes points are
    corr = fit_floor(transform(seen_from_true, _room(np.random.default_rng(4))), CAM)
    net = corr.matrix @ seen_from_true  # believed after the correction, from true
    np.testing.assert_allclose(net[2, :3], [0.0, 0.0, 1.0], atol=1e-6)  # levelled
    left = np.degrees(np.arctan2(net[1, 0], net[0, 0]))
    assert abs(left) == pytest.approx(turn, abs=0.01)


def test_noisy_floor_is_fitted_without_bias_and_its_noise_measured():
    rng = np.random.default_rng(1)
    seen = _turn(_room(rng, noise=0.002), 2.0, 0.0, 0.0)
    corr = fit_floor(seen, CAM)
    fixed = corr.apply(seen)
    assert abs(corr.pitch) == pytest.approx(2.0, abs=0.15)
    assert abs(corr.height) < 0.005
    ranges = np.linalg.norm(fixed - corr.new_camera, axis=1)
    tol = floor_tolerance(fixed[:, 2], ranges, base=0.02)
    far, near = ranges > 3.5, ranges < 1.8
    assert tol[far].mean() > tol[near].mean() >= 0.0199  # wider where the noise is larger


def test_relative_depth_takes_its_scale_from_the_calibrated_height():
    rng = np.random.default_rng(2)
    true = _room(rng)
    seen = (true - CAM) * 1.06 + CAM  # 6 % too far
    corr = fit_floor(seen, CAM, metric=False)
    assert corr.scale == pytest.approx(1 / 1.06, rel=1e-6)
    np.testing.assert_allclose(corr.apply(seen), true, atol=1e-5)
    # metric depth reads the same points as a camera 8 cm higher than calibrated
    assert fit_floor(seen, CAM).height == pytest.approx(0.06 * 1.3, abs=1e-5)


def test_no_floor_plane_is_a_clear_error():
    rng = np.random.default_rng(3)
    wall = np.column_stack(
        [np.full(5000, 3.0), rng.uniform(-1, 1, 5000), rng.uniform(0.5, 2, 5000)]
    )
    with pytest.raises(MomaError, match="no floor plane found: 0 points lie within 30 cm"):
        fit_floor(wall, CAM)
    high = _turn(_room(rng), 0.0, 0.0, 0.5)  # extrinsics 50 cm off: no floor near z = 0
    with pytest.raises(MomaError, match=r"no floor plane found.*check the extrinsics"):
        fit_floor(high, CAM)
    with pytest.raises(MomaError, match="max_tilt"):
        FloorFitConfig(max_tilt=0)
