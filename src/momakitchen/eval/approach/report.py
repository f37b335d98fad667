"""Tables and figures of the approach track: one row per (method, policy, start) with
success, SPL, looks and time, breakdowns per robot, target category and start, McNemar
between every pair of rows of a start (with the least lead its configurations can detect
at 80 % power), and success against the final-stop error."""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Sequence
from typing import Any

import numpy as np

from momakitchen.eval.approach.records import strata

ROW_KEYS = ("method", "policy", "start")


def _mean(values: Sequence[float]) -> float:
    return float(np.mean(values)) if len(values) else 0.0


def _group(records: Sequence[dict[str, Any]]) -> dict[tuple[str, str, str], list[dict[str, Any]]]:
    rows: dict[tuple[str, str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        rows[(r["method"], r["policy"], r["start"])].append(r)
    return rows


def halving_error(sigmas: Sequence[float], rates: Sequence[float]) -> float | None:
    """The stop error (cm) at which success falls to half its value at the first sigma
    (linear between the swept values); None when it never does within the sweep."""
    if not len(rates) or rates[0] <= 0:
        return None
    half = rates[0] / 2
    for k in range(1, len(rates)):
        (s0, r0), (s1, r1) = (sigmas[k - 1], rates[k - 1]), (sigmas[k], rates[k])
        if r1 <= half:
            return float(s0 + (s1 - s0) * (r0 - half) / (r0 - r1)) if r0 != r1 else float(s1)
    return None


def summarize(result: dict[str, Any]) -> list[dict[str, Any]]:
    """The result's rows: ``method``, ``policy``, ``start``, ``episodes``, ``success``,
    ``spl``, ``looks`` (mean per episode), ``seconds`` (mean robot time: driving, turning,
    looks, inference), ``cpu_seconds`` (mean per episode of this process), ``failures``
    (stage counts), ``start_distance`` (mean, min, max), ``per_robot`` and
    ``per_category`` success, ``per_stratum`` (success by what makes a stance hard:
    :func:`~momakitchen.eval.approach.records.strata`), and ``stop_sweep`` (success per
    stop error and the error that halves it) when the run swept it."""
    sweep = result["config"].get("stop_sweep") or []
    rows = []
    for (method, policy, start), recs in _group(result["records"]).items():
        dist = [r["start_distance"] for r in recs]
        row: dict[str, Any] = {
            "method": method,
            "policy": policy,
            "start": start,
            "episodes": len(recs),
            "success": _mean([r["success"] for r in recs]),
            "spl": _mean([r["spl"] for r in recs]),
            "looks": _mean([r["n_looks"] for r in recs]),
            "seconds": _mean([r["seconds"]["total"] for r in recs]),
            "seconds_parts": {
                k: _mean([r["seconds"][k] for r in recs])
                for k in ("driving", "turning", "looking", "inference")
            },
            "cpu_seconds": _mean([r["cpu_seconds"] for r in recs]),
            "success_feasible": _mean([r["success"] for r in recs if r["feasible"]]),
            "failures": dict(sorted(Counter(r["stage"] for r in recs if not r["success"]).items())),
            "blocked": sum(bool(r["blocked"]) for r in recs),
            "start_distance": [_mean(dist), min(dist), max(dist)],
        }
        for key, field in (("per_robot", "robot"), ("per_category", "category")):
            groups: dict[str, list[int]] = defaultdict(list)
            for r in recs:
                groups[r[field]].append(r["success"])
            row[key] = {
                k: {"success": _mean(v), "episodes": len(v)} for k, v in sorted(groups.items())
            }
        by_stratum: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(list))
        for r in recs:
            for axis, value in strata(r).items():
                by_stratum[axis][value].append(r["success"])
        if by_stratum:
            row["per_stratum"] = {
                axis: {k: {"success": _mean(v), "episodes": len(v)} for k, v in sorted(g.items())}
                for axis, g in by_stratum.items()
            }
        # An episode that ended before its trial fails at every stop error.
        swept = [r.get("stop_sweep", [0] * len(sweep)) for r in recs]
        if sweep and any("stop_sweep" in r for r in recs):
            rates = np.mean(np.asarray(swept, float), axis=0).tolist()
            cms = [float(s[0]) for s in sweep]
            row["stop_sweep"] = {
                "sigma_cm": cms,
                "sigma_deg": [float(s[1]) for s in sweep],
                "success": rates,
                "halving_cm": halving_error(cms, rates),
            }
        rows.append(row)
    return rows


def pairwise(result: dict[str, Any], power: float = 0.8) -> list[dict[str, Any]]:
    """McNemar's exact test between every two rows of the same start, on the episodes
    both ran (paired by configuration), with the least lead detectable at ``power``
    given the observed discordant rate."""
    from momakitchen.eval.stats import detectable_lead, mcnemar

    groups = _group(result["records"])
    out = []
    keys = sorted(groups)
    for i, a in enumerate(keys):
        for b in keys[i + 1 :]:
            if a[2] != b[2]:
                continue
            sa = {(r["scene_id"], r["config_index"]): r["success"] for r in groups[a]}
            sb = {(r["scene_id"], r["config_index"]): r["success"] for r in groups[b]}
            common = sorted(set(sa) & set(sb))
            if not common:
                continue
            only_a, only_b, p = mcnemar([sa[k] for k in common], [sb[k] for k in common])
            n = len(common)
            discordant = (only_a + only_b) / n
            lead = detectable_lead(n, discordant, power) if discordant > 0 else float("nan")
            out.append(
                {
                    "a": dict(zip(ROW_KEYS, a, strict=True)),
                    "b": dict(zip(ROW_KEYS, b, strict=True)),
                    "configurations": n,
                    "only_a": only_a,
                    "only_b": only_b,
                    "p": p,
                    "detectable_lead": None if np.isnan(lead) else round(lead, 4),
                }
            )
    return out


def _label(row: dict[str, Any]) -> str:
    return row["method"] if row["policy"] == "-" else f"{row['method']} ({row['policy']})"


def markdown_table(rows: Sequence[dict[str, Any]]) -> str:
    """The rows as a Markdown table, grouped by start."""
    head = (
        "| start | method (policy) | episodes | success | SPL | looks | robot time (s) | "
        "CPU s / episode | failures |\n"
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |"
    )
    lines = [head]
    for r in sorted(rows, key=lambda r: (r["start"] != "far", -r["success"], _label(r))):
        fails = ", ".join(f"{k} {v}" for k, v in r["failures"].items()) or "-"
        lines.append(
            f"| {r['start']} ({r['start_distance'][0]:.1f} m) | {_label(r)} | {r['episodes']} | "
            f"{100 * r['success']:.1f} % | {r['spl']:.3f} | {r['looks']:.2f} | "
            f"{r['seconds']:.1f} | {r['cpu_seconds']:.1f} | {fails} |"
        )
    return "\n".join(lines)


def sweep_table(rows: Sequence[dict[str, Any]]) -> str:
    """Success against the final-stop error (rows that swept it), Markdown."""
    swept = [r for r in rows if "stop_sweep" in r]
    if not swept:
        return ""
    s = swept[0]["stop_sweep"]
    cols = [
        f"{cm:g} cm / {deg:g} deg" for cm, deg in zip(s["sigma_cm"], s["sigma_deg"], strict=True)
    ]
    lines = [
        "| start | method (policy) | " + " | ".join(cols) + " | halves at |",
        "| --- | --- |" + " ---: |" * (len(cols) + 1),
    ]
    for r in sorted(swept, key=lambda r: (r["start"] != "far", _label(r))):
        sw = r["stop_sweep"]
        half = "beyond the sweep" if sw["halving_cm"] is None else f"{sw['halving_cm']:.1f} cm"
        rates = " | ".join(f"{100 * v:.1f} %" for v in sw["success"])
        lines.append(f"| {r['start']} | {_label(r)} | {rates} | {half} |")
    return "\n".join(lines)


def pairs_table(pairs: Sequence[dict[str, Any]]) -> str:
    """The McNemar tests, Markdown."""
    lines = [
        "| start | a | b | only a | only b | p | least lead detectable (80 %) |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: |",
    ]
    for q in pairs:
        lead = "-" if q["detectable_lead"] is None else f"{100 * q['detectable_lead']:.1f} points"
        lines.append(
            f"| {q['a']['start']} | {_label(q['a'])} | {_label(q['b'])} | {q['only_a']} | "
            f"{q['only_b']} | {q['p']:.3g} | {lead} |"
        )
    return "\n".join(lines)


def strata_table(rows: Sequence[dict[str, Any]]) -> str:
    """Success per stratum (columns: each axis's values) and row, as Markdown; "" when
    the rows have no strata."""
    axes: dict[str, set[str]] = defaultdict(set)
    for r in rows:
        for axis, groups in r.get("per_stratum", {}).items():
            axes[axis] |= set(groups)
    if not axes:
        return ""
    columns = [(axis, value) for axis in axes for value in sorted(axes[axis])]
    out = ["| start | method (policy) | " + " | ".join(v for _, v in columns) + " |"]
    out.append("| --- | --- |" + " ---: |" * len(columns))
    for r in sorted(rows, key=lambda r: (r["start"] != "far", _label(r))):
        cells = []
        for axis, value in columns:
            g = r.get("per_stratum", {}).get(axis, {}).get(value)
            cells.append(f"{100 * g['success']:.0f} % ({g['episodes']})" if g else "-")
        out.append(f"| {r['start']} | {_label(r)} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def _map_words(config: dict[str, Any]) -> str:
    """What the robot knew of the room, for the report's header ("" for runs made before
    the setting was recorded)."""
    if "map" not in config:
        return ""
    from momakitchen.eval.approach.config import ApproachConfig

    words = f", map `{config['map']}`"
    if config["map"] == "static":
        # to_dict leaves the threshold out at its default
        n = config.get("obstacle_min_points", ApproachConfig.obstacle_min_points)
        words += f" (a costmap cell marked at {n} depth point{'s' if n > 1 else ''})"
    return words


def report_markdown(result: dict[str, Any]) -> str:
    """The whole Markdown report: main table, per-robot success, stop errors, McNemar."""
    rows = result.get("results") or summarize(result)
    config = result["config"]
    parts = [
        f"# Approach track: {result['dataset']}",
        "",
        f"{result['configurations']} configurations ({config['split']} split), seed "
        f"{config['seed']}, perception `{config['perception']}`{_map_words(config)}; "
        f"{len(result['skipped'])} starts that could not be placed.",
        "",
        markdown_table(rows),
        "",
        "Per robot (success):",
        "",
    ]
    robots = sorted({k for r in rows for k in r["per_robot"]})
    parts.append("| start | method (policy) | " + " | ".join(robots) + " |")
    parts.append("| --- | --- |" + " ---: |" * len(robots))
    for r in sorted(rows, key=lambda r: (r["start"] != "far", _label(r))):
        cells = [
            f"{100 * r['per_robot'][k]['success']:.0f} % ({r['per_robot'][k]['episodes']})"
            if k in r["per_robot"]
            else "-"
            for k in robots
        ]
        parts.append(f"| {r['start']} | {_label(r)} | " + " | ".join(cells) + " |")
    table = strata_table(rows)
    if table:
        parts += ["", "By what makes the stance hard (success, episodes):", "", table]
    sweep = sweep_table(rows)
    if sweep:
        parts += ["", "Success against the final-stop error (standard deviations):", "", sweep]
    pairs = result.get("pairs") or pairwise(result)
    if pairs:
        parts += ["", "McNemar's exact test, paired by configuration:", "", pairs_table(pairs)]
    return "\n".join(parts) + "\n"


CSV_COLUMNS = (
    "start",
    "method",
    "policy",
    "episodes",
    "success",
    "spl",
    "looks",
    "seconds",
    "cpu_seconds",
    "success_feasible",
    "blocked",
)


def summary_csv(rows: Sequence[dict[str, Any]]) -> str:
    """The summary rows as CSV: :data:`CSV_COLUMNS`, then success per stratum
    (``stratum:AXIS=VALUE``) and failures per stage (``failures:STAGE``)."""
    import csv
    import io

    strata = sorted({(a, v) for r in rows for a, g in r.get("per_stratum", {}).items() for v in g})
    stages = sorted({k for r in rows for k in r["failures"]})
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(
        [*CSV_COLUMNS, *(f"stratum:{a}={v}" for a, v in strata), *(f"failures:{k}" for k in stages)]
    )
    for r in sorted(rows, key=lambda r: (r["start"] != "far", _label(r))):
        cells = [r[c] for c in CSV_COLUMNS]
        cells += [
            r.get("per_stratum", {}).get(a, {}).get(v, {}).get("success", "") for a, v in strata
        ]
        cells += [r["failures"].get(k, 0) for k in stages]
        writer.writerow(cells)
    return buf.getvalue()


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """A plain-text table for the terminal."""
    out = [("start", "method (policy)", "episodes", "success", "SPL", "looks", "time (s)", "CPU s")]
    for r in sorted(rows, key=lambda r: (r["start"] != "far", -r["success"], _label(r))):
        out.append(
            (
                r["start"],
                _label(r),
                str(r["episodes"]),
                f"{100 * r['success']:.1f} %",
                f"{r['spl']:.3f}",
                f"{r['looks']:.2f}",
                f"{r['seconds']:.1f}",
                f"{r['cpu_seconds']:.1f}",
            )
        )
    widths = [max(len(row[i]) for row in out) for i in range(len(out[0]))]
    lines = [
        "  ".join(
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(row, widths, strict=True))
        )
        for row in out
    ]
    lines.insert(1, "-" * len(lines[0]))
    lines.append(
        "(success: the trial at the true final pose; SPL: success x L*/max(L, L*), L* the "
        "shortest free path to a successful grid cell; time: driving, turning, looks, inference)"
    )
    return "\n".join(lines)


def merge_results(parts: Sequence[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
    """One approach result from runs on the same dataset and settings: runs of other
    methods (e.g. the baselines in one run, each model in its own) and the parts of one
    split (``--part K/N``, every part with the same methods). Valid because an episode
    depends only on its configuration, start, method, policy and seed. The tables are
    computed again; MomaError when the runs' settings or datasets differ, two share a
    method on the same part, or the parts do not make up the whole split."""
    from momakitchen.errors import MomaError

    if not parts:
        raise MomaError("no approach results to merge")
    label0, first = parts[0]

    def settings(run: dict[str, Any]) -> dict[str, Any]:
        return {k: v for k, v in run["config"].items() if k not in ("starts", "policies", "part")}

    by_part: dict[tuple[int, ...], list[tuple[str, dict[str, Any]]]] = defaultdict(list)
    for label, run in parts:
        if run.get("dataset") != first.get("dataset"):
            raise MomaError(f"{label!r} differs from {label0!r} in dataset")
        if settings(run) != settings(first):
            raise MomaError(f"{label!r} was run with other settings than {label0!r}")
        by_part[tuple(run["config"].get("part", (1, 1)))].append((label, run))
    merged = {k: v for k, v in first.items() if k not in ("results", "pairs", "seconds")}
    merged["config"] = dict(first["config"], part=[1, 1])
    merged["records"], merged["skipped"], merged["configurations"] = [], [], 0
    methods: list[str] | None = None
    for key, runs in sorted(by_part.items()):
        here: list[str] = []
        for label, run in runs:
            if run.get("configurations") != runs[0][1].get("configurations"):
                raise MomaError(f"{label!r} differs from {runs[0][0]!r} in configurations")
            shared = sorted(set(run["methods"]) & set(here))
            if shared:
                raise MomaError(f"{label!r} repeats methods {shared}")
            here += run["methods"]
            merged["records"] += run["records"]
            merged["skipped"] += run.get("skipped", [])
        if methods is not None and sorted(here) != sorted(methods):
            raise MomaError(f"part {key[0]}/{key[1]} has methods {here}, part 1 has {methods}")
        methods = methods or here
        merged["configurations"] += runs[0][1]["configurations"]
    n = {key[1] for key in by_part}
    if len(n) != 1 or sorted(by_part) != [(k, *n) for k in range(1, next(iter(n)) + 1)]:
        got = ", ".join(f"{k}/{m}" for k, m in sorted(by_part))
        raise MomaError(f"the parts do not make up the whole split: got {got}")
    merged["methods"] = methods
    merged["results"] = summarize(merged)
    merged["pairs"] = pairwise(merged)
    return merged
