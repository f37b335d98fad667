"""The statistics of the benchmark's comparisons, apart from its tables and figures:
McNemar's exact test of paired closed-loop outcomes and its power (how large a lead a
number of configurations can find, and how many configurations a lead needs), the sign
test of paired counts, the Wilcoxon signed-rank test of paired map metrics, and the
AUROC of a confidence score against outcomes."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from momakitchen.errors import MomaError


def mcnemar(a: Sequence[int], b: Sequence[int]) -> tuple[int, int, float]:
    """McNemar's exact test of two methods' paired outcomes (1 success, 0 failure) on the
    same configurations: (only a succeeded, only b succeeded, two-sided p-value). The p-value
    is the binomial test of the discordant pairs at 1/2."""
    if len(a) != len(b):
        raise MomaError(f"paired outcomes differ in length: {len(a)} and {len(b)}")
    pairs = [(bool(x), bool(y)) for x, y in zip(a, b, strict=True)]
    only_a, only_b = pairs.count((True, False)), pairs.count((False, True))
    return only_a, only_b, sign_test(only_a, only_b)


def mcnemar_power(
    configurations: int, discordant: float, lead: float, alpha: float = 0.05
) -> float:
    """Probability that :func:`mcnemar` finds method a ahead of method b (p < ``alpha``, more
    configurations solved only by a) over ``configurations`` independent configurations, where
    a configuration is solved by exactly one of the two with probability ``discordant``, and
    a's success rate exceeds b's by ``lead`` (only a: (discordant + lead) / 2, only b:
    (discordant - lead) / 2). Exact: summed over the number of discordant configurations."""
    from scipy.stats import binom

    if configurations < 1 or not 0 < discordant <= 1 or not 0 <= lead <= discordant:
        raise MomaError(
            f"mcnemar_power: want configurations >= 1 and 0 <= lead <= discordant <= 1, got "
            f"{configurations}, discordant {discordant}, lead {lead}"
        )
    d = np.arange(configurations + 1)
    # Two-sided exact test at 1/2: p = 2 P(X >= k) for k above d / 2, so a is ahead from the
    # least k with P(X >= k) < alpha / 2: isf(q) + 1 (the least k with P(X >= k) <= q), one
    # more where that is equality.
    k_min = binom.isf(alpha / 2, d, 0.5) + 1
    k_min = np.where(binom.sf(k_min - 1, d, 0.5) < alpha / 2, k_min, k_min + 1)
    given_d = binom.sf(k_min - 1, d, (discordant + lead) / (2 * discordant))
    return float(np.sum(binom.pmf(d, configurations, discordant) * given_d))


MAX_CONFIGURATIONS = 1_000_000  # configurations_needed gives up beyond


def detectable_lead(configurations: int, discordant: float, power: float) -> float:
    """The least lead (to 1e-4) that McNemar's test finds with probability ``power`` over
    ``configurations``, or NaN if even a lead of ``discordant`` is not found that often
    (power rises with the lead, so bisection finds it)."""
    if mcnemar_power(configurations, discordant, discordant) < power:
        return float("nan")
    lo, hi = 0.0, discordant
    while hi - lo > 1e-4:
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if mcnemar_power(configurations, discordant, mid) >= power else (mid, hi)
    return hi


def configurations_needed(discordant: float, lead: float, power: float) -> int:
    """The number of configurations (to 1 %) from which McNemar's test finds ``lead`` with
    probability ``power``: bisection between the powers of two around it. The exact test's
    power saw-tooths a little with the number of configurations, so a slightly smaller number
    may reach ``power`` too (by a few configurations, at discordant rates near 1)."""
    if lead <= 0:
        raise MomaError(f"a lead of {lead} is never found ahead; want a positive lead")
    lo, hi = 0, 1
    while mcnemar_power(hi, discordant, lead) < power:
        lo, hi = hi, 2 * hi
        if hi > MAX_CONFIGURATIONS:
            raise MomaError(f"a lead of {lead} needs over {MAX_CONFIGURATIONS} configurations")
    while hi - lo > max(1, hi // 100):
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if mcnemar_power(mid, discordant, lead) >= power else (mid, hi)
    return hi


def sign_test(ahead: int, behind: int) -> float:
    """Two-sided sign test: the p-value of ``ahead`` against ``behind`` paired differences
    (ties dropped) under equal chances; 1 when there are none."""
    from scipy.stats import binomtest

    n = ahead + behind
    return float(binomtest(ahead, n, 0.5).pvalue) if n else 1.0


def signed_rank_test(differences: np.ndarray) -> float:
    """Two-sided Wilcoxon signed-rank p-value of paired ``differences`` (shape (n,)); 1 when
    all of them are zero."""
    from scipy.stats import wilcoxon

    d = np.asarray(differences, np.float64)
    return float(wilcoxon(d).pvalue) if np.any(d != 0) else 1.0


def auroc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Probability that a random success scores higher than a random failure (ties 1/2)."""
    pos, neg = scores[labels == 1], scores[labels == 0]
    if not len(pos) or not len(neg):
        return float("nan")
    greater = (pos[:, None] > neg[None, :]).mean()
    ties = (pos[:, None] == neg[None, :]).mean()
    return float(greater + 0.5 * ties)
