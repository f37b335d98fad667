"""The dataset card: ``README.md`` with statistics and ``example.png`` in the dataset root."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data import manifest as mf
from momakitchen.data.coverage import COVERAGE_RADIUS
from momakitchen.data.episode import Episode
from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.fileio import atomic_path, atomic_write_text, dumps_strict

CARD_NAME = "README.md"
FIGURE_NAME = "example.png"


def save_episode_figure(ep: Episode, path: str | os.PathLike) -> None:
    """RGB (the target outlined), depth, the global cloud seen from above coloured by the
    alignment channel and the floor cloud coloured by its affordance label, the target
    marked in both clouds; sized for a page (DOC_WIDTH inches, text of 8 pt or more)."""
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter

    from momakitchen.data.episode import SEMANTIC_CLASSES
    from momakitchen.perception.figures import DOC_WIDTH, pyplot, text_sizes

    plt = pyplot()
    target = ep.global_xyz[ep.global_align > 0]
    centre = target.mean(0) if len(target) else None
    star: dict[str, Any] = {"marker": "*", "color": "red", "mec": "black", "ms": 13, "ls": ""}
    with plt.rc_context(text_sizes(8)):
        fig, axes = plt.subplots(2, 2, figsize=(DOC_WIDTH, 6.2), layout="constrained")
        ax = axes.ravel()
        if ep.rgb.size:  # imported reference data may have no images
            ax[0].imshow(ep.rgb)
            mask = ep.semantic == SEMANTIC_CLASSES.index("target")
            if mask.any():
                ax[0].contour(mask.astype(float), levels=[0.5], colors="red", linewidths=1.5)
                rows, cols = np.nonzero(mask)
                ax[0].annotate(
                    "target",
                    (float(cols.mean()), float(rows.min())),
                    xytext=(0, 7),
                    textcoords="offset points",
                    ha="center",
                    color="red",
                    weight="bold",
                )
            depth = np.where(ep.depth > 0, ep.depth, np.nan)
            im = ax[1].imshow(depth, cmap="viridis")
            fig.colorbar(im, ax=ax[1], shrink=0.8, label="depth (m)")
        ax[0].set_title("RGB (the target outlined in red)")
        ax[1].set_title("depth")
        for a in ax[:2]:
            a.axis("off")
        order = np.argsort(np.abs(ep.global_align), kind="stable")  # flagged points on top
        g = ep.global_xyz[order]
        colours = np.array([[0.85, 0.2, 0.15], [0.75, 0.75, 0.75], [0.1, 0.45, 0.9]])
        ax[2].scatter(-g[:, 1], g[:, 0], s=1.5, c=colours[ep.global_align[order] + 1], lw=0)
        ax[2].set_title("global cloud, from above")
        sc = ax[3].scatter(
            -ep.floor_xyz[:, 1],
            ep.floor_xyz[:, 0],
            s=2,
            c=ep.floor_label,
            cmap="viridis",  # the colour map of every other affordance figure
            vmin=0,
            vmax=1,
            linewidths=0,
        )
        fig.colorbar(sc, ax=ax[3], shrink=0.8, label="affordance (success rate)")
        ax[3].set_title("floor cloud, labelled")
        # As in every top-down view of the base frame: forward up, left to the left, the
        # axis labelled with y itself (the points are drawn at -y).
        left = FuncFormatter(lambda v, _pos: f"{-v + 0.0:g}")
        for a in ax[2:]:
            if centre is not None:
                a.plot(-centre[1], centre[0], **star)
            a.set_aspect("equal")
            a.xaxis.set_major_formatter(left)
            a.set_xlabel("y (m), positive to the left")
            a.set_ylabel("x, forward (m)")

        def point(colour: Any, label: str) -> Line2D:
            return Line2D([], [], marker="o", ls="", color=colour, ms=5, label=label)

        fig.legend(
            handles=[
                point(colours[2], "cloud: target"),
                point(colours[0], "cloud: obstacle"),
                point(colours[1], "cloud: other"),
                Line2D([], [], **star, label="the target's centre"),
            ],
            loc="outside lower center",
            ncols=4,
        )
        fig.suptitle(
            f"scene {ep.scene_id}, configuration {ep.config_index}, episode "
            f"{ep.episode_index}, robot {ep.robot}",
            fontsize=9,
        )
        fig.savefig(path, dpi=110, metadata={"Software": None})
    plt.close(fig)


def _table(rows: list[list[Any]], header: list[str]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def _range(summary: dict[str, float] | None) -> str:
    if not summary:
        return "-"
    return f"mean {summary['mean']:g}, min {summary['min']:g}, max {summary['max']:g}"


def _rate(row: dict[str, int]) -> str:
    return f"{row['successful_trials'] / row['trials']:.3f}" if row.get("trials") else "-"


def _ground_truth_line(total: dict[str, int]) -> str:
    """Infeasible configurations and view coverage, in one sentence."""
    n, bad = total.get("configurations", 0), total.get("infeasible_configurations", 0)
    views, covering = total.get("feasible_views", 0), total.get("covering_views", 0)
    share = f"{100 * bad / n:.1f} %" if n else "-"
    coverage = f"{100 * covering / views:.1f} %" if views else "-"
    return (
        f"Infeasible configurations (no successful grid trial; kept, flagged `feasible` = 0): "
        f"{bad} of {n} ({share}). View coverage: {covering} of the {views} views of feasible "
        f"configurations ({coverage}) see floor within {100 * COVERAGE_RADIUS:.0f} cm of a "
        "successful trial position."
    )


def _user_robot_lines(manifest: dict[str, Any]) -> list[str]:
    """The card's lines on the user robots the dataset was labelled with (none: none)."""
    records = manifest.get("user_robots") or []
    if not records:
        return []
    files = "; ".join(
        f"`{r['name']}` from `{r['yaml']}` (sha256 {r['sha256'][:12]})" for r in records
    )
    return [
        f"User robots (URDF + YAML): {files}. Commands that rebuild the worlds (`msr`, "
        "`robustness`, `audit`) need them registered: `--robot-yaml FILE` or "
        "`MOMAKITCHEN_ROBOT_YAML`.",
        "",
    ]


