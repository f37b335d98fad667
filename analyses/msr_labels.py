"""Do the ground-truth maps predict the closed-loop trials? The label at each method's Top-1
point of a `momakitchen msr` result against that trial's outcome.

    python analyses/msr_labels.py --data ~/mk-data/gt2-300 \
        --msr ~/mk-runs/navaff/msr.json ~/mk-runs/msr-baselines.json --versus oracle

Per method: Top-1 success binned by the ground-truth value at the chosen floor point (the
MSR picks are the view's floor points, whose labels the episode stores); label-0 points are
split by whether the interpolation of the grid trials alone is positive there (then the
standable mask, docs/LABELS.md, set the label to 0: the base's box meets a floor-plan
footprint) or 0 (no successful trial nearby). With
``--versus M``: the same label for the configurations where a method failed and M
succeeded, i.e. whether the method chose where the labels said no, or the labels were wrong.
Results of several MSR seeds (each judges every configuration on another of its views) are
counted together, view by view (methods missing from a seed are left out); ``NAME=FILE``
renames a file's one method, as in ``msr_views.py``.
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np
from analysis_cli import run_main
from msr_views import by_seed

from momakitchen.data.config import GenerationConfig
from momakitchen.data.manifest import load_manifest
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError
from momakitchen.eval.report.tables import top1_outcomes
from momakitchen.frames import base_to_world_xy
from momakitchen.sim.labels import dense_map

BINS = (0.0, 0.3, 0.6, 0.9, 1.0 + 1e-9)  # above 0: (0, 0.3), [0.3, 0.6), ...
COLUMNS = ("0, masked", "0, no success near", "(0, 0.3)", "[0.3, 0.6)", "[0.6, 0.9)", "[0.9, 1]")


def labels_at_picks(data: Path, msr: dict) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Ground-truth label at every method's Top-1 point, and the grid trials' interpolation
    there without the standable mask, per record: two {method: (R,)} (NaN where the method
    chose no point)."""
    manifest = load_manifest(data)
    dense = GenerationConfig.from_dict(manifest["config"]).dense
    out = {m: np.full(len(msr["records"]), np.nan) for m in msr["methods"]}
    raw = {m: np.full(len(msr["records"]), np.nan) for m in msr["methods"]}
    shard, file = None, None
    for i, rec in enumerate(msr["records"]):
        entry = manifest["shards"][str(rec["scene_id"])]
        if entry["file"] != file:
            if shard is not None:
                shard.close()
            file, shard = entry["file"], SceneShard(data / entry["file"])
        assert shard is not None
        ep = shard.episode(rec["config_index"], rec["episode_index"])
        grid = shard.configuration(rec["config_index"])
        world_xy = base_to_world_xy(ep.floor_xyz[:, :2].astype(np.float64), ep.base_pose)
        for m, chosen in rec["methods"].items():
            if chosen["points"]:  # points are stored rounded to 0.1 mm: the nearest one
                j = np.argmin(np.hypot(*(world_xy - chosen["points"][0]).T))
                out[m][i] = float(ep.floor_label[j])
                raw[m][i] = dense_map(
                    grid.trial_positions, grid.trial_outcomes, world_xy[j][None], dense
                )[0]
    if shard is not None:
        shard.close()
    return out, raw


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--msr", nargs="+", required=True, metavar="[NAME=]FILE")
    ap.add_argument("--versus", default=None, help="a method to compare the others with")
    args = ap.parse_args()
    results = list(by_seed(args.msr).values())
    methods = [m for m in results[0]["methods"] if all(m in r["methods"] for r in results)]
    if args.versus is not None and args.versus not in methods:
        raise MomaError(f"--versus {args.versus!r}: the MSR results have {methods}")
    picked = [labels_at_picks(args.data, msr) for msr in results]
    labels = {m: np.concatenate([lab[m] for lab, _ in picked]) for m in methods}
    raw = {m: np.concatenate([r[m] for _, r in picked]) for m in methods}
    ok = {m: np.concatenate([top1_outcomes(r, m) for r in results]) == 1 for m in methods}
    print("| Top-1 success by label | " + " | ".join(COLUMNS) + " |")
    print("| --- |" + " ---: |" * len(COLUMNS))
    for m, lab in labels.items():
        zero = lab == 0
        groups = [zero & (raw[m] > 0), zero & (raw[m] == 0)]
        groups += [
            (lab > a if a == 0 else lab >= a) & (lab < b) for a, b in itertools.pairwise(BINS)
        ]
        cells = [f"{ok[m][g].mean():.0%} of {g.sum()}" if g.any() else "–" for g in groups]
        print(f"| {m} | " + " | ".join(cells) + " |")
    if args.versus:
        unit = "configurations" if len(results) == 1 else "views of configurations"
        for m, lab in labels.items():
            sel = ~ok[m] & ok[args.versus]
            if m == args.versus or not sel.any():
                continue
            v = lab[sel]
            print(
                f"{m} failed where {args.versus} succeeded: {sel.sum()} {unit}; label "
                f"at {m}'s point: median {np.nanmedian(v):.2f}, 0 in {np.mean(v == 0):.0%}, "
                f"below 0.3 in {np.mean(v < 0.3):.0%}"
            )


if __name__ == "__main__":
    run_main(main, "msr_labels.py")
