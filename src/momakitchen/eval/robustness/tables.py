"""The robustness track's figures: per-model summaries, the printed and Markdown tables,
McNemar's tests of models under each combined corruption, and the one-view figure."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.eval.robustness.views import NO_TARGET, REFERENCE

# What the printed table's less obvious columns count (printed under it; docs/METHODS.md).
ROBUSTNESS_LEGEND = (
    "views: views judged; range: of them, views whose target lies beyond the sensor's "
    "working range (left out of every rate); errors: views with no input (errors count as "
    "failures); usable: Top-1 over the views whose corrupted mask kept a target pixel of "
    "valid depth; feas.: Top-1 over the feasible configurations (some labelling trial "
    "succeeded); dTop-1, dPCC: change from clean, msr's view as stored."
)
# The same for the Markdown table's columns (benchmark --robustness).
MARKDOWN_LEGEND = (
    "beyond range: views whose target lies beyond the sensor's working range, left out of "
    "every rate; errors: views with no input, by cause, counted as failures; Top-1, usable "
    "masks: over the views whose corrupted mask kept a target pixel of valid depth; vs "
    "clean: the change from clean, msr's view as stored."
)


def summarize(records: Sequence[dict[str, Any]], model: str, name: str) -> dict[str, Any]:
    """One model's figures under one corruption (see
    :func:`~momakitchen.eval.robustness.run_robustness`)."""
    views = [(r, r["views"][model][name]) for r in records if name in r["views"].get(model, {})]
    counted = [(r, v) for r, v in views if v["status"] != "beyond_range"]
    ok = [v for _, v in counted if v["status"] == "ok"]

    def rate(items: list[tuple[dict[str, Any], dict[str, Any]]], k: bool) -> float:
        vals = [
            (float(np.mean(v["outcomes"])) if k else float(v["outcomes"][0]))
            if v["status"] == "ok"
            else 0.0
            for _, v in items
        ]
        return round(float(np.mean(vals)), 4) if vals else 0.0

    feasible = [(r, v) for r, v in counted if r["feasible"]]
    # views left with a target pixel of valid depth: what any method could act on
    usable = [(r, v) for r, v in counted if v.get("cause") not in NO_TARGET]
    return {
        "views": len(views),
        "beyond_range": sum(v["status"] == "beyond_range" for _, v in views),
        "errors": dict(Counter(v["cause"] for _, v in counted if v["status"] == "error")),
        "top1": rate(counted, False),
        "top1_usable": rate(usable, False),
        "top1_feasible": rate(feasible, False),
        "topk": rate(counted, True),
        "pcc": round(float(np.mean([v["pcc"] for v in ok])), 4) if ok else 0.0,
        "sim": round(float(np.mean([v["sim"] for v in ok])), 4) if ok else 0.0,
    }


def _vs_clean(s: dict[str, Any], ref: dict[str, Any] | None, name: str) -> tuple[str, str]:
    """A row's Top-1 (points) and PCC changes from ``clean`` ("" for clean itself)."""
    if ref is None or name == REFERENCE:
        return "", ""
    return f"{(s['top1'] - ref['top1']) * 100:+.1f}", f"{s['pcc'] - ref['pcc']:+.3f}"


def format_robustness_table(result: dict[str, Any]) -> str:
    """A text table: one row per model and corruption, with the change from ``clean``,
    and the legend of its columns (:data:`ROBUSTNESS_LEGEND`) under it."""
    import textwrap

    k = result["config"]["top_k"]
    head = (
        f"{'model':<12} {'corruption':<14} {'views':>5} {'range':>5} {'errors':>6} "
        f"{'Top-1':>6} {'dTop-1':>7} {'usable':>6} {'feas.':>6}"
        + (f" {f'Top-{k}':>6}" if k > 1 else "")
        + f" {'PCC':>6} {'dPCC':>6} {'SIM':>6}"
    )
    lines = [head, "-" * len(head)]
    for model, rows in result["models"].items():
        ref = rows.get(REFERENCE)
        for name, s in rows.items():
            d1, dp = _vs_clean(s, ref, name)
            lines.append(
                f"{model:<12} {name:<14} {s['views']:>5} {s['beyond_range']:>5} "
                f"{sum(s['errors'].values()):>6} {s['top1'] * 100:>6.1f} {d1:>7} "
                f"{s.get('top1_usable', s['top1']) * 100:>6.1f} {s['top1_feasible'] * 100:>6.1f}"
                + (f" {s['topk'] * 100:>6.1f}" if k > 1 else "")
                + f" {s['pcc']:>6.3f} {dp:>6} {s['sim']:>6.3f}"
            )
    legend = textwrap.wrap(ROBUSTNESS_LEGEND, max(len(head), 60))
    return "\n".join([*lines, "", *legend])


