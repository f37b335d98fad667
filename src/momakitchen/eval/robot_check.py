"""Does a model serve a robot? The closed-loop gap between a model and the oracle on a
robot's own scenes, with a 95 % interval and a verdict (``momakitchen robot-check``).

The gap is the oracle's Top-1 MSR less the model's, over the same configurations (paired:
both judged on the same view of each). Its interval is a paired bootstrap over
configurations (SciPy's ``bootstrap``, percentile method, seeded): the configurations of a
few scenes are what varies from one check to the next.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.eval.methods import CLASSICAL

# The verdicts, in the order a check can end.
SERVES, UNDECIDED, DOES_NOT_SERVE = "serves", "undecided", "does-not-serve"
BOOTSTRAP_RESAMPLES = 9999


def top1_outcomes(result: dict[str, Any], name: str) -> list[int]:
    """One method's Top-1 outcome (1 success, 0 failure) per configuration of an
    ``msr`` result, in its order; MomaError when the result has no such method."""
    if name not in result.get("methods", {}):
        raise MomaError(f"msr result has no method {name!r}: {', '.join(result['methods'])}")
    outcomes = [r["methods"][name]["outcomes"] for r in result["records"]]
    return [int(o[0]) if o else 0 for o in outcomes]


def gap_interval(
    model: Sequence[int], oracle: Sequence[int], confidence: float = 0.95, seed: int = 0
) -> tuple[float, float, float]:
    """(gap, low, high): the oracle's success rate less the model's over paired
    outcomes, and its ``confidence`` interval by a paired bootstrap over
    configurations."""
    from scipy.stats import bootstrap

    if len(model) != len(oracle) or not len(model):
        raise MomaError(f"want paired outcomes, got {len(model)} and {len(oracle)}")
    d = np.asarray(oracle, float) - np.asarray(model, float)
    gap = float(d.mean())
    if np.all(d == d[0]):  # every resample has the same mean (SciPy warns and gives NaN)
        return gap, gap, gap
    ci = bootstrap(
        (d,),
        np.mean,
        confidence_level=confidence,
        n_resamples=BOOTSTRAP_RESAMPLES,
        method="percentile",
        rng=np.random.default_rng(seed),
    ).confidence_interval
    return gap, float(ci.low), float(ci.high)


def gap_closed_interval(
    model: Sequence[int],
    oracle: Sequence[int],
    random: Sequence[int],
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float]:
    """The ``confidence`` interval of the share of the random -> oracle gap a model closes,
    ``(rate(model) - rate(random)) / (rate(oracle) - rate(random))``, by a paired bootstrap
    over configurations (NaN bounds if some resample has the oracle no better than random,
    where the share is undefined)."""
    from scipy.stats import bootstrap

    if not len(model) == len(oracle) == len(random) or not len(model):
        raise MomaError(f"want paired outcomes, got {len(model)}, {len(oracle)} and {len(random)}")

    def share(m: np.ndarray, o: np.ndarray, r: np.ndarray, axis: int = -1) -> np.ndarray:
        span = o.mean(axis) - r.mean(axis)
        closed = m.mean(axis) - r.mean(axis)
        return np.where(span > 0, closed / np.where(span > 0, span, 1.0), np.nan)

    m, o, r = (np.asarray(x, float) for x in (model, oracle, random))
    value = float(share(m, o, r))
    if np.isnan(value) or all(np.all(x == x[0]) for x in (m, o, r)):
        return value, value
    ci = bootstrap(
        (m, o, r),
        share,
        paired=True,
        vectorized=True,
        confidence_level=confidence,
        n_resamples=BOOTSTRAP_RESAMPLES,
        method="percentile",
        rng=np.random.default_rng(seed),
    ).confidence_interval
    return float(ci.low), float(ci.high)


def verdict(gap: float, low: float, high: float, tolerance: float) -> str:
    """:data:`SERVES` when the whole interval lies within ``tolerance`` of the oracle,
    :data:`DOES_NOT_SERVE` when all of it lies beyond, else :data:`UNDECIDED`."""
    if high <= tolerance:
        return SERVES
    if low > tolerance:
        return DOES_NOT_SERVE
    return UNDECIDED


def check_summary(
    result: dict[str, Any], model: str, robot: str, tolerance: float, seed: int = 0
) -> dict[str, Any]:
    """The check of ``model`` against the oracle and random in one ``msr`` result (which
    ran the model and the ``oracle`` and ``random`` baselines, and the classical methods
    where it ran them: their rates too): rates, the gap and its
    interval, the share of the random-to-oracle gap the model closes, and the verdict."""
    classical = [m for m in CLASSICAL if m in result["methods"]]  # older results: none
    outcomes = {m: top1_outcomes(result, m) for m in (model, "oracle", "random", *classical)}
    if not any(outcomes["oracle"]):
        raise MomaError(
            f"the oracle solves none of the {len(outcomes['oracle'])} configurations: "
            f"no grid trial of robot {robot!r} succeeded, so the check cannot judge a model "
            "(see `momakitchen label --robot` for why its trials fail)"
        )
    rate = {m: float(np.mean(o)) for m, o in outcomes.items()}
    gap, low, high = gap_interval(outcomes[model], outcomes["oracle"], seed=seed)
    span = rate["oracle"] - rate["random"]
    return {
        "robot": robot,
        "model": model,
        "configurations": len(outcomes[model]),
        "feasible": int(sum(r["feasible"] for r in result["records"])),
        "top1": rate,
        "gap": gap,
        "gap_interval": [low, high],
        "tolerance": tolerance,
        "gap_closed": (rate[model] - rate["random"]) / span if span > 0 else None,
        "verdict": verdict(gap, low, high, tolerance),
    }


def format_check(summary: dict[str, Any], label: str = "") -> str:
    """The check as a few lines of text, ending with the verdict."""
    s, pct = summary, lambda x: f"{100 * x:.1f} %"
    low, high = s["gap_interval"]
    closed = "" if s["gap_closed"] is None else f"; closes {pct(s['gap_closed'])} of random's gap"
    classical = ", ".join(f"{m} {pct(s['top1'][m])}" for m in CLASSICAL if m in s["top1"])
    lines = [
        f"{label or s['model']} on {s['robot']}: {s['configurations']} configurations "
        f"({s['feasible']} where some grid trial succeeds), Top-1 in closed loop",
        f"  model {pct(s['top1'][s['model']])}, oracle {pct(s['top1']['oracle'])}, "
        f"random {pct(s['top1']['random'])}" + (f"; classical: {classical}" if classical else ""),
        f"  gap to the oracle {100 * s['gap']:.1f} points (95 % interval {100 * low:.1f} to "
        f"{100 * high:.1f}){closed}",
    ]
    tol = f"{100 * s['tolerance']:.0f} points"
    words = {
        SERVES: f"serves {s['robot']}: within {tol} of the oracle (the whole interval)",
        DOES_NOT_SERVE: f"does not serve {s['robot']}: more than {tol} below the oracle "
        "(the whole interval); fine-tune it on this robot (--finetune-scenes)",
        UNDECIDED: f"cannot tell yet: the interval spans the {tol} tolerance; more scenes "
        "narrow it (--scenes)",
    }
    lines.append(f"verdict: {words[s['verdict']]}")
    return "\n".join(lines)
