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
    have a successful trial. PNG bytes."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.eval.predictions import dataset_episodes, load_predictions
    from momakitchen.models.inference import inference_collator, predict_batch
    from momakitchen.perception.figures import png_bytes
    from momakitchen.train.checkpoint import load_checkpoint

    data = EpisodeDataset(data_dir, "test")
    last_view: dict[tuple[int, int], int] = {}
    for i, (_, sid, c, _e, _) in enumerate(data.index):
        last_view[(sid, c)] = i
    picked = []
    for i in last_view.values():
        sample = data[i]
        if float(sample["floor_label"].max()) > 0.5:
            picked.append(sample)
        if len(picked) == examples:
            break
    if not picked:
        raise MomaError(f"no test configuration of {str(data_dir)!r} has a successful trial")
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
        title = f"ground truth: scene {sample['scene_id']}, {sample['robot_name']}"
        rows.append((title, sample["floor_xyz"].numpy(), sample["floor_label"].numpy(), maps))
    fig = qualitative_grid(rows)
    return png_bytes(fig)


def qualitative_grid(
    rows: Sequence[tuple[str, np.ndarray, np.ndarray, Sequence[tuple[str, np.ndarray]]]],
) -> Any:
    """The figure of :func:`qualitative_figure`: per row (title, floor points (N, 3), the
    ground truth (N,), [(model name, its map (N,))]) the ground truth and every map, all on
    one 0-1 colour scale with one colour bar, so that a model whose map peaks at
    0.06 looks as unsure as it is (each map's maximum is in its title)."""
    from momakitchen.perception.figures import floor_map, pyplot

    plt = pyplot()
    columns = 1 + max(len(maps) for *_, maps in rows)
    fig, axes = plt.subplots(
        len(rows),
        columns,
        figsize=(3.6 * columns + 0.8, 3.2 * len(rows)),
        constrained_layout=True,
        squeeze=False,
    )
    scatter = None
    for row, (title, xyz, label, maps) in enumerate(rows):
        scatter = floor_map(axes[row, 0], xyz, label, title, vmax=1.0)
        for col, (name, pred) in enumerate(maps, start=1):
            floor_map(axes[row, col], xyz, pred, f"{name} (max {pred.max():.2f})", vmax=1.0)
    fig.colorbar(scatter, ax=axes.ravel().tolist(), shrink=0.6, label="affordance (0–1)")
    return fig
