"""predict: same map as evaluate on a dataset episode, outputs, uncertainty, bad input."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import momakitchen
from momakitchen.data.episode import SEMANTIC_CLASSES
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError

TARGET = SEMANTIC_CLASSES.index("target")
OBSTACLE = SEMANTIC_CLASSES.index("obstacle")


@pytest.fixture(scope="module")
def episode(real_view):
    with SceneShard(real_view / "scenes" / "scene_000003.h5") as shard:
        return shard.episode(0, shard.episode_indices(0)[-1])


def _inputs(ep):
    return dict(
        depth=ep.depth,
        intrinsics=ep.intrinsics,
        camera_to_base=ep.camera_to_base,
        target_mask=ep.semantic == TARGET,
        robot=ep.robot,
    )


def test_predict_gives_evaluates_map_on_a_dataset_episode(real_view, episode, tiny_run):
    from momakitchen.data import EpisodeDataset
    from momakitchen.data.batch import EpisodeCollator
    from momakitchen.models.inference import PICK_RADIUS, local_mean, predict_batch
    from momakitchen.train import load_checkpoint

    run = load_checkpoint(tiny_run)
    data = EpisodeDataset(real_view, "all")
    sample = next(
        data[i] for i in range(len(data)) if data[i]["episode_index"] == episode.episode_index
    )
    # every floor point predicted, the floor encoded at the training density
    assert len(sample["floor_xyz"]) > run.config.num_floor
    collate = EpisodeCollator(
        run.config.num_global, None, run.config.seed, num_context=run.config.num_floor
    )
    ep = episode
    pred = momakitchen.predict(
        **_inputs(ep),
        rgb=ep.rgb,
        obstacle_masks=[ep.semantic == OBSTACLE],
        checkpoint=tiny_run,
        episode_id=(3, 0, ep.episode_index),
    )
    # The clean render's floor is found where it is: no correction, the clouds are the
    # stored ones with the floor (points within 2 cm of it) put on the plane, and the map
    # is evaluate's on those clouds.
    c = pred.correction
    assert (c.height, c.pitch, c.roll, c.scale) == (0.0, 0.0, 0.0, 1.0)
    np.testing.assert_array_equal(pred.floor_xyz[:, :2].astype(np.float32), ep.floor_xyz[:, :2])
    assert (pred.floor_xyz[:, 2] == 0).all()
    flat = dict(sample)
    flat["floor_xyz"] = sample["floor_xyz"].clone()
    flat["floor_xyz"][:, 2] = 0
    flat["global_xyz"] = sample["global_xyz"].clone()
    flat["global_xyz"][sample["global_xyz"][:, 2].abs() <= 0.02, 2] = 0
    expected = predict_batch(run.model, collate([flat]))[0].numpy()
    np.testing.assert_allclose(pred.affordance, expected, rtol=0, atol=1e-6)
    assert pred.poses.shape == (5, 3) and (pred.uncertainty >= 0).all()
    assert PICK_RADIUS == 0.0 and pred.pose_scores[0] == pytest.approx(pred.affordance.max())
    # With a pick radius, the first pose is the best point of the map averaged over it.
    smoothed = momakitchen.predict(
        **_inputs(ep),
        rgb=ep.rgb,
        obstacle_masks=[ep.semantic == OBSTACLE],
        checkpoint=tiny_run,
        episode_id=(3, 0, ep.episode_index),
        pick_radius=0.1,
        mc_samples=0,
    )
    best = np.argmax(local_mean(pred.floor_xyz[:, :2], pred.affordance, 0.1))
    np.testing.assert_allclose(smoothed.poses[0, :2], pred.floor_xyz[best, :2])
    assert smoothed.pose_scores[0] == pred.affordance[best]
    # the yaw faces the target centroid
    dx, dy = pred.target_xyz[:2] - pred.poses[0, :2]
    assert np.cos(pred.poses[0, 2] - np.arctan2(dy, dx)) == pytest.approx(1.0)


def test_predict_any_resolution_invalid_depth_and_uncertainty(episode, tiny_run):
    ep = episode
    depth = ep.depth.copy()
    depth[::7] = np.nan  # invalid pixels are ignored
    depth[1::7] = 0.0
    half = {k: v for k, v in _inputs(ep).items()}
    half.update(
        depth=depth[::2, ::2],
        target_mask=(ep.semantic == TARGET)[::2, ::2],
        intrinsics=np.asarray(ep.intrinsics) / 2,
    )
    a = momakitchen.predict(**half, checkpoint=tiny_run, mc_samples=4)
    b = momakitchen.predict(**half, checkpoint=tiny_run, mc_samples=4)
    assert len(a.floor_xyz) > 50 and np.isfinite(a.affordance).all()
    np.testing.assert_array_equal(a.uncertainty, b.uncertainty)  # reproducible
    assert a.uncertainty.max() > 0
    none = momakitchen.predict(**half, checkpoint=tiny_run, mc_samples=0)
    assert (none.uncertainty == 0).all()
    np.testing.assert_array_equal(none.affordance, a.affordance)


def _raised(tf, metres):
    out = np.array(tf, np.float64)
    out[2, 3] += metres
    return out


def test_predict_bad_input(episode, tiny_run):
    ep = episode
    ok = _inputs(ep)
    cases = {
        "does not match the depth image": dict(target_mask=ep.semantic[:-1] == TARGET),
        "no valid pixel": dict(depth=np.full_like(ep.depth, np.nan)),
        "depth looks like millimetres": dict(depth=ep.depth * 1000),
        "but none with a valid depth": dict(depth=np.where(ep.semantic == TARGET, 0, ep.depth)),
        "no floor plane found": dict(camera_to_base=_raised(ep.camera_to_base, 1.0)),
        "target mask is empty": dict(target_mask=np.zeros_like(ep.semantic, bool)),
        "not a rigid transform": dict(camera_to_base=ep.camera_to_base * 2),
        "unknown robot": dict(robot="r2d2"),
        "fx, fy, cx, cy": dict(intrinsics=[1.0, 2.0]),
        r"pick_radius must be in \[0, 1\] m, got 2": dict(pick_radius=2.0),
    }
    for message, change in cases.items():
        with pytest.raises(MomaError, match=message):
            momakitchen.predict(**{**ok, **change}, checkpoint=tiny_run)
    with pytest.raises(MomaError, match="reach"):
        momakitchen.predict(
            **{**ok, "robot": {"reach": 9.0, "mount_height": 1.0}}, checkpoint=tiny_run
        )


def test_robot_input_takes_a_finger_force_and_version_1_vectors():
    from momakitchen.deploy.predict import robot_input
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import DESCRIPTOR_DIM, get_robot_spec

    name, d = robot_input("elephant")
    assert name == "elephant" and d.shape == (DESCRIPTOR_DIM,) and d[4] == np.float32(0.4)
    _, strong = robot_input({"reach": 0.8, "mount_height": 1.0, "finger_force": 120})
    _, default = robot_input({"reach": 0.8, "mount_height": 1.0})
    _, cup = robot_input({"reach": 0.8, "mount_height": 1.0, "suction": True})
    assert (strong[4], default[4], cup[4]) == (np.float32(1.2), np.float32(0.4), 0.0)
    # Where the shoulder stands: 0.25 m above the mount unless given.
    assert default[5:] == pytest.approx((1.25, 0.0))
    _, tall = robot_input(
        {"reach": 0.8, "mount_height": 1.0, "shoulder_rise": 0.4, "shoulder_offset": 0.06}
    )
    assert tall[5:] == pytest.approx((1.4, 0.6))
    # Older vectors (reach, mount, dof / 7, suction[, force / 100]) get the defaults.
    ur5e = robot_descriptor(get_robot_spec("ur5e"))
    for old in (ur5e[:4], ur5e[:5]):
        got = robot_input(list(old))[1]
        assert np.array_equal(got[:5], np.float32(ur5e[:5]))
        assert got[5:] == pytest.approx((1.03 + 0.25, 0.0))
    _, grip = robot_input([0.8, 1.0, 1.0, 0.0, 1.2])
    assert grip[4] == np.float32(1.2)
    # A registered robot at another mount keeps its name (a model may read its URDF).
    name, high = robot_input(("ur5e", 1.3))
    assert (
        name == "ur5e"
        and high[1] == np.float32(1.3)
        and high[0] == np.float32(get_robot_spec("ur5e").reach)
    )
    with pytest.raises(MomaError, match="mount"):
        robot_input(("ur5e", 3.0))
    with pytest.raises(MomaError, match=r"robot finger_force must be in \[10, 200\] N, got 500"):
        robot_input({"reach": 0.8, "mount_height": 1.0, "finger_force": 500})
    with pytest.raises(MomaError, match=r"robot shoulder_rise must be in \[0, 1\] m, got 2"):
        robot_input({"reach": 0.8, "mount_height": 1.0, "shoulder_rise": 2})
    with pytest.raises(MomaError, match="must be 7 finite numbers"):
        robot_input([0.8, 1.0, 1.0])


def test_predict_cli(episode, tiny_run, tmp_path, capsys):
    from PIL import Image

    from momakitchen.cli.main import main

    ep = episode
    depth_png = tmp_path / "depth.png"
    Image.fromarray(np.round(ep.depth * 1000).astype(np.uint16)).save(depth_png)
    mask = tmp_path / "target.png"
    Image.fromarray(((ep.semantic == TARGET) * 255).astype(np.uint8)).save(mask)
    np.save(tmp_path / "tf.npy", ep.camera_to_base)
    np.save(tmp_path / "rgb.npy", ep.rgb)
    args = [
        "predict",
        "--depth",
        str(depth_png),
        "--intrinsics",
        *map(str, ep.intrinsics),
        "--extrinsics",
        str(tmp_path / "tf.npy"),
        "--target-mask",
        str(mask),
        "--rgb",
        str(tmp_path / "rgb.npy"),
        "--checkpoint",
        str(tiny_run),
        "--out",
        str(tmp_path / "out"),
    ]
    assert main([*args, "--robot", "panda"]) == 0
    result = json.loads((tmp_path / "out" / "prediction.json").read_text())
    assert len(result["poses"]) == 5 and result["floor_points"]["rows"]
    assert (tmp_path / "out" / "prediction.png").stat().st_size > 10_000
    assert main([*args, "--reach", "0.8", "--mount-height", "0.5", "--top-k", "2"]) == 0
    numbers = ["--reach", "0.8", "--mount-height", "0.5", "--finger-force", "120"]
    assert main([*args, *numbers]) == 0
    assert main([*args, "--robot", "panda", "--finger-force", "120"]) == 2
    # a registered robot at another mount: its name stays (a model may read its URDF)
    assert main([*args, "--robot", "panda", "--mount-height", "1.25", "--top-k", "1"]) == 0
    assert json.loads((tmp_path / "out" / "prediction.json").read_text())["robot"] == "panda"
    assert main([*args, "--robot", "panda", "--mount-height", "2.5"]) == 2
    assert main([*args, "--robot", "r2d2"]) == 2
    assert main([*args]) == 2  # no robot at all
    bad = tmp_path / "bad.npy"
    np.save(bad, np.eye(4) * 3)
    i = args.index("--extrinsics")
    assert main([*args[: i + 1], str(bad), *args[i + 2 :], "--robot", "panda"]) == 2
    err = capsys.readouterr().err
    assert "unknown robot" in err and "rigid" in err


def test_write_outputs_takes_the_inputs_predict_takes(episode, tiny_run, tmp_path):
    """The Python API: intrinsics as (fx, fy, cx, cy) and the transform as an array, as
    `predict` takes them; wrong ones fail with a MomaError, not deep in plotting."""
    from momakitchen.deploy.predict import write_outputs

    ep = episode
    pred = momakitchen.predict(**_inputs(ep), rgb=ep.rgb, checkpoint=tiny_run, mc_samples=0)
    paths = write_outputs(
        pred, tmp_path / "out", ep.rgb, ep.depth, tuple(ep.intrinsics), ep.camera_to_base
    )
    assert paths["png"].stat().st_size > 10_000
    assert json.loads(paths["json"].read_text())["poses"]
    with pytest.raises(MomaError, match="intrinsics must be fx, fy, cx, cy"):
        write_outputs(pred, tmp_path / "bad", ep.rgb, ep.depth, (1.0, 2.0), ep.camera_to_base)
    assert not (tmp_path / "bad").exists()


def test_write_outputs_names_the_image_the_intrinsics_do_not_fit(episode, tiny_run, tmp_path):
    """Intrinsics for another image size are checked against the depth image, or without
    one against the RGB image, and the error names which."""
    from momakitchen.deploy.predict import write_outputs
    from momakitchen.perception.camera import Intrinsics

    ep = episode
    pred = momakitchen.predict(**_inputs(ep), rgb=ep.rgb, checkpoint=tiny_run, mc_samples=0)
    h, w = ep.depth.shape
    full = Intrinsics(*map(float, ep.intrinsics), w, h)
    with pytest.raises(MomaError, match=f"but the RGB image is {w // 2}x{h // 2}"):
        write_outputs(pred, tmp_path / "bad", ep.rgb[::2, ::2], None, full, ep.camera_to_base)
    with pytest.raises(MomaError, match=f"but the depth image is {w // 2}x{h // 2}"):
        write_outputs(pred, tmp_path / "bad", ep.rgb, ep.depth[::2, ::2], full, None)
    assert not (tmp_path / "bad").exists()


def test_a_target_beyond_the_training_views_gives_a_warning(episode, tiny_run):
    from momakitchen.models.inference import TRAINED_DISTANCE, predict_map
    from momakitchen.perception.floor import fit_floor
    from momakitchen.perception.live import FrameClouds
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec
    from momakitchen.train import load_checkpoint

    ep = episode
    run = load_checkpoint(tiny_run)
    desc = np.asarray(robot_descriptor(get_robot_spec(ep.robot)), np.float32)
    arrays = {k: getattr(ep, k) for k in ("global_xyz", "global_rgb", "global_align")}
    correction = fit_floor(ep.floor_xyz.astype(np.float64), ep.camera_to_base[:3, 3])
    for x, warned in ((TRAINED_DISTANCE - 0.5, False), (TRAINED_DISTANCE + 0.5, True)):
        clouds = FrameClouds(
            **arrays,
            floor_xyz=ep.floor_xyz,
            target_xyz=np.array([x, 0.0, 1.0]),
            correction=correction,
        )
        pred = predict_map(run, clouds, ep.robot, desc, mc_samples=0)
        assert bool(pred.warnings) == warned
        assert pred.to_dict(floor_points=False)["target_distance_m"] == pytest.approx(x, abs=1e-3)
    assert "move closer" in pred.warnings[0]
    # A run trained on farther views (as its config.json records) warns only beyond them.
    far = dataclasses.replace(run, view_distance=6.0)
    clouds = FrameClouds(
        **arrays,
        floor_xyz=ep.floor_xyz,
        target_xyz=np.array([5.5, 0.0, 1.0]),
        correction=correction,
    )
    assert not predict_map(far, clouds, ep.robot, desc, mc_samples=0).warnings


def test_a_robot_by_name_at_another_mount_is_its_descriptor_there(episode, tiny_run):
    """``(name, mount_height)`` gives the model the descriptor at that mount, as the
    descriptor itself does, and keeps the name, which a model's gates read the URDF by."""
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import get_robot_spec

    inputs = {k: v for k, v in _inputs(episode).items() if k != "robot"}
    by_name = momakitchen.predict(**inputs, robot=("ur10e", 1.3), checkpoint=tiny_run)
    vector = robot_descriptor(get_robot_spec("ur10e"), 1.3)
    by_vector = momakitchen.predict(**inputs, robot=vector, checkpoint=tiny_run)
    np.testing.assert_array_equal(by_name.affordance, by_vector.affordance)
    with pytest.raises(MomaError, match=r"mount_height must be in \[0.3, 1.3\]"):
        momakitchen.predict(**inputs, robot=("ur10e", 1.6), checkpoint=tiny_run)


def test_opens_leaves_the_shipped_body_models_dexterity_weight_off(episode, tmp_path):
    """``opens=True``: the shipped ``body`` (``index_picks_only``) predicts what it does
    without its dexterity weight; ``opens=False`` (the default), what it does with it."""
    from momakitchen.train.checkpoint import SHIPPED_CHECKPOINTS, load_checkpoint
    from script_helpers import load_script

    gate = load_script("gate_checkpoint")
    body = SHIPPED_CHECKPOINTS["body"]
    for name, index in (("weighted", 0.5), ("unweighted", 0.0)):
        gate.gate_copy(body, tmp_path / name, 0.03, 8, footprint=True, index=index)
    inputs = dict(_inputs(episode), obstacle_masks=[episode.semantic == OBSTACLE], mc_samples=0)

    def scores(checkpoint, **fields):
        run = load_checkpoint(checkpoint)
        return momakitchen.predict(**inputs, checkpoint=run, **fields).affordance

    picked, opened = scores("body"), scores("body", opens=True)
    assert not np.allclose(picked, opened)  # the weight matters on this view
    np.testing.assert_array_equal(picked, scores(tmp_path / "weighted", opens=True))
    np.testing.assert_array_equal(opened, scores(tmp_path / "unweighted"))
