"""Tables and the qualitative figure of docs/RESULTS.md from evaluate / msr outputs.

Usage::

    python benchmarks/results_report.py --data DIR --runs RUN... --metrics JSON... \
        --msr JSON --out docs/RESULTS_tables.md --figure docs/img/qualitative.png

``--metrics`` are ``momakitchen evaluate`` JSON files (one per run, same order as
``--runs``); ``--msr`` is one ``momakitchen msr`` JSON holding the runs and baselines. The
qualitative figure shows the ground truth and every run's map on the same test episodes
(the first ``--examples`` test configurations with a successful trial, one view each).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from momakitchen.data import EpisodeDataset
from momakitchen.data.batch import EpisodeCollator
from momakitchen.deploy.figures import floor_map, pyplot
from momakitchen.train.checkpoint import load_checkpoint
from momakitchen.train.evaluate import predict_batch

MAP_COLUMNS = (("rmse", "RMSE ↓"), ("logmse", "logMSE ↓"), ("pcc", "PCC ↑"), ("sim", "SIM ↑"),
               ("ciou", "cIoU ↑"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--runs", nargs="+", required=True)
    ap.add_argument("--metrics", nargs="+", required=True)
    ap.add_argument("--msr", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--figure", required=True)
    ap.add_argument("--examples", type=int, default=4)
    args = ap.parse_args()
    msr = json.loads(Path(args.msr).read_text())
    k = msr["config"]["top_k"]
    lines = ["| method | " + " | ".join(c for _, c in MAP_COLUMNS)
             + f" | Top-1 MSR ↑ | Top-{k} MSR ↑ | Top-1 (feasible) | Top-{k} (feasible) |",
             "|---" * (len(MAP_COLUMNS) + 5) + "|"]
    names = []
    for metrics_file in args.metrics:
        report = json.loads(Path(metrics_file).read_text())
        names.append(report["model"])
        m, s = report["metrics"], msr["methods"].get(report["model"], {})
        lines.append(f"| {report['model']} | " + " | ".join(f"{m[key]:.4f}" for key, _ in
                                                           MAP_COLUMNS)
                     + "".join(f" | {100 * s[key]:.1f} %" if s else " | –" for key in
                               ("top1", "topk", "top1_feasible", "topk_feasible")) + " |")
    for name, s in msr["methods"].items():
        if name not in names:
            lines.append(f"| {name} | " + " | ".join("–" for _ in MAP_COLUMNS)
                         + "".join(f" | {100 * s[key]:.1f} %" for key in
                                   ("top1", "topk", "top1_feasible", "topk_feasible")) + " |")
    lines += ["", f"MSR on {msr['configurations']} {msr['config']['split']} configurations "
              f"({msr['feasible_configurations']} feasible), seed {msr['config']['seed']}.", ""]
    robots = sorted({r for s in msr["methods"].values() for r in s["per_robot"]})
    lines += ["| Top-1 MSR per robot | " + " | ".join(robots) + " |",
              "|---" * (len(robots) + 1) + "|"]
    for name, s in msr["methods"].items():
        lines.append(f"| {name} | " + " | ".join(
            f"{100 * s['per_robot'][r]['top1']:.0f} % ({s['per_robot'][r]['configurations']})"
            if r in s["per_robot"] else "–" for r in robots) + " |")
    cats = sorted({c for s in msr["methods"].values() for c in s["per_category"]})
    lines += ["", "| Top-1 MSR per target | " + " | ".join(cats) + " |",
              "|---" * (len(cats) + 1) + "|"]
    for name, s in msr["methods"].items():
        lines.append(f"| {name} | " + " | ".join(
            f"{100 * s['per_category'][c]['top1']:.0f} %" if c in s["per_category"] else "–"
            for c in cats) + " |")
    lines += ["", *per_scene_table([json.loads(Path(f).read_text()) for f in args.metrics], msr)]
    for name in msr["methods"]:
        if any("uncertainty" in r["methods"][name] for r in msr["records"]):
            lines += ["", *confidence_table(msr, name)]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    qualitative(args.data, args.runs, args.figure, args.examples)


def per_scene_table(reports: list[dict], msr: dict) -> list[str]:
    """Per test scene: each run's RMSE and PCC, and every MSR method's Top-1 rate."""
    methods = list(msr["methods"])
    top1: dict[str, dict[str, list[int]]] = {}
    for r in msr["records"]:
        for name in methods:
            o = r["methods"][name]["outcomes"]
            top1.setdefault(str(r["scene_id"]), {}).setdefault(name, []).append(o[0] if o else 0)
    head = ["scene", "episodes"] + [f"{r['model']} RMSE / PCC" for r in reports] + [
        f"{m} Top-1" for m in methods]
    out = ["Per test scene (map metrics over its episodes; MSR over its configurations):", "",
           "| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for scene in sorted(reports[0]["per_scene"], key=int):
        cells = [scene, str(int(reports[0]["per_scene"][scene]["episodes"]))]
        cells += [f"{r['per_scene'][scene]['rmse']:.3f} / {r['per_scene'][scene]['pcc']:.2f}"
                  for r in reports]
        cells += [f"{np.mean(top1.get(scene, {}).get(m, [0])):.0%}" for m in methods]
        out.append("| " + " | ".join(cells) + " |")
    return out


def auroc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Probability that a random success scores higher than a random failure (ties 1/2)."""
    pos, neg = scores[labels == 1], scores[labels == 0]
    if not len(pos) or not len(neg):
        return float("nan")
    greater = (pos[:, None] > neg[None, :]).mean()
    ties = (pos[:, None] == neg[None, :]).mean()
    return float(greater + 0.5 * ties)