def render_card(manifest: dict[str, Any], stats: dict[str, Any] | None, figure: bool) -> str:
    c = manifest["counts"]
    splits = [
        [s, c[s]["scenes"], c[s]["configurations"], c[s]["episodes"], c[s]["trials"], _rate(c[s])]
        for s in ("train", "test", "total")
    ]
    head = ["split", "scenes", "configurations", "episodes", "trials", "trial success"]
    robots = [
        [r, row["train"].get("episodes", 0), row["test"].get("episodes", 0), _rate(row["total"])]
        for r, row in c["robots"].items()
    ]
    missing = {
        s: sorted(r for r, row in c["robots"].items() if not row[s].get("episodes"))
        for s in ("train", "test")
    }
    coverage = (
        "Every robot appears in both splits."
        if not any(missing.values())
        else "Robots missing from a split: "
        + "; ".join(f"{s}: {', '.join(v)}" for s, v in missing.items() if v)
        + "."
    )
    targets = [
        [t, row["train"].get("episodes", 0), row["test"].get("episodes", 0), _rate(row["total"])]
        for t, row in c["targets"].items()
    ]
    parts = [
        "# MoMa-Kitchen dataset (momakitchen)",
        "",
        f"Generated by momakitchen {manifest['generator_version']} with producer "
        f"`{manifest['producer']}`; shard schema version {manifest['schema_version']}, "
        f"robot descriptor version {manifest['descriptor_version']} "
        f"({', '.join(manifest['descriptor_names'])}).",
        "",
        "Status: "
        + (
            "complete."
            if manifest["complete"]
            else "**incomplete** (run `momakitchen generate` again to finish it)."
        ),
        "",
        "One HDF5 shard per scene in `scenes/`; `manifest.json` holds the full generation "
        "config, the splits and the counts. Read it with `momakitchen.data.EpisodeDataset`, "
        "check it with `momakitchen check`.",
        "",
        f"Splits are by scene (unseen-scene test set): {manifest['split_rule']}.",
        "",
        _ground_truth_line(c["total"]),
        "",
        "## Counts",
        "",
        _table(splits, head),
        "",
        "## Robots (episodes)",
        "",
        _table(robots, ["robot", "train", "test", "trial success"]),
        "",
        coverage,
        "",
        *_user_robot_lines(manifest),
        "## Target categories (episodes)",
        "",
        _table(targets, ["target", "train", "test", "trial success"]),
        "",
    ]
    if stats:
        pts = stats["points_per_episode"]
        parts += [
            "## Sizes",
            "",
            f"- bytes on disk: {stats['bytes']:,} ({stats['bytes_per_episode']:,.0f} per episode)",
            f"- image: {stats['image_shape']}",
            f"- global points per episode: {_range(pts['global'])}",
            f"- floor points per episode: {_range(pts['floor'])}",
            f"- mean floor label per episode: {_range(stats['floor_label_mean'])}",
            f"- episodes without global or floor points (skipped by EpisodeDataset): "
            f"{stats['episodes_with_empty_cloud']}",
            "",
        ]
    if figure:
        parts += ["## Example", "", f"![example episode]({FIGURE_NAME})", ""]
    parts += [
        "## Generation config",
        "",
        "```json",
        dumps_strict(manifest["config"], indent=1),
        "```",
        "",
    ]
    return "\n".join(parts)


def write_dataset_card(root: str | os.PathLike, manifest: dict[str, Any] | None = None) -> Path:
    """(Re)write ``README.md`` and ``example.png`` from the manifest and the first shard."""
    from momakitchen.data.integrity import dataset_stats

    root = Path(root)
    manifest = manifest or mf.load_manifest(root)
    shards = list_shards(root)
    figure = False
    if shards and manifest["counts"]["total"]["episodes"]:
        with SceneShard(next(iter(shards.values()))) as shard:
            # The first shard's episode with the most affordance mass: an informative map.
            keys = [(c, e) for c in shard.config_indices() for e in shard.episode_indices(c)]
            mass = [
                float(shard.arrays(c, e, ["floor_label"])["floor_label"].sum()) for c, e in keys
            ]
            ep = shard.episode(*keys[int(np.argmax(mass))])
        with atomic_path(root / FIGURE_NAME) as tmp:
            save_episode_figure(ep, tmp)
        figure = True
    stats = dataset_stats(root) if manifest["shards"] else None
    atomic_write_text(root / CARD_NAME, render_card(manifest, stats, figure))
    return root / CARD_NAME
