"""How much floor does the standable mask take from the maps, and does the base really
collide there? Per test configuration and view, the floor points within the robot's reach
where the grid trials' interpolation is positive, split by the floor-plan check that the
labels use (docs/LABELS.md: the base's box, facing the target, clear of the floor-plan
footprints); a sample of each side is checked in PyBullet with the trial's own first check
(`TrialRunner.base_free`).

    python analyses/mask_band.py --data ~/mk-data/gt2-300 --every 5

Prints, per target and overall: the positive floor points, the share the mask zeroes (the
"band"), the share of the band the base fits in PyBullet, and the share of the unmasked
points where the base collides in PyBullet (0 if the floor plan is conservative, as the
labels promise). The samples are drawn per view with a seed of (scene, configuration,
view): the same input prints the same table.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np
from analysis_cli import run_main
from tqdm.auto import tqdm

from momakitchen.data.config import GenerationConfig
from momakitchen.data.manifest import load_manifest
from momakitchen.data.reader import rebuilt_configurations, split_configurations
from momakitchen.errors import MomaError
from momakitchen.frames import base_to_world_xy
from momakitchen.robots.spec import get_robot_spec
from momakitchen.scene.configuration import base_fits
from momakitchen.sim.labels import dense_map, in_sampling_area
from momakitchen.sim.trials import TrialRunner
from momakitchen.sim.world import World

COLUMNS = (
    "positive points",
    "masked (band)",
    "band: base fits in PyBullet",
    "unmasked: base collides in PyBullet",
)


def _sample(rng: np.random.Generator, idx: np.ndarray, n: int) -> np.ndarray:
    return rng.choice(idx, min(n, len(idx)), replace=False) if len(idx) else idx


def count(data: Path, every: int, sample: int, progress: bool = False) -> dict[str, np.ndarray]:
    """Per target category (and ``"all"``): (6,) counts: positive points, masked points,
    band points checked, of them free, unmasked points checked, of them colliding."""
    manifest = load_manifest(data)
    gen = GenerationConfig.from_dict(manifest["config"])
    todo = split_configurations(manifest, "test")[::every]
    if not todo:
        raise MomaError(f"dataset {str(data)!r} has no test configurations")
    totals: dict[str, np.ndarray] = defaultdict(lambda: np.zeros(6, np.int64))
    bar = tqdm(todo, desc="configurations", disable=not progress)
    for scene, shard, ci in rebuilt_configurations(data, bar, gen.scene):
        cfg = scene.configurations[ci]
        grid = shard.configuration(ci)
        views = [shard.episode(ci, e) for e in shard.episode_indices(ci)]
        with World(scene.layout) as world:
            world.load_configuration(cfg)
            runner = TrialRunner(world, cfg.robot, gen.trial)
            try:
                for ep in views:
                    xy = base_to_world_xy(ep.floor_xyz[:, :2].astype(np.float64), ep.base_pose)
                    interp = dense_map(grid.trial_positions, grid.trial_outcomes, xy, gen.dense)
                    positive = np.flatnonzero((interp > 0) & in_sampling_area(cfg, xy))
                    footprint = get_robot_spec(cfg.robot).footprint
                    fits = base_fits(scene.layout, cfg, xy[positive], footprint)
                    rng = np.random.default_rng([ep.scene_id, ci, ep.episode_index])
                    band = _sample(rng, positive[~fits], sample)
                    kept = _sample(rng, positive[fits], sample)
                    free = sum(runner.base_free(*xy[i]) for i in band)
                    hit = sum(not runner.base_free(*xy[i]) for i in kept)
                    row = [len(positive), int((~fits).sum()), len(band), free, len(kept), hit]
                    for key in (grid.target, "all"):
                        totals[key] += row
            finally:
                runner.close()
    return dict(totals)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--every", type=int, default=1, help="every N-th test configuration")
    ap.add_argument("--sample", type=int, default=20, help="points per view and side checked")
    args = ap.parse_args()
    for name in ("every", "sample"):
        if getattr(args, name) < 1:
            raise MomaError(f"--{name} must be >= 1, got {getattr(args, name)}")
    totals = count(args.data, args.every, args.sample, progress=True)
    print("| target | " + " | ".join(COLUMNS) + " |")
    print("| --- |" + " ---: |" * len(COLUMNS))
    for key in sorted(totals, key=lambda k: (k == "all", -totals[k][0])):
        pos, masked, band, free, kept, hit = (int(v) for v in totals[key])
        cells = [
            str(pos),
            f"{masked / pos:.0%}" if pos else "–",
            f"{free / band:.0%} of {band}" if band else "–",
            f"{hit / kept:.1%} of {kept}" if kept else "–",
        ]
        print(f"| {key} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    run_main(main, "mask_band.py")
