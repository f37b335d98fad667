"""How large a closed-loop lead can McNemar's test see on these configurations? The power of
the test `momakitchen msr` and `benchmark` report, from two methods' measured Top-1 outcomes.

    python analyses/msr_power.py --reference navaff --other pointnet2 \
        --msr results/runs/navaff-12ep/msr.json results/runs/pointnet2-12ep/msr.json

From the configurations solved by only one of the two (their share: the discordant rate)
and the measured lead (difference of Top-1 rates), it prints McNemar's test as measured,
the test's power for the measured lead on this many configurations, the lead it detects
with ``--power`` on them, and how many configurations it would need for the measured lead
(or ``--lead``). The discordant rate is held at its measured value (at least the lead):
configurations are taken as independent, each discordant with that probability.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.msr import merge_msr
from momakitchen.eval.report.tables import top1_outcomes
from momakitchen.eval.stats import (
    configurations_needed,
    detectable_lead,
    mcnemar,
    mcnemar_power,
)
from momakitchen.fileio import read_json_object


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--msr", type=Path, nargs="+", required=True, help="`momakitchen msr` JSONs")
    ap.add_argument("--reference", required=True, help="the method hoped to be ahead")
    ap.add_argument("--other", required=True, help="the method it is tested against")
    ap.add_argument("--power", type=float, default=0.8, help="wanted power (default 0.8)")
    ap.add_argument(
        "--lead", type=float, default=None, help="plan for this lead (e.g. 0.01) instead"
    )
    ap.add_argument("--alpha", type=float, default=0.05, help="significance level (0.05)")
    args = ap.parse_args(argv)
    if not args.alpha / 2 < args.power < 1 or not 0 < args.alpha < 1:
        raise MomaError(
            f"want 0 < --alpha < 1 and --alpha / 2 < --power < 1 (below that a test finds "
            f"anything by chance), got --alpha {args.alpha}, --power {args.power}"
        )
    if args.lead is not None and not 0 < args.lead <= 1:  # also rejects NaN
        raise MomaError(
            f"--lead must lie in (0, 1] (a difference of success rates), got {args.lead}"
        )
    if args.reference == args.other:
        raise MomaError(f"--reference and --other are both {args.reference!r}")
    msr = merge_msr([(str(p), read_json_object(p)) for p in args.msr])
    for name in (args.reference, args.other):
        if name not in msr["methods"]:
            raise MomaError(f"method {name!r} is not in the MSR results: {list(msr['methods'])}")
    a, b = top1_outcomes(msr, args.reference), top1_outcomes(msr, args.other)
    n = len(a)
    only_a, only_b, p = mcnemar(a, b)
    measured = (only_a + only_b) / n
    lead = (only_a - only_b) / n if args.lead is None else args.lead
    discordant = max(measured, lead)  # only-a configurations alone make the lead
    if discordant == 0:
        raise MomaError("the two methods agree on every configuration: nothing to test")
    pct = f"{100 * args.power:.0f} %"
    found = detectable_lead(n, discordant, args.power)
    if lead > 0:  # everything computed before anything is printed
        power = mcnemar_power(n, discordant, lead, args.alpha)
        need = configurations_needed(discordant, lead, args.power)

    print(
        f"{n} configurations: {args.reference} {100 * np.mean(a):.1f} %, {args.other} "
        f"{100 * np.mean(b):.1f} % Top-1; only {args.reference} {only_a}, only {args.other} "
        f"{only_b} (discordant {100 * measured:.1f} %), McNemar p = {p:.2g}"
    )
    held = "" if discordant == measured else f", discordant rate held at {100 * discordant:.1f} %"
    source = "measured" if args.lead is None else "planned"
    if lead > 0:
        print(
            f"{source} lead {100 * lead:+.1f} points{held}: power {100 * power:.0f} % on {n} "
            f"configurations; {pct} power needs {need} configurations ({need / n:.1f}x)"
        )
    else:
        print(f"{source} lead {100 * lead:+.1f} points: not ahead, so no number of configurations")
    print(
        f"least lead found with {pct} power on {n} configurations: "
        + ("none up to the discordant rate" if np.isnan(found) else f"{100 * found:.1f} points")
    )


if __name__ == "__main__":
    run_main(main, "msr_power.py")
