"""Statistics against hand computations."""

import math

import numpy as np
import pytest

from graspjax.stats import mcnemar_p, mcnemar_z, paired_changes, paired_detectable, wilson


def test_paired_changes_count_gains_and_losses_by_hand():
    before = [True, True, False, False, True, False]
    after = [True, False, True, True, True, True]
    # pairs 2, 3 and 5 succeed only after (gained), pair 1 only before (lost): z = 2 / sqrt(4)
    assert paired_changes(before, after) == (3, 1, pytest.approx(1.0))
    assert paired_changes(after, before) == (1, 3, pytest.approx(-1.0))
    assert paired_changes(before, before) == (0, 0, 0.0)  # no discordant pair
    assert mcnemar_z(9, 0) == pytest.approx(3.0)


def test_mcnemar_p_is_the_exact_binomial_tail():
    # 1 of 6 discordant pairs one way: 2 (C(6,0) + C(6,1)) / 64 = 14 / 64
    assert mcnemar_p(1, 5) == pytest.approx(14 / 64)
    assert mcnemar_p(3, 3) == 1.0 and mcnemar_p(0, 0) == 1.0


def test_wilson_interval_and_detectable_difference_by_hand():
    low, high = wilson(5, 10)  # p = 0.5: centre 0.5, half z sqrt(p q / n + z^2 / 4n^2) / (1 + z^2 / n)
    z = 1.959964
    half = z * math.sqrt(0.025 + z**2 / 400) / (1 + z**2 / 10)
    assert (float(low), float(high)) == pytest.approx((0.5 - half, 0.5 + half))
    assert np.isnan(wilson(0, 0)[0])
    # 2.8 sqrt(p_d / n) with p_d = 100 / 1000 discordant of 1,000 pairs
    assert paired_detectable(100, 1000) == pytest.approx(2.8 * math.sqrt(0.1 / 1000))
