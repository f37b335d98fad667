"""Reference-layout interop: export then import gives the same dataset; PLY I/O."""

from __future__ import annotations

import json

import numpy as np
import pytest

from momakitchen.cli.main import main
from momakitchen.data.integrity import check_dataset
from momakitchen.data.manifest import load_manifest
from momakitchen.data.ply import read_ply, write_ply
from momakitchen.data.reference import (
    BARRIER_PLY,
    CLOUD_DIR,
    GLOBAL_PLY,
    LABEL_TXT,
    import_reference,
)
from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.errors import MomaError


def test_export_import_round_trip(small_dataset, tmp_path, capsys):
    ref, back = tmp_path / "ref", tmp_path / "back"
    assert main(["export-reference", str(small_dataset), "--out", str(ref)]) == 0
    assert main(["import-reference", str(ref), "--out", str(back)]) == 0
    capsys.readouterr()
    item = "rgbd_scene_000000_config_001/episode_002"
    folder = ref / "rgbd" / item
    assert (folder / CLOUD_DIR / GLOBAL_PLY).is_file() and (folder / LABEL_TXT).is_file()
    info = json.loads((ref / "info" / "scene_000000_config_001" / "trial_info.json").read_text())
    assert info["robot_name"] in {"panda", "flexiv", "ur5e", "xarm6", "realman", "elephant"}
    split = load_manifest(small_dataset)["shards"]["0"]["split"]
    assert item in (ref / "data_split" / f"kitchen_{split}.txt").read_text().split()
    rows = np.loadtxt(folder / LABEL_TXT, delimiter=",")
    assert rows.ndim == 2 and rows.shape[1] == 4
    m_in, m_out = load_manifest(small_dataset), load_manifest(back)
    assert m_out["splits"] == m_in["splits"] and m_out["counts"] == m_in["counts"]
    assert check_dataset(back)["episodes"] == 30
    a, b = list_shards(small_dataset), list_shards(back)
    assert list(a) == list(b)
    for sid in a:
        with SceneShard(a[sid]) as sa, SceneShard(b[sid]) as sb:
            for (la, ea), (lb, eb) in zip(sa.records(), sb.records(), strict=True):
                assert (la.robot, la.target, la.anchor) == (lb.robot, lb.target, lb.anchor)
                np.testing.assert_array_equal(la.trial_stages, lb.trial_stages)
                np.testing.assert_allclose(la.trial_positions, lb.trial_positions, atol=1e-9)
                for x, y in zip(ea, eb, strict=True):
                    for f in (
                        "global_xyz",
                        "floor_xyz",
                        "floor_label",
                        "camera_pose",
                        "intrinsics",
                        "descriptor",
                    ):
                        np.testing.assert_allclose(getattr(x, f), getattr(y, f), atol=1e-6)
                    for f in ("global_rgb", "global_align", "rgb", "semantic", "depth"):
                        np.testing.assert_array_equal(getattr(x, f), getattr(y, f))


def test_import_of_a_plain_reference_folder_rebuilds_alignment(small_dataset, tmp_path):
    """The reference release has no align property, images or camera files."""
    ref = tmp_path / "ref"
    main(["export-reference", str(small_dataset), "--out", str(ref)])
    for folder in (ref / "rgbd").glob("*/*"):
        ply = read_ply(folder / CLOUD_DIR / GLOBAL_PLY)
        write_ply(folder / CLOUD_DIR / GLOBAL_PLY, {k: ply[k] for k in ("x", "y", "z")})
        for name in ("rgb.png", "semantic.png", "depth.npy", "camera.json"):
            (folder / name).unlink()
    for info in (ref / "info").glob("*/trial_info.json"):
        data = json.loads(info.read_text())
        info.write_text(json.dumps({"robot_name": data["robot_name"]}))
    import_reference(ref, tmp_path / "back")
    with (
        SceneShard(list_shards(small_dataset)[0]) as sa,
        SceneShard(list_shards(tmp_path / "back")[0]) as sb,
    ):
        x, y = sa.episode(0, 0), sb.episode(0, 0)
    # Every flagged point is recovered; a few unflagged neighbours within 3.1 cm may join.
    assert np.all(y.global_align[x.global_align == 1] == 1)
    assert np.all(y.global_align[x.global_align == -1] == -1)
    np.testing.assert_array_equal(x.floor_label, y.floor_label)
    np.testing.assert_allclose(x.descriptor, y.descriptor)
    assert y.rgb.shape == (0, 0, 3)
    assert (
        ref
        / "rgbd"
        / "rgbd_scene_000000_config_000"
        / "episode_000"
        / CLOUD_DIR
        / BARRIER_PLY.format(0)
    ).exists() or not np.any(x.global_align == -1)


def test_ply_ascii_and_errors(tmp_path):
    p = tmp_path / "a.ply"
    p.write_text(
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
        "property float z\nproperty uchar red\nend_header\n0 1 2 255\n3 4 5 7\n"
    )
    d = read_ply(p)
    np.testing.assert_array_equal(d["y"], [1, 4])
    assert d["red"].dtype == np.uint8 and d["red"][1] == 7
    write_ply(tmp_path / "b.ply", {"x": np.arange(3, dtype=np.float32)})
    data = (tmp_path / "b.ply").read_bytes()
    (tmp_path / "b.ply").write_bytes(data[:-2])
    with pytest.raises(MomaError, match="truncated"):
        read_ply(tmp_path / "b.ply")


def test_export_refuses_non_empty_out(small_dataset, tmp_path):
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "keep").write_text("1")
    with pytest.raises(MomaError, match="not an empty directory"):
        from momakitchen.data.reference import export_reference

        export_reference(small_dataset, tmp_path / "x")
