"""Interop with the folder layout of the MoMa-Kitchen reference release.

Layout written by :func:`export_reference` (and read by the reference data loader)::

    DIR/data_split/kitchen_train.txt, kitchen_test.txt    one episode item per line
    DIR/rgbd/<item>/                                      item = rgbd_<detail>/episode_EEE
        point_cloud_transformed/world_pcd_transformed.ply         global cloud (x y z,
                                                                   red green blue, align)
        point_cloud_transformed/filtered_pcd_z_less_than_0_02.ply floor cloud (x y z)
        point_cloud_transformed/target_pcd_transformed.ply        target points
        point_cloud_transformed/barrier_0_pcd_transformed.ply     obstacle points (if any)
        filtered_transformed_results_with_gaussian_success_rate.txt  "x,y,z,value" rows
        rgb.png, semantic.png, depth.npy, camera.json             images and camera
    DIR/info/<detail>/trial_info.json                     robot_name, trials, target, ...

with ``detail = scene_SSSSSS_config_CCC``; the reference loader finds ``trial_info.json``
at ``info/<item's first component minus its 'rgbd_' prefix>``. Clouds are in the
viewpoint's robot base frame, float32, binary PLY; labels are written with 9 significant
digits, so float32 values survive the round trip exactly.

:func:`import_reference` reads that layout (also from the reference release itself:
images, camera files and our extra fields are optional; the alignment channel is then
rebuilt from the target/barrier clouds with the reference's 0.031 m matching threshold)
and writes a dataset of shards with a manifest.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data import manifest as mf
from momakitchen.data.episode import ConfigurationLabels, Episode
from momakitchen.data.ply import read_ply, write_ply
from momakitchen.data.shard import SCENES_DIR, SceneShard, list_shards, write_shard
from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict, existing_dir, read_json_object
from momakitchen.frames import float3
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import get_robot_spec

CLOUD_DIR = "point_cloud_transformed"
GLOBAL_PLY = "world_pcd_transformed.ply"
FLOOR_PLY = "filtered_pcd_z_less_than_0_02.ply"
TARGET_PLY = "target_pcd_transformed.ply"
BARRIER_PLY = "barrier_{}_pcd_transformed.ply"
LABEL_TXT = "filtered_transformed_results_with_gaussian_success_rate.txt"
TRIAL_INFO = "trial_info.json"
ALIGN_THRESHOLD = 0.031  # the reference loader's target/barrier matching distance (m)
ROBOT_ALIASES = {"xarm": "xarm6"}  # reference names -> registry names
_DETAIL = re.compile(r"scene_(\d+)_config_(\d+)$")
_EPISODE = re.compile(r"episode_(\d+)$")


def _detail(scene_id: int, config_index: int) -> str:
    return f"scene_{scene_id:06d}_config_{config_index:03d}"


def export_reference(root: str | os.PathLike, out: str | os.PathLike) -> dict[str, int]:
    """Write the dataset at ``root`` in the reference layout under ``out``.

    Returns counts ``{"configurations", "episodes"}``. ``out`` must be empty or missing.
    """
    from PIL import Image

    root, out = Path(root), Path(out)
    manifest = mf.load_manifest(root)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise MomaError(f"--out {str(out)!r} exists and is not an empty directory")
    shards = list_shards(root)
    items: dict[str, list[str]] = {s: [] for s in mf.SPLITS}
    n_cfg = n_ep = 0
    for key, entry in manifest["shards"].items():
        sid = int(key)
        if sid not in shards:
            raise MomaError(f"shard {entry['file']} listed in the manifest is missing")
        with SceneShard(shards[sid]) as shard:
            for c in shard.config_indices():
                lab = shard.configuration(c)
                detail = _detail(sid, c)
                info_dir = out / "info" / detail
                info_dir.mkdir(parents=True)
                episodes = shard.episode_indices(c)
                first = (
                    shard.arrays(c, episodes[0], ["descriptor"])["descriptor"]
                    if episodes
                    else np.asarray(robot_descriptor(get_robot_spec(lab.robot), lab.mount_height))
                )
                info = {
                    "robot_name": lab.robot,
                    "scene_id": sid,
                    "config_index": c,
                    "target": lab.target,
                    "anchor": list(lab.anchor),
                    "descriptor": first.tolist(),
                    "trial_positions": lab.trial_positions.tolist(),
                    "trial_yaws": lab.trial_yaws.tolist(),
                    "trial_stages": lab.trial_stages.tolist(),
                    "trial_moved": lab.trial_moved.astype(float).tolist(),
                }
                (info_dir / TRIAL_INFO).write_text(dumps_strict(info) + "\n")
                n_cfg += 1
                for e in episodes:
                    ep = shard.episode(c, e)
                    item = f"rgbd_{detail}/episode_{e:03d}"
                    _export_episode(ep, out / "rgbd" / item, Image)
                    items[entry["split"]].append(item)
                    n_ep += 1
    split_dir = out / "data_split"
    split_dir.mkdir(parents=True, exist_ok=True)
    for split, names in items.items():
        (split_dir / f"kitchen_{split}.txt").write_text("".join(f"{n}\n" for n in names))
    return {"configurations": n_cfg, "episodes": n_ep}


def _export_episode(ep: Episode, folder: Path, image_module: Any) -> None:
    clouds = folder / CLOUD_DIR
    clouds.mkdir(parents=True)
    g, rgb = ep.global_xyz, ep.global_rgb
    write_ply(
        clouds / GLOBAL_PLY,
        {
            "x": g[:, 0],
            "y": g[:, 1],
            "z": g[:, 2],
            "red": rgb[:, 0],
            "green": rgb[:, 1],
            "blue": rgb[:, 2],
            "align": ep.global_align.astype(np.int8),
        },
    )
    f = ep.floor_xyz
    write_ply(clouds / FLOOR_PLY, {"x": f[:, 0], "y": f[:, 1], "z": f[:, 2]})
    for name, flag in ((TARGET_PLY, 1), (BARRIER_PLY.format(0), -1)):
        pts = g[ep.global_align == flag]
        if flag == 1 or len(pts):
            write_ply(clouds / name, {"x": pts[:, 0], "y": pts[:, 1], "z": pts[:, 2]})
    rows = np.column_stack([f.astype(np.float64), ep.floor_label.astype(np.float64)])
    np.savetxt(folder / LABEL_TXT, rows, fmt="%.9g", delimiter=",")
    if ep.rgb.size:
        image_module.fromarray(ep.rgb).save(folder / "rgb.png")
        image_module.fromarray(ep.semantic).save(folder / "semantic.png")
    np.save(folder / "depth.npy", ep.depth)
    camera = {
        "intrinsics": ep.intrinsics.tolist(),
        "camera_pose": ep.camera_pose.tolist(),
        "camera_to_base": ep.camera_to_base.tolist(),
        "base_pose": list(ep.base_pose),
        "frames": "camera_pose: camera-to-world (OpenCV axes); camera_to_base: camera "
        "to the viewpoint's robot base frame; clouds are in that base frame",
    }
    (folder / "camera.json").write_text(dumps_strict(camera) + "\n")


def _discover(src: Path) -> list[tuple[str, str | None]]:
    """(item, split) pairs from the split files, or every episode folder under rgbd/."""
    split_dir = src / "data_split"
    pairs: list[tuple[str, str | None]] = []
    if split_dir.is_dir():
        for split in mf.SPLITS:
            f = split_dir / f"kitchen_{split}.txt"
            if f.is_file():
                pairs += [
                    (line.strip(), split) for line in f.read_text().splitlines() if line.strip()
                ]
    if not pairs:
        base = _rgbd_root(src)
        pairs = sorted(
            (str(p.parent.relative_to(base)), None) for p in base.glob(f"**/{CLOUD_DIR}")
        )
    if not pairs:
        raise MomaError(
            f"{src}: no episodes in the reference layout (no data_split/*.txt "
            f"and no */{CLOUD_DIR} folders)"
        )
    return pairs


def _rgbd_root(src: Path) -> Path:
    return src / "rgbd" if (src / "rgbd").is_dir() else src


def _floor(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    clouds = folder / CLOUD_DIR
    ply = read_ply(clouds / FLOOR_PLY)
    xyz = np.column_stack([ply["x"], ply["y"], ply["z"]]).astype(np.float32)
    txt = next(iter(sorted(folder.glob("*_gaussian_success_rate.txt"))), None)
    if txt is None:
        raise MomaError(f"{folder}: no *_gaussian_success_rate.txt")
    try:
        text = txt.read_text().replace(",", " ")
        rows = np.loadtxt(text.splitlines(), dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as exc:
        raise MomaError(f"{txt}: malformed label rows ({exc})") from None
    if rows.shape[0] == 0:
        rows = rows.reshape(0, 4)
    if rows.shape[1] != 4 or rows.shape[0] != xyz.shape[0]:
        raise MomaError(
            f"{txt}: {rows.shape} rows for {xyz.shape[0]} floor points; "
            "expected x,y,z,value per floor point"
        )
    return xyz, np.clip(rows[:, 3], 0.0, 1.0).astype(np.float32)


def _global(folder: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    clouds = folder / CLOUD_DIR
    ply = read_ply(clouds / GLOBAL_PLY)
    xyz = np.column_stack([ply["x"], ply["y"], ply["z"]]).astype(np.float32)
    if all(k in ply for k in ("red", "green", "blue")):
        rgb = np.column_stack([ply["red"], ply["green"], ply["blue"]]).astype(np.uint8)
    else:
        rgb = np.zeros_like(xyz, dtype=np.uint8)
    if "align" in ply:
        return xyz, rgb, ply["align"].astype(np.int8)
    # The reference's visual alignment: points within 3.1 cm of the target / barrier clouds.
    from scipy.spatial import cKDTree

    align = np.zeros(len(xyz), np.int8)
    for name, flag in [(TARGET_PLY, 1)] + [(BARRIER_PLY.format(i), -1) for i in range(8)]:
        path = clouds / name
        if not path.is_file():
            continue
        p = read_ply(path)
        pts = np.column_stack([p["x"], p["y"], p["z"]])
        if len(pts) and len(xyz):
            dist, _ = cKDTree(pts).query(xyz, k=1)
            align[dist < ALIGN_THRESHOLD] = flag
    return xyz, rgb, align


def _episode_from_folder(
    folder: Path, sid: int, c: int, e: int, robot: str, descriptor: np.ndarray
) -> Episode:
    from PIL import Image

    gxyz, grgb, align = _global(folder)
    fxyz, label = _floor(folder)
    depth = (
        np.load(folder / "depth.npy")
        if (folder / "depth.npy").is_file()
        else np.zeros((0, 0), np.float32)
    )
    h, w = depth.shape
    rgb = (
        np.asarray(Image.open(folder / "rgb.png").convert("RGB"))
        if (folder / "rgb.png").is_file()
        else np.zeros((h, w, 3), np.uint8)
    )
    sem = (
        np.asarray(Image.open(folder / "semantic.png"))
        if (folder / "semantic.png").is_file()
        else np.zeros((h, w), np.uint8)
    )
    cam = read_json_object(folder / "camera.json") if (folder / "camera.json").is_file() else {}
    return Episode(
        scene_id=sid,
        config_index=c,
        episode_index=e,
        robot=robot,
        descriptor=descriptor,
        rgb=rgb,
        depth=depth.astype(np.float32),
        semantic=sem.astype(np.uint8),
        intrinsics=np.asarray(cam.get("intrinsics", np.zeros(4)), np.float64),
        camera_pose=np.asarray(cam.get("camera_pose", np.eye(4)), np.float64),
        base_pose=float3(cam.get("base_pose", (0.0, 0.0, 0.0))),
        camera_to_base=np.asarray(cam.get("camera_to_base", np.eye(4)), np.float64),
        global_xyz=gxyz,
        global_rgb=grgb,
        global_align=align,
        floor_xyz=fxyz,
        floor_label=label,
    )


def import_reference(src: str | os.PathLike, out: str | os.PathLike) -> dict[str, Any]:
    """Read the reference layout at ``src`` and write a dataset (shards + manifest) to
    ``out`` (empty or missing). Returns the manifest.

    Folder names ``scene_S_config_C`` / ``episode_E`` keep their ids; otherwise every
    configuration folder becomes its own scene, numbered in sorted order. Splits come from
    ``data_split/kitchen_{train,test}.txt`` when present, else from the scene-id rule.
    """
    from momakitchen.data.card import write_dataset_card

    src, out = existing_dir(src, "reference directory"), Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise MomaError(f"--out {str(out)!r} exists and is not an empty directory")
    pairs = _discover(src)
    rgbd = _rgbd_root(src)
    # Group episode items by configuration folder ("detail").
    groups: dict[str, list[tuple[str, str | None]]] = {}
    for item, split in pairs:
        head = item.split("/")[0]
        groups.setdefault(head, []).append((item, split))
    ids: dict[str, tuple[int, int]] = {}
    parsed = {h: _DETAIL.search(h) for h in groups}
    matched = {h: m for h, m in parsed.items() if m is not None}
    if len(matched) == len(parsed):
        ids = {h: (int(m.group(1)), int(m.group(2))) for h, m in matched.items()}
    else:
        ids = {h: (i, 0) for i, h in enumerate(sorted(groups))}
    scenes: dict[int, dict[int, str]] = {}
    for h, (sid, c) in ids.items():
        scenes.setdefault(sid, {})[c] = h
    manifest = mf.new_manifest(
        "momakitchen.data.reference.import_reference", {"source": str(src.resolve())}
    )
    (out / SCENES_DIR).mkdir(parents=True, exist_ok=True)
    for sid in sorted(scenes):
        records = []
        splits = set()
        for new_c, (_, head) in enumerate(sorted(scenes[sid].items())):
            detail = head[5:] if head.startswith("rgbd_") else head
            info_path = next(
                (
                    p
                    for p in (src / "info" / detail / TRIAL_INFO, rgbd / head / TRIAL_INFO)
                    if p.is_file()
                ),
                None,
            )
            if info_path is None:
                raise MomaError(
                    f"{head}: no {TRIAL_INFO} (looked in info/{detail}/ and rgbd/{head}/)"
                )
            info = read_json_object(info_path)
            if "robot_name" not in info:
                raise MomaError(f"{info_path}: no robot_name")
            robot = ROBOT_ALIASES.get(info["robot_name"], info["robot_name"])
            desc = (
                np.asarray(info["descriptor"], np.float32)
                if "descriptor" in info
                else np.asarray(robot_descriptor(get_robot_spec(robot)), np.float32)
            )
            labels = ConfigurationLabels(
                scene_id=sid,
                config_index=new_c,
                robot=robot,
                target=str(info.get("target", "unknown")),
                anchor=float3(info.get("anchor", (0.0, 0.0, 0.0))),
                trial_positions=np.asarray(info.get("trial_positions", []), np.float64).reshape(
                    -1, 2
                ),
                trial_yaws=np.asarray(info.get("trial_yaws", []), np.float64),
                trial_stages=np.asarray(info.get("trial_stages", []), np.uint8),
                trial_moved=np.asarray(info.get("trial_moved", []), np.float32),
            )
            items = sorted(groups[head], key=lambda p: p[0])
            episodes = []
            for new_e, (item, split) in enumerate(items):
                splits.add(split)
                episodes.append(_episode_from_folder(rgbd / item, sid, new_c, new_e, robot, desc))
            records.append((labels, episodes))
        summary = write_shard(out / SCENES_DIR, sid, records)
        split = next(iter(splits)) if len(splits) == 1 and None not in splits else None
        if len(splits - {None}) > 1:
            raise MomaError(f"scene {sid} has episodes in both splits; splits must be by scene")
        mf.add_shard(manifest, summary, split)
    mf.finalize(manifest, complete=True)
    mf.save_manifest(out, manifest)
    write_dataset_card(out, manifest)
    return manifest
