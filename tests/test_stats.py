"""Statistics against hand computations."""

import math

import numpy as np
import pytest

from graspjax.stats import mcnemar_p, mcnemar_z, paired_changes, paired_detectable, paired_difference, wilson


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


def test_paired_difference_by_hand_and_against_published_intervals():
    z = 1.959964
    half = z * math.sqrt(0.25 / 100 + z**2 / 40_000) / (1 + z**2 / 100)  # Wilson at 50 of 100
    # ad = bc: no correlation, each rate's distance to its Wilson bound added in square
    assert paired_difference(25, 25, 25, 25) == pytest.approx((0.0, -math.sqrt(2) * half,
                                                               math.sqrt(2) * half))
    # Fagerland, Lydersen & Laake's examples of Newcombe's interval (Statistical Analysis of
    # Contingency Tables, ch. 8): complete response before and after consolidation therapy
    # (Cavo et al. 2012), airway hyper-responsiveness before and after a stem cell transplant
    # (Bentur et al. 2009)
    assert paired_difference(59, 6, 16, 80) == pytest.approx((-10 / 161, -0.1186, -0.0046),
                                                             abs=6e-5)
    assert paired_difference(1, 1, 7, 12) == pytest.approx((-6 / 21, -0.507, -0.026), abs=6e-4)
    assert np.isnan(paired_difference(0, 0, 0, 0)).all()


def test_paired_difference_covers_the_true_difference_as_often_as_it_claims():
    """20,000 samples of pairs drawn from known cells: the 95 % interval holds the true
    difference in 95 % of them (+-1 point: the simulation's own error is 0.15). Where few
    pairs differ (nearly all alike, at 50 % or at 90 %) it stays at or above 95 %, where the
    Wald interval ((b - c) / n +- z se) falls below 90 %."""
    rng = np.random.default_rng(0)
    for cells, n, (least, most) in (((0.70, 0.06, 0.03, 0.21), 300, (0.94, 0.96)),
                                    ((0.50, 0.001, 0.0, 0.499), 1800, (0.95, 1.0)),
                                    ((0.90, 0.02, 0.005, 0.075), 100, (0.95, 1.0))):
        counts = rng.multinomial(n, cells, size=20_000).T
        truth = cells[1] - cells[2]
        _, low, high = paired_difference(*counts)
        assert least <= np.mean((low <= truth) & (truth <= high)) <= most
    gained, lost = counts[1], counts[2]  # the sparse cells: Wald's interval
    wald = (gained - lost) / n
    se = np.sqrt((gained + lost) / n**2 - (gained - lost) ** 2 / n**3)
    assert np.mean((wald - 1.96 * se <= truth) & (truth <= wald + 1.96 * se)) < 0.9
