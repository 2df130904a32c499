"""Statistics of success rates: intervals, paired tests and the differences a sample can detect."""

from __future__ import annotations

import math

import numpy as np


def wilson(successes, n, z: float = 1.959964):
    """95% Wilson score interval (low, high) for `successes` out of `n` (arrays or scalars)."""
    successes, n = np.asarray(successes, float), np.asarray(n, float)
    p = np.where(n > 0, successes / np.maximum(n, 1), np.nan)
    denom = 1 + z**2 / np.maximum(n, 1)
    centre = (p + z**2 / (2 * np.maximum(n, 1))) / denom
    half = z * np.sqrt(p * (1 - p) / np.maximum(n, 1) + z**2 / (4 * np.maximum(n, 1) ** 2)) / denom
    low, high = np.clip(centre - half, 0, 1), np.clip(centre + half, 0, 1)
    return np.fmin(low, p), np.fmax(high, p)  # rounding must never leave p outside


def detectable_difference(rate: float, n: int) -> float:
    """Smallest difference of two rates near `rate`, each from `n` independent views, that a
    two-sided test at 5 % finds with 80 % power (normal approximation; `summarize` passes the
    rate as (k + 1) / (n + 2), so a rate of 0 or 1 does not claim a zero difference)."""
    return (1.96 + 0.84) * np.sqrt(2 * max(rate * (1 - rate), 1e-12) / max(n, 1))


def mcnemar_p(only_here: int, only_reference: int) -> float:
    """Exact two-sided McNemar p: the discordant pairs split as a fair coin would split them."""
    n, k = only_here + only_reference, min(only_here, only_reference)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n
    return min(1.0, 2 * tail)


def mcnemar_z(only_here: int, only_reference: int) -> float:
    """McNemar's z of paired binary outcomes, (b - c) / sqrt(b + c); 0 when no pair differs."""
    n = only_here + only_reference
    return (only_here - only_reference) / math.sqrt(n) if n else 0.0


def paired_changes(before, after) -> tuple[int, int, float]:
    """Paired bool outcomes (arrays of the same pairs): (gained, lost, McNemar's z), `gained`
    the pairs that succeed after but not before."""
    before, after = np.asarray(before, bool), np.asarray(after, bool)
    gained, lost = int((after & ~before).sum()), int((before & ~after).sum())
    return gained, lost, mcnemar_z(gained, lost)


def paired_difference(both, gained, lost, neither, z: float = 1.959964):
    """The difference of two success rates measured on the same pairs, with its 95 % interval:
    (difference, low, high) as fractions (arrays or scalars). The pairs: `both` succeed,
    `gained` succeed only in the first sample, `lost` only in the second, `neither`; the
    difference is (gained - lost) / pairs. The interval is Newcombe's square-and-add interval
    (1998, Statistics in Medicine 17:2635, method 10): each rate's Wilson interval, combined
    with the correlation of the pairs' outcomes, its numerator ad - bc lessened by n / 2 when
    positive (0 when that leaves it below 0, or a margin is empty), so that pairs all alike do
    not claim a perfect correlation. Unlike the Wald interval it keeps its coverage where few
    pairs differ (tests/test_stats.py). nan for no pairs."""
    a, b, c, d = (np.asarray(x, float) for x in (both, gained, lost, neither))
    n = a + b + c + d
    first, second = (a + b) / np.where(n > 0, n, np.nan), (a + c) / np.where(n > 0, n, np.nan)
    low1, high1 = wilson(a + b, n, z)
    low2, high2 = wilson(a + c, n, z)
    margins = (a + b) * (c + d) * (a + c) * (b + d)
    alike = a * d - b * c
    alike = np.where(alike > n / 2, alike - n / 2, np.minimum(alike, 0.0))
    phi = np.where(margins > 0, alike / np.sqrt(np.where(margins > 0, margins, 1.0)), 0.0)
    below = np.sqrt(np.maximum(0.0, (first - low1) ** 2 - 2 * phi * (first - low1) * (high2 - second)
                               + (high2 - second) ** 2))
    above = np.sqrt(np.maximum(0.0, (high1 - first) ** 2 - 2 * phi * (high1 - first) * (second - low2)
                               + (second - low2) ** 2))
    difference = first - second
    return difference, np.maximum(difference - below, -1.0), np.minimum(difference + above, 1.0)


def paired_detectable(discordant: int, pairs: int) -> float:
    """Smallest paired difference of success rates detectable at 5 % (two-sided), 80 % power."""
    share = max(discordant, 1) / max(pairs, 1)
    return (1.96 + 0.84) * math.sqrt(share / max(pairs, 1))


def mean_interval(values, z: float = 1.959964) -> tuple[float, float, float]:
    """Mean of per-round values and its 95% normal interval (mean +- z s / sqrt(n)); nan for
    no values, the mean itself for one."""
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    if not len(values):
        return math.nan, math.nan, math.nan
    mean = float(values.mean())
    half = z * float(values.std(ddof=1)) / math.sqrt(len(values)) if len(values) > 1 else 0.0
    return mean, mean - half, mean + half
