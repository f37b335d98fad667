"""Which number of the robot descriptor a model's map follows: every test view of a dataset
scored with the descriptor it stores, and again with chosen columns replaced.

    python analyses/descriptor_ablation.py --data check-panda13/data --checkpoint bundled \
        --variant reach_m=0.85 --variant reach_m=0.85,mount_height_m=1.03 --out ablation

Per variant (``stored`` first) prints the mean PCC of the map with the label and the
ground-truth label at the map's best point (the Top-1 pick, read off the labelled grid), and
writes ``OUT/<variant>.npz``, a predictions file of every episode of the split (``--split``;
``all`` for a ``robot-check`` dataset) for ``momakitchen msr --predictions`` (the picks then
executed in physics). A model that ignored a column would score the same either way.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch
from analysis_cli import run_main

from momakitchen.data import EpisodeDataset
from momakitchen.data.batch import episode_maps
from momakitchen.errors import MomaError
from momakitchen.eval.evaluate import predicted_maps
from momakitchen.eval.predictions import dataset_episodes, write_predictions
from momakitchen.metrics import episode_metrics
from momakitchen.models.inference import predict_batch
from momakitchen.robots.spec import DESCRIPTOR_LAYOUTS
from momakitchen.train.checkpoint import load_checkpoint


def parse_variant(text: str, names: tuple[str, ...]) -> dict[int, float]:
    """``"reach_m=0.85,mount_height_m=1.03"`` -> {column index: value}; MomaError naming a
    column the model does not read or a value that is not a number."""
    out = {}
    for part in text.split(","):
        name, _, value = part.partition("=")
        if name.strip() not in names:
            raise MomaError(
                f"--variant {text!r}: no column {name.strip()!r} (the model reads {names})"
            )
        try:
            out[names.index(name.strip())] = float(value)
        except ValueError:
            raise MomaError(f"--variant {text!r}: {value!r} is not a number") from None
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--checkpoint", default="bundled", help="run directory or 'bundled'")
    ap.add_argument("--variant", action="append", default=[], help="COLUMN=VALUE[,...]")
    ap.add_argument("--out", type=Path, required=True, help="folder for the predictions files")
    ap.add_argument(
        "--split", choices=("train", "test", "all"), default="test", help="views of (test)"
    )
    args = ap.parse_args()
    torch.set_num_threads(1)
    run = load_checkpoint(args.checkpoint)
    names = DESCRIPTOR_LAYOUTS[run.config.model_config.descriptor_version]
    variants = {"stored": {}} | {v: parse_variant(v, names) for v in args.variant}
    data = EpisodeDataset(args.data, args.split)
    keys = [k for k, _ in dataset_episodes(data)]
    maps: dict[str, dict[str, np.ndarray]] = {v: {} for v in variants}
    scores: dict[str, list[tuple[float, float]]] = {v: [] for v in variants}
    for batch, stored, labels in predicted_maps(run, data):
        first = len(maps["stored"])
        for variant, columns in variants.items():
            preds = stored
            if columns:
                robot = batch["robot"].clone()
                for i, value in columns.items():
                    robot[:, i] = value
                other = {**batch, "robot": robot}
                preds = episode_maps(other, predict_batch(run.model, other))[0]
            for j, (p, g) in enumerate(zip(preds, labels, strict=True)):
                maps[variant][keys[first + j]] = np.clip(p, 0.0, 1.0).astype(np.float32)
                scores[variant].append((episode_metrics(p, g)["pcc"], float(g[np.argmax(p)])))
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"{len(keys)} {args.split} views of {args.data}; the model reads {', '.join(names)}")
    print("| descriptor | PCC | label at the best point | predictions file |")
    print("| --- | ---: | ---: | --- |")
    for variant in variants:
        path = args.out / f"{variant.replace(',', '_').replace('=', '-')}.npz"
        write_predictions(path, maps[variant])
        pcc, top1 = np.nanmean(scores[variant], axis=0)
        print(f"| {variant} | {pcc:.3f} | {top1:.3f} | {path} |")


if __name__ == "__main__":
    run_main(main, "descriptor_ablation.py")
