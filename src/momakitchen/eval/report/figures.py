"""The benchmark report's figures: the loss-weight sweep and the qualitative grid (ground
truth next to every method's map on the same test episodes)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.errors import MomaError


def sweep_figure(sweep: Sequence[tuple[float, dict]]) -> bytes:
    """PCC and RMSE against lambda (two panels), as PNG bytes."""
    from momakitchen.perception.figures import png_bytes, pyplot

    plt = pyplot()
    lam = [s[0] for s in sweep]
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), constrained_layout=True)
    for ax, key, label in zip(axes, ("pcc", "rmse"), ("PCC ↑", "RMSE ↓"), strict=True):
        ax.plot(lam, [s[1]["metrics"][key] for s in sweep], "o-", color="tab:blue")
        ax.set_xlabel("λ (weight on zero-valued labels)")
        ax.set_title(label)
        ax.grid(alpha=0.3)
    return png_bytes(fig)


def qualitative_figure(
    data_dir: Path,
    runs: Sequence[Path],
    examples: int,
    predictions: Sequence[tuple[str, Path]] = (),
) -> bytes:
    """Ground truth and every run's and predictions file's (``(name, file)``) map on the
    same test episodes: the last view of the first ``examples`` test configurations that
    have a successful trial, one robot after another (a robot comes again only once every
    robot of the split has a row). PNG bytes."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.eval.predictions import dataset_episodes, load_predictions
    from momakitchen.models.inference import inference_collator, predict_batch
    from momakitchen.perception.figures import png_bytes
    from momakitchen.train.checkpoint import load_checkpoint

    data = EpisodeDataset(data_dir, "test")
    last_view: dict[tuple[int, int], int] = {}
    for i, (_, sid, c, _e, _) in enumerate(data.index):
        last_view[(sid, c)] = i
    feasible = []
    for i in last_view.values():
        sample = data[i]
        if float(sample["floor_label"].max()) > 0.5:
            feasible.append(sample)
    if not feasible:
        raise MomaError(f"no test configuration of {str(data_dir)!r} has a successful trial")
    picked: list[dict[str, Any]] = []
    while len(picked) < examples and feasible:  # each round: every robot once, in order
        shown: set[str] = set()
        left = []
        for sample in feasible:
            if sample["robot_name"] not in shown and len(picked) < examples:
                shown.add(sample["robot_name"])
                picked.append(sample)
            else:
                left.append(sample)
        feasible = left
    loaded = [load_checkpoint(r) for r in runs]
    stored = [
        load_predictions(path, dataset_episodes(data), name).maps for name, path in predictions
    ]
    rows = []
    for sample in picked:
        maps = []
        for run in loaded:
            batch = inference_collator(run.config)([sample])
            maps.append((run.config.model, predict_batch(run.model, batch)[0].numpy()))
        key = f"{sample['scene_id']}/{sample['config_index']}/{sample['episode_index']}"
        maps += [(name, m[key]) for (name, _), m in zip(predictions, stored, strict=True)]
        title = f"ground truth\nscene {sample['scene_id']}, {sample['robot_name']}"
        xyz = sample["global_xyz"].numpy()
        target = xyz[sample["global_align"].numpy() > 0]
        rows.append(
            (
                title,
                sample["floor_xyz"].numpy(),
                sample["floor_label"].numpy(),
                maps,
                target.mean(0) if len(target) else None,
            )
        )
    fig = qualitative_grid(rows)
    return png_bytes(fig)


def qualitative_grid(rows: Sequence[tuple[Any, ...]]) -> Any:
    """The figure of :func:`qualitative_figure`: per row (title, floor points (N, 3), the
    ground truth (N,), [(model name, its map (N,))], and optionally the target's centre
    (3,) or None) the ground truth and every map, all on one 0-1 colour scale with one
    colour bar, so that a model whose map peaks at 0.06 looks as unsure as it is (each
    map's maximum is in its title). Every panel of a row shows the floor around the
    target and the maps' peaks, the target marked; DOC_WIDTH wide, its text 8 pt."""
    from momakitchen.perception.figures import (
        DOC_WIDTH,
        floor_map,
        focus_region,
        marks_legend,
        pyplot,
        text_sizes,
    )

    plt = pyplot()
    columns = 1 + max(len(row[3]) for row in rows)
    panel = (DOC_WIDTH - 1.2) / columns
    with plt.rc_context(text_sizes(8)):
        fig, axes = plt.subplots(
            len(rows),
            columns,
            figsize=(DOC_WIDTH, (0.85 * panel + 0.5) * len(rows) + 0.8),
            layout="constrained",
            dpi=150,
            squeeze=False,
        )
        scatter = None
        for r, (title, xyz, label, maps, *rest) in enumerate(rows):
            target = rest[0] if rest else None
            keep = np.zeros((0, 2)) if target is None else np.asarray(target, float)[None, :2]
            values = [label, *(m for _, m in maps)]
            region = focus_region(xyz, values, 1.0, keep, margin=0.5)
            scatter = floor_map(axes[r, 0], xyz, label, title, target, vmax=1.0, extent=region)
            for col, (name, pred) in enumerate(maps, start=1):
                floor_map(
                    axes[r, col],
                    xyz,
                    pred,
                    f"{name}\n(max {pred.max():.2f})",
                    target,
                    vmax=1.0,
                    extent=region,
                )
        for ax in axes.ravel():
            ax.set_xlabel("")
            ax.set_ylabel("")
        fig.supxlabel("y (m), positive to the left (the robot's base frame)")
        fig.supylabel("x, forward (m)")
        fig.colorbar(scatter, ax=axes.ravel().tolist(), shrink=0.6, label="affordance (0–1)")
        marks_legend(fig, camera=False, loc="outside lower right")
    return fig