def robustness_figure(
    view_maps: dict[str, Any], title: str, views: dict[str, dict[str, Any]] | None = None
) -> bytes:
    """One view's map under each corruption, on one 0-1 colour scale (PNG bytes, DOC_WIDTH
    wide, its text 8 pt). ``views`` (corruption -> the view's record of the model, as
    ``records[i]["views"][model]``) adds to each panel its Top-1 trial's outcome and the
    map's PCC against the ground truth."""
    from momakitchen.perception.figures import (
        DOC_WIDTH,
        floor_map,
        marks_legend,
        png_bytes,
        pyplot,
        text_sizes,
    )

    plt = pyplot()
    names = list(view_maps)
    cols = min(4, len(names))
    rows = (len(names) + cols - 1) // cols
    preds = [p for p in view_maps.values() if hasattr(p, "floor_xyz")]
    # the floor within 1.2 m of the target, where the robot may stand
    t = preds[0].target_xyz[:2] if preds else np.zeros(2)
    extent = (float(t[0] - 1.2), float(t[0] + 0.3), float(t[1] - 1.2), float(t[1] + 1.2))
    panel = (DOC_WIDTH - 1.3) / cols
    aspect = (extent[1] - extent[0]) / (extent[3] - extent[2])
    scatter = None
    with plt.rc_context(text_sizes(8)):
        fig, axes = plt.subplots(
            rows,
            cols,
            figsize=(DOC_WIDTH, rows * (0.8 * panel * aspect + 0.6) + 0.9),
            squeeze=False,
            layout="constrained",
            dpi=130,
        )
        for ax, name in zip(axes.flat, names, strict=False):
            p = view_maps[name]
            caption = _panel_caption(name, (views or {}).get(name))
            if hasattr(p, "floor_xyz"):
                scatter = floor_map(
                    ax, p.floor_xyz, p.affordance, caption, p.target_xyz, p.poses[:1], extent=extent
                )
            else:
                ax.set_title(caption)
                reason = (
                    "target beyond the sensor's range"
                    if p["status"] == "beyond_range"
                    else (p.get("cause", "error").replace("_", " "))
                )
                ax.text(0.5, 0.5, reason, ha="center", va="center", transform=ax.transAxes)
                ax.set_xticks([])
                ax.set_yticks([])
        for i, ax in enumerate(axes.flat):
            if i >= len(names):
                ax.axis("off")
            ax.set_xlabel("")
            ax.set_ylabel("")
        fig.supxlabel("y (m), positive to the left (the robot's base frame)")
        fig.supylabel("x, forward (m)")
        if scatter is not None:
            fig.colorbar(scatter, ax=axes, shrink=0.5, label="predicted affordance (0–1)")
        spare = list(axes.flat[len(names) :])
        if spare:  # the legend in the grid's first empty cell
            legend = marks_legend(spare[0], camera=False, poses=1, loc="center", frameon=False)
            legend.set_in_layout(False)  # the grid's columns stay as wide as each other
        else:
            marks_legend(fig, camera=False, poses=1, loc="outside upper right")
        fig.suptitle(title, fontsize=9)
        return png_bytes(fig)


def _panel_caption(name: str, view: dict[str, Any] | None) -> str:
    """A panel's title: the corruption, and with the view's record its Top-1 outcome and
    PCC (or why there is no map)."""
    if view is None:
        return name
    if view.get("status") != "ok":
        return f"{name}\nno map"
    outcome = "success" if view["outcomes"] and view["outcomes"][0] else "failure"
    return f"{name}\nTop-1 {outcome}, PCC {view['pcc']:.2f}"


def top1_by_view(result: dict[str, Any], model: str, corruption: str) -> dict[tuple, int]:
    """Each counted view's Top-1 outcome (errors: 0; views beyond range left out), keyed
    by (seed, scene, configuration, episode): the record's own ``seed`` where results of
    several seeds are pooled, else the run's."""
    out = {}
    for r in result["records"]:
        v = r["views"].get(model, {}).get(corruption)
        if v is None or v["status"] == "beyond_range":
            continue
        seed = r.get("seed", result["config"]["seed"])
        key = (seed, r["scene_id"], r["config_index"], r["episode_index"])
        out[key] = int(v["outcomes"][0]) if v["status"] == "ok" else 0
    return out


def robustness_markdown(results: Sequence[dict[str, Any]]) -> list[str]:
    """Markdown lines: one table row per model and corruption (``robustness`` results,
    merged), with the change from ``clean``, and McNemar's test of every pair of models
    under each combined corruption (Top-1 per view, the views both counted)."""
    from momakitchen.eval.stats import mcnemar

    models: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {}
    for res in results:
        for model in res["models"]:
            if model in models:
                raise MomaError(f"robustness results name model {model!r} twice")
            names = res["config"]["corruptions"]
            rows = {name: summarize(res["records"], model, name) for name in names}
            models[model] = (rows, res)
    lines = [
        "| model | corruption | views | beyond range | errors | Top-1 | vs clean "
        "| Top-1, usable masks | PCC | vs clean | SIM |",
        "| --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for model, (rows, _) in models.items():
        ref = rows.get(REFERENCE)
        for name, s in rows.items():
            errors = ", ".join(f"{k} {v}" for k, v in s["errors"].items()) or "0"
            d1, dp = _vs_clean(s, ref, name)
            lines.append(
                f"| {model} | {name} | {s['views']} | {s['beyond_range']} | {errors} | "
                f"{s['top1'] * 100:.1f} | {d1} | {s['top1_usable'] * 100:.1f} | "
                f"{s['pcc']:.3f} | {dp} | {s['sim']:.3f} |"
            )
    lines += ["", MARKDOWN_LEGEND]
    names = list(models)
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
    tests = []
    for a, b in pairs:
        (ra, res_a), (rb, res_b) = models[a], models[b]
        for corruption in [c for c in ra if c in rb and (c == REFERENCE or "combined" in c)]:
            oa = top1_by_view(res_a, a, corruption)
            ob = top1_by_view(res_b, b, corruption)
            common = sorted(set(oa) & set(ob))
            if not common:
                continue
            only_a, only_b, p = mcnemar([oa[k] for k in common], [ob[k] for k in common])
            tests.append(
                f"| {a} vs {b} | {corruption} | {len(common)} | {only_a} | {only_b} | {p:.3g} |"
            )
    if tests:
        lines += [
            "",
            "| McNemar (Top-1 per view) | corruption | views | only first | only second | p |",
            "| --- | --- | ---: | ---: | ---: | ---: |",
            *tests,
        ]
    return lines
