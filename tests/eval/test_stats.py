"""The benchmark's statistics, in their own module: exact values on small cases, and the
report itself computes no statistic of its own."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from momakitchen.eval import stats


def test_sign_test_is_the_exact_binomial_at_one_half():
    assert stats.sign_test(5, 0) == pytest.approx(2 * 0.5**5)
    assert stats.sign_test(3, 3) == 1.0 and stats.sign_test(0, 0) == 1.0
    assert stats.sign_test(9, 1) == stats.sign_test(1, 9)


def test_mcnemar_is_the_sign_test_of_the_discordant_pairs():
    a, b = [1, 1, 1, 1, 0, 0, 1], [0, 0, 0, 0, 0, 1, 1]
    assert stats.mcnemar(a, b) == (4, 1, stats.sign_test(4, 1))


def test_signed_rank_test():
    assert stats.signed_rank_test(np.zeros(5)) == 1.0
    assert stats.signed_rank_test(np.arange(1.0, 11.0)) < 0.01
    assert math.isclose(stats.signed_rank_test(np.array([1.0, -1.0])), 1.0)


def test_auroc():
    scores = np.array([0.9, 0.8, 0.3, 0.1])
    assert stats.auroc(scores, np.array([1, 1, 0, 0])) == 1.0
    assert stats.auroc(scores, np.array([0, 0, 1, 1])) == 0.0
    assert stats.auroc(np.ones(4), np.array([1, 0, 1, 0])) == 0.5
    assert math.isnan(stats.auroc(scores, np.ones(4, int)))


def test_the_report_computes_no_statistic_itself():
    for part in sorted((Path(stats.__file__).parent / "report").glob("*.py")):
        source = part.read_text()
        assert not re.search(
            r"scipy|binomtest|wilcoxon|def (mcnemar|auroc|detectable_lead)", source
        )
