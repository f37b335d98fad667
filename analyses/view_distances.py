"""How far a dataset's views stand from their targets, and how many stand as far as a
driven robot starts where the room holds such a viewpoint.

    python analyses/view_distances.py --data far-start

For every view, the distance on the floor from the viewing base to the target's anchor.
Prints the views' count, median, 10th and 90th percentiles and farthest distance, and the
share of views at least ``--far-from`` m away: over all views, and over the views of the
configurations whose room holds a viewpoint ``--far-from`` to ``--far-to`` m from the
target within ``--max-angle`` degrees of its front, the base in the room and clear of
furniture and obstacles (``far_view_points``, the rule ``views.far_share`` follows; by
default the driven track's far starts, 3.8-6 m within 45 degrees). The configurations are
rebuilt from their scene ids and the dataset's generation config (no simulator).

With ``--points N`` it also prints, by distance band, the median number of the target's
points among the N a model draws from the view's cloud (``EpisodeCollator``, seed 0; the
cpu preset's ``num_global`` is 2048): what of the target a far look leaves the model.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.data import EpisodeDataset
from momakitchen.data.batch import EpisodeCollator
from momakitchen.data.reader import dataset_generation, rebuilt_configurations, split_configurations
from momakitchen.errors import MomaError
from momakitchen.generation.producer import far_view_points
from momakitchen.robots import get_robot_spec


def view_distances(
    root: Path, far_from: float, far_to: float, max_angle: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each view's floor distance from its target (V,) m, and (V,) whether its
    configuration's room holds a viewpoint ``far_from`` to ``far_to`` m away."""
    manifest, gen = dataset_generation(root)
    views = dataclasses.replace(
        gen.views,
        distance=(min(0.75, far_from), far_to),
        max_angle=max_angle,
        far_share=0.0,
        far_from=far_from,
    )
    dist, room = [], []
    todo = split_configurations(manifest, "all")
    for scene, shard, ci in rebuilt_configurations(root, todo, gen.scene):
        cfg = scene.configurations[ci]
        anchor = np.asarray(shard.configuration(ci).anchor, float)
        footprint = get_robot_spec(cfg.robot).footprint
        far = far_view_points(
            scene.layout, cfg, views, footprint, cfg.mount + gen.camera.above_mount
        )
        for e in shard.episode_indices(ci):
            base = np.asarray(shard.episode_attrs(ci, e)["base_pose"], float)
            dist.append(float(np.hypot(*(base[:2] - anchor[:2]))))
            room.append(len(far) > 0)
    if not dist:
        raise MomaError(f"dataset {str(root)!r} has no views")
    return np.asarray(dist), np.asarray(room, bool)


# The distance bands --points reports, m.
BANDS = (0.0, 2.0, 3.0, 3.8, 10.0)


def target_points(root: Path, points: int) -> np.ndarray:
    """(V,) how many of each view's ``points`` cloud points a model draws are the target's,
    in :func:`view_distances`'s order; -1 for a view without points (a model is never
    given it: ``EpisodeDataset`` leaves it out)."""
    data = EpisodeDataset(root, "all")
    draw = EpisodeCollator(num_global=points, num_floor=1, seed=0)
    counts = {
        (sid, c, e): int((draw([data[i]])["global_align"][0] > 0).sum())
        for i, (_file, sid, c, e, _robot) in enumerate(data.index)
    }
    shards = data.manifest["shards"]
    return np.asarray(
        [
            counts.get((sid, c, e), -1)
            for sid, c, _file in split_configurations(data.manifest, "all")
            for e in range(shards[str(sid)]["episodes_per_config"][c])
        ]
    )


def format_points(dist: np.ndarray, target: np.ndarray, points: int) -> str:
    lines = [f"the target's points among the {points} a model draws, by view distance:"]
    for lo, hi in itertools.pairwise(BANDS):
        band = (dist >= lo) & (dist < hi) & (target >= 0)
        if band.any():
            lines.append(
                f"  {lo:g}-{hi:g} m: {int(band.sum())} views, median {np.median(target[band]):.0f}"
            )
    return "\n".join(lines)


def format_distances(dist: np.ndarray, room: np.ndarray, far_from: float) -> str:
    q10, q50, q90 = np.percentile(dist, [10, 50, 90])
    far = dist >= far_from
    lines = [
        f"views {len(dist)}: median {q50:.2f} m (10th percentile {q10:.2f}, 90th {q90:.2f}), "
        f"farthest {dist.max():.2f} m",
        f"{far_from:g} m or more: {far.mean():.1%} of all views; "
        f"{far[room].mean() if room.any() else float('nan'):.1%} of the {int(room.sum())} views "
        f"whose room holds such a viewpoint ({room.mean():.1%} of the views)",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="a simulator-made dataset")
    ap.add_argument("--far-from", type=float, default=3.8)
    ap.add_argument("--far-to", type=float, default=6.0)
    ap.add_argument("--max-angle", type=float, default=45.0)
    ap.add_argument("--points", type=int, default=0, help="a model's cloud draw (0: off)")
    args = ap.parse_args()
    if args.points < 0:
        raise MomaError(f"--points must be 0 (off) or a point count, got {args.points}")
    if not 0.5 <= args.far_from < args.far_to <= 10:
        raise MomaError(
            f"--far-from and --far-to must satisfy 0.5 <= from < to <= 10 m, "
            f"got {args.far_from} and {args.far_to}"
        )
    dist, room = view_distances(args.data, args.far_from, args.far_to, args.max_angle)
    print(format_distances(dist, room, args.far_from))
    if args.points:
        print(format_points(dist, target_points(args.data, args.points), args.points))


if __name__ == "__main__":
    run_main(main, "view_distances.py")
