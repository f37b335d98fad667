"""Sensor, mask and calibration models: each preset's published figures, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from momakitchen.errors import MomaError
from momakitchen.perception.camera import Intrinsics
from momakitchen.perception.sensors import (
    CORRUPTIONS,
    SENSORS,
    CalibrationError,
    ColourError,
    Corruption,
    DepthModel,
    Frame,
    MaskError,
    SensorAugmentation,
    apply_depth_model,
    apply_mask_error,
    corrupt_frame,
    get_corruption,
    real_camera_to_base,
)

INTR = Intrinsics(579.4, 579.4, 320.0, 240.0, 640, 480)


def _wall(z: float) -> np.ndarray:
    return np.full((480, 640), z, np.float32)


def _interior(a: np.ndarray) -> np.ndarray:
    return a[20:-20, 20:-20]


@pytest.mark.parametrize("z", [1.0, 2.5, 3.5])
def test_kinect_axial_noise_follows_nguyen(z):
    out = apply_depth_model(_wall(z), INTR, SENSORS["kinect"].depth, np.random.default_rng(0))
    err = _interior(out)[_interior(out) > 0] - z
    expected = 0.0012 + 0.0019 * (z - 0.4) ** 2
    assert np.std(err) == pytest.approx(np.sqrt(expected**2 + 0.001**2 / 12), rel=0.06)
    assert abs(np.mean(err)) < 0.1 * expected


@pytest.mark.parametrize("z", [1.0, 3.0, 5.0])
def test_d435_noise_grows_with_the_square_of_depth(z):
    out = apply_depth_model(_wall(z), INTR, SENSORS["d435"].depth, np.random.default_rng(1))
    err = _interior(out)[_interior(out) > 0] - z
    rms = z**2 * 0.08 / (INTR.fx * 0.050)
    assert np.sqrt(np.mean(err**2)) == pytest.approx(rms, rel=0.15)
    # disparity is quantised to 1/32 px: few distinct depths
    assert len(np.unique(np.round(_interior(out), 4))) < 60


def test_working_range_and_millimetre_output():
    kinect = SENSORS["kinect"].depth
    rng = np.random.default_rng(2)
    assert (apply_depth_model(_wall(4.5), INTR, kinect, rng) == 0).all()
    assert (apply_depth_model(_wall(0.5), INTR, kinect, rng) == 0).all()
    out = apply_depth_model(_wall(2.0), INTR, kinect, rng)
    valid = out[out > 0]
    np.testing.assert_allclose(valid * 1000, np.round(valid * 1000), atol=1e-3)


def test_edges_get_holes_and_flying_pixels():
    depth = _wall(3.0)
    depth[:, 320:] = 1.5  # a step edge
    out = apply_depth_model(depth, INTR, SENSORS["d435"].depth, np.random.default_rng(3))
    band = out[100:380, 316:324]
    assert (band == 0).mean() > 0.3  # holes beside the edge
    mid = (band > 1.7) & (band < 2.8)  # flying pixels between the two sides
    assert mid.any()
    far = out[100:380, 100:200]
    assert (far == 0).mean() < 0.05  # away from the edge: the dropout only


def test_monocular_scale_and_warp():
    out = apply_depth_model(_wall(2.0), INTR, SENSORS["mono"].depth, np.random.default_rng(4))
    ratio = out / 2.0
    assert abs(np.median(ratio) - 1) == pytest.approx(0.06, abs=0.02)  # the scale error
    assert 0.01 < ratio.std() < 0.04  # and a smooth warp of a few per cent
    assert np.abs(np.diff(ratio, axis=1)).max() < 0.002  # smooth, no per-pixel noise


def test_ideal_is_exact_and_models_are_deterministic():
    depth = np.random.default_rng(5).uniform(0.5, 5, (480, 640)).astype(np.float32)
    depth[0, 0] = np.nan
    ideal = apply_depth_model(depth, INTR, SENSORS["ideal"].depth, np.random.default_rng(0))
    np.testing.assert_array_equal(ideal[1:], depth[1:])
    assert ideal[0, 0] == 0
    for preset in SENSORS.values():
        a = apply_depth_model(depth, INTR, preset.depth, np.random.default_rng(9))
        b = apply_depth_model(depth, INTR, preset.depth, np.random.default_rng(9))
        np.testing.assert_array_equal(a, b)


def test_mask_errors():
    m = np.zeros((100, 100), bool)
    m[40:60, 40:60] = True
    rng = np.random.default_rng(0)
    assert apply_mask_error(m, MaskError(erode=5), rng).sum() == 100
    assert apply_mask_error(m, MaskError(dilate=2), rng).sum() > 400
    shifted = apply_mask_error(m, MaskError(shift=10.0), rng)
    v, u = np.nonzero(shifted)
    assert shifted.sum() == 400
    assert np.hypot(v.mean() - 49.5, u.mean() - 49.5) == pytest.approx(10, abs=0.8)
    part = apply_mask_error(m, MaskError(partial=0.5), rng)
    assert 150 <= part.sum() <= 250 and (part <= m).all()
    spill = apply_mask_error(m, MaskError(spill=8), rng)
    assert (spill >= m).all() and spill.sum() > 500
    assert not apply_mask_error(m, MaskError(erode=10), rng).any()


def test_calibration_error_is_undone_by_its_inverse():
    tf = np.eye(4)
    tf[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]  # camera looking forward
    tf[:3, 3] = [0.1, 0.0, 1.3]
    err = CalibrationError(height=0.02, pitch=2.0, roll=-1.0, yaw=0.5)
    frame = Frame(
        _wall(2.0), np.zeros((480, 640, 3), np.uint8), np.zeros((480, 640), bool), (), INTR, tf
    )
    bad = corrupt_frame(frame, Corruption(calibration=err), np.random.default_rng(0))
    np.testing.assert_allclose(real_camera_to_base(bad.camera_to_base, err), tf, atol=1e-12)
    # pitched up: the calibrated optical axis points lower than the real one
    up = Corruption(calibration=CalibrationError(pitch=2.0))
    calibrated = corrupt_frame(frame, up, np.random.default_rng(0)).camera_to_base
    assert calibrated[2, 2] < tf[2, 2] - 0.03
    assert calibrated[2, 3] == tf[2, 3]


def test_named_corruptions_and_bad_values():
    assert next(iter(CORRUPTIONS)) == "clean"
    assert get_corruption("combined").sensor == "kinect"
    with pytest.raises(MomaError, match="unknown corruption 'fog'"):
        get_corruption("fog")
    with pytest.raises(MomaError, match="unknown sensor 'lidar'"):
        Corruption(sensor="lidar")
    with pytest.raises(MomaError, match=r"MaskError.erode must be in \[0, 50\] px, got -1"):
        MaskError(erode=-1)
    with pytest.raises(MomaError, match=r"CalibrationError\.pitch"):
        CalibrationError(pitch=45.0)
    with pytest.raises(MomaError, match=r"DepthModel\.kind"):
        DepthModel(kind="sonar")
    with pytest.raises(MomaError, match="ColourError"):
        ColourError(gain=0.0)
    with pytest.raises(MomaError, match="p_ideal"):
        SensorAugmentation(p_ideal=2.0)
    with pytest.raises(MomaError, match=r"p_calibration must be in \[0, 1\], got -0.5"):
        SensorAugmentation(p_calibration=-0.5)
    with pytest.raises(MomaError, match=r"SensorAugmentation.erode must be in \[1, 50\] px, got 0"):
        SensorAugmentation(erode=0)
    with pytest.raises(MomaError, match="unknown sensor 'sonar'"):
        SensorAugmentation(sensors=("sonar",))


def test_augmentation_draws_every_kind_deterministically():
    aug = SensorAugmentation()
    draws = [aug.draw(np.random.default_rng([7, i])) for i in range(200)]
    again = [aug.draw(np.random.default_rng([7, i])) for i in range(200)]
    assert draws == again
    sensors = {d.sensor for d in draws}
    assert sensors == {"ideal", *aug.sensors}
    assert all(abs(d.calibration.height) <= aug.height for d in draws)
    assert sum(d.mask != MaskError() for d in draws) == pytest.approx(200 * aug.p_mask, abs=25)


def test_augmentation_rates_are_settable():
    only_d435 = SensorAugmentation(sensors=("d435",), p_ideal=0.0, p_calibration=0.0)
    draws = [only_d435.draw(np.random.default_rng([7, i])) for i in range(100)]
    assert {d.sensor for d in draws} == {"d435"}
    assert all(d.calibration == CalibrationError() for d in draws)
    some = SensorAugmentation(p_calibration=0.3)
    draws = [some.draw(np.random.default_rng([7, i])) for i in range(200)]
    exact = sum(d.calibration == CalibrationError() for d in draws)
    assert exact == pytest.approx(200 * 0.7, abs=25)