def confidence_table(msr: dict, name: str) -> list[str]:
    """Does the model's confidence at its Top-1 point predict the trial's outcome?"""
    rows = [r["methods"][name] for r in msr["records"] if r["methods"][name]["outcomes"]]
    ok = np.array([r["outcomes"][0] for r in rows])
    aff = np.array([r["affordance"][0] for r in rows])
    unc = np.array([r["uncertainty"][0] for r in rows])
    out = [f"Confidence of {name} at its Top-1 point vs the trial outcome ({len(rows)} "
           f"configurations, {ok.mean():.0%} succeeded). AUROC (0.5 = no signal): predicted "
           f"affordance {auroc(aff, ok):.2f}; low uncertainty {auroc(-unc, ok):.2f}; low relative "
           f"uncertainty (std / affordance) {auroc(-unc / np.maximum(aff, 1e-3), ok):.2f}.", "",
           "| tercile | affordance range | success | uncertainty range | success |",
           "|---|---|---|---|---|"]
    qs = [0, 1 / 3, 2 / 3, 1]
    a_edges, u_edges = np.quantile(aff, qs), np.quantile(unc, qs)

    def inside(v: np.ndarray, edges: np.ndarray, t: int) -> np.ndarray:
        return (v >= edges[t]) & ((v <= edges[t + 1]) if t == 2 else (v < edges[t + 1]))

    for t, label in enumerate(("low", "middle", "high")):
        a_in, u_in = inside(aff, a_edges, t), inside(unc, u_edges, t)
        out.append(f"| {label} | {a_edges[t]:.2f}–{a_edges[t + 1]:.2f} | "
                   f"{ok[a_in].mean():.0%} ({a_in.sum()}) | {u_edges[t]:.3f}–{u_edges[t + 1]:.3f}"
                   f" | {ok[u_in].mean():.0%} ({u_in.sum()}) |")
    return out


def qualitative(data_dir: str, runs: list[str], path: str, examples: int) -> None:
    data = EpisodeDataset(data_dir, "test")
    picked, seen = [], set()
    for i, (_, sid, c, e, _) in enumerate(data.index):
        if (sid, c) in seen or e != 5:
            continue
        sample = data[i]
        if float(sample["floor_label"].max()) > 0.5:
            picked.append(sample)
            seen.add((sid, c))
        if len(picked) == examples:
            break
    loaded = [load_checkpoint(r) for r in runs]
    plt = pyplot()
    fig, axes = plt.subplots(len(picked), 1 + len(loaded),
                             figsize=(3.6 * (1 + len(loaded)), 3.2 * len(picked)),
                             constrained_layout=True, squeeze=False)
    for row, sample in enumerate(picked):
        xyz = sample["floor_xyz"].numpy()
        gt = sample["floor_label"].numpy()
        floor_map(axes[row, 0], xyz, gt, f"ground truth: scene {sample['scene_id']}, "
                  f"{sample['robot_name']}")
        for col, run in enumerate(loaded, start=1):
            batch = EpisodeCollator(run.config.num_global, None, run.config.seed)([sample])
            pred = predict_batch(run.model, batch)[0].numpy()
            floor_map(axes[row, col], xyz, pred, f"{run.config.model} (max {pred.max():.2f})",
                      vmax=max(float(pred.max()), 0.05))
    fig.savefig(path, dpi=80)
    print(f"-> {path}")


if __name__ == "__main__":
    main()
