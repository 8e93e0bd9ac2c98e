"""The book's intervals (hoi_tutorial.intervals) at cases with known answers and against scipy's."""
import numpy as np
import pytest
import torch
from scipy import stats

from hoi_tutorial.intervals import (VERDICTS, Interval, bootstrap_interval, correlation_interval, paired_difference,
                                    share_interval, unpaired_difference)


# ----------------------------------------------------------------------------- the paired bootstrap


def test_paired_bootstrap_of_normal_differences_matches_the_normal_interval():
    # For N = 400 differences from N(0.3, 1) the percentile bootstrap of the mean is close to
    # mean +- 1.96 s / sqrt(N) (the central limit theorem's interval).
    rng = np.random.default_rng(0)
    b = rng.normal(0.0, 2.0, 400)
    a = b + rng.normal(0.3, 1.0, 400)
    found = paired_difference(a, b, resamples=8000, seed=1)
    d = a - b
    half = 1.96 * d.std(ddof=1) / np.sqrt(len(d))
    assert found.estimate == pytest.approx(d.mean(), abs=1e-12)
    assert found.low == pytest.approx(d.mean() - half, abs=0.15 * half)
    assert found.high == pytest.approx(d.mean() + half, abs=0.15 * half)
    assert found.n == 400 and found.level == 0.95 and found.verdict("above") == "held"


def test_pairing_matters_a_shared_case_effect_cancels():
    # Each case has a large effect shared by both methods (the scene's difficulty) and a small constant
    # advantage of a: paired, the interval is tight around it; unpaired, the case effect would swamp it.
    rng = np.random.default_rng(2)
    case = rng.normal(0, 5, 50)
    a, b = case + 0.1 + rng.normal(0, 0.01, 50), case
    found = paired_difference(a, b)
    assert found.low > 0.09 and found.high < 0.11
    shuffled = paired_difference(a, rng.permutation(b))   # pairs broken: the same means, a wide interval
    assert shuffled.side() == "straddles"


def test_paired_bootstrap_agrees_with_scipy_bootstrap():
    rng = np.random.default_rng(3)
    a, b = rng.gamma(2.0, 1.0, 60), rng.gamma(2.0, 0.8, 60)
    ours = paired_difference(a, b, resamples=20000, seed=4)
    theirs = stats.bootstrap((a, b), lambda x, y, axis=-1: np.mean(x, axis=axis) - np.mean(y, axis=axis),
                             paired=True, vectorized=True, n_resamples=20000, method="percentile",
                             random_state=np.random.default_rng(5)).confidence_interval
    width = ours.high - ours.low
    assert ours.low == pytest.approx(theirs.low, abs=0.05 * width)    # two Monte-Carlo estimates of one interval
    assert ours.high == pytest.approx(theirs.high, abs=0.05 * width)


def test_median_statistic_is_the_difference_of_medians_and_a_callable_works():
    a = np.array([1.0, 2.0, 3.0, 4.0, 100.0])
    b = np.array([0.0, 0.0, 1.0, 1.0, 1.0])
    assert paired_difference(a, b, statistic="median").estimate == 2.0
    assert paired_difference(a, b).estimate == pytest.approx(np.mean(a - b))
    trimmed = paired_difference(a, b, statistic=lambda x, axis: np.sort(x, axis=axis)[..., :-1].mean(axis=axis))
    assert trimmed.estimate == pytest.approx(np.mean(a[:-1]) - np.mean(b[:-1]))


def test_constant_differences_give_a_point_and_zero_is_inconclusive():
    a = np.linspace(0, 1, 20)
    same = paired_difference(a, a)
    assert same.low == same.high == same.estimate == 0.0
    assert same.verdict("above") == "inconclusive" and same.verdict("below") == "inconclusive"
    shifted = paired_difference(a + 0.5, a)
    assert shifted.low == pytest.approx(0.5) and shifted.high == pytest.approx(0.5)
    assert shifted.verdict("above") == "held" and shifted.verdict("below") == "not held"


def test_booleans_torch_and_determinism():
    a = torch.tensor([True, True, False, True, True, False, True, True])
    b = np.array([False, True, False, False, True, False, False, False])
    found = paired_difference(a, b, seed=7)
    assert found.estimate == pytest.approx(6 / 8 - 2 / 8)
    assert found == paired_difference(a.numpy(), b, seed=7)               # the same seed, the same interval
    x = np.random.default_rng(0).normal(size=30)
    assert paired_difference(x, 0 * x, seed=7) != paired_difference(x, 0 * x, seed=8)   # the seed is used


@pytest.mark.parametrize("a, b, match", [
    (np.ones(5), np.ones(4), "the same length"),
    (np.ones(1), np.ones(1), "at least 2 test cases"),
    (np.array([1.0, np.nan]), np.ones(2), "finite"),
    (np.ones((2, 3)), np.ones((2, 3)), "1-D"),
    (np.array(["a", "b"]), np.ones(2), "numbers or booleans"),
])
def test_paired_bootstrap_errors(a, b, match):
    with pytest.raises((ValueError, TypeError), match=match):
        paired_difference(a, b)


def test_paired_bootstrap_argument_errors():
    with pytest.raises(ValueError, match="statistic"):
        paired_difference(np.ones(3), np.ones(3), statistic="mode")
    with pytest.raises(ValueError, match="level"):
        paired_difference(np.ones(3), np.ones(3), level=95)
    with pytest.raises(ValueError, match="resamples"):
        paired_difference(np.ones(3), np.ones(3), resamples=10)
    with pytest.raises(ValueError, match="reduce the last axis"):
        paired_difference(np.ones(3), np.ones(3), statistic=lambda x, axis: x)


def test_one_sample_bootstrap_of_a_mean_and_a_median():
    rng = np.random.default_rng(6)
    x = rng.normal(1.5, 0.5, 500)
    found = bootstrap_interval(x, resamples=8000, seed=2)
    half = 1.96 * x.std(ddof=1) / np.sqrt(len(x))
    assert found.low == pytest.approx(x.mean() - half, abs=0.15 * half)
    assert found.high == pytest.approx(x.mean() + half, abs=0.15 * half)
    assert found.method == "bootstrap (mean)" and found.verdict("above", 1.4) == "held"
    # the same numbers as a paired difference with nothing subtracted
    paired = paired_difference(x, np.zeros_like(x), resamples=8000, seed=2)
    assert (paired.low, paired.high, paired.estimate) == (found.low, found.high, found.estimate)
    median = bootstrap_interval(x, statistic="median")
    assert median.estimate == np.median(x) and median.low < np.median(x) < median.high
    with pytest.raises(ValueError, match="at least 2"):
        bootstrap_interval([1.0])


def test_block_bootstrap_widens_the_interval_of_a_correlated_series():
    # An AR(1) series with phi = 0.9: the variance of its mean is (1 + phi) / (1 - phi) = 19 times that of as many
    # independent values, so the honest interval is about sqrt(19) = 4.4 times wider than the one that resamples
    # single values. Blocks of 100 values recover most of it.
    rng = np.random.default_rng(8)
    phi, n = 0.9, 4000
    x = np.zeros(n)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + rng.normal()
    single = bootstrap_interval(x, seed=1)
    blocks = bootstrap_interval(x, seed=1, block=100)
    ratio = (blocks.high - blocks.low) / (single.high - single.low)
    assert 3.0 < ratio < 5.5, ratio
    assert blocks.estimate == single.estimate and blocks.method == "bootstrap in blocks of 100 (mean)"
    # independent values: blocks change little
    y = rng.normal(size=n)
    wide = bootstrap_interval(y, seed=1, block=50)
    narrow = bootstrap_interval(y, seed=1)
    assert 0.8 < (wide.high - wide.low) / (narrow.high - narrow.low) < 1.25
    paired = paired_difference(x + 1.0, x, block=100)   # a constant shift stays exact, in blocks too
    assert paired.low == pytest.approx(1.0) and paired.high == pytest.approx(1.0)
    for bad in (0, n + 1, 2.5, True):
        with pytest.raises(ValueError, match="block"):
            bootstrap_interval(x, block=bad)


def test_unpaired_bootstrap_matches_the_two_sample_normal_interval_and_scipy():
    rng = np.random.default_rng(9)
    a, b = rng.normal(1.0, 1.0, 300), rng.normal(0.7, 2.0, 500)
    found = unpaired_difference(a, b, resamples=10000, seed=3)
    half = 1.96 * np.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    d = a.mean() - b.mean()
    assert found.estimate == pytest.approx(d) and found.n == 800 and found.method == "unpaired bootstrap (mean)"
    assert found.low == pytest.approx(d - half, abs=0.15 * half) and found.high == pytest.approx(d + half, abs=0.15 * half)
    theirs = stats.bootstrap((a, b), lambda x, y, axis=-1: np.mean(x, axis=axis) - np.mean(y, axis=axis),
                             paired=False, vectorized=True, n_resamples=10000, method="percentile",
                             random_state=np.random.default_rng(4)).confidence_interval
    assert found.low == pytest.approx(theirs.low, abs=0.05 * 2 * half)
    assert found.high == pytest.approx(theirs.high, abs=0.05 * 2 * half)
    # groups of different sizes and a median; too small a group is refused
    assert unpaired_difference(np.arange(5.0), np.arange(3.0), statistic="median").estimate == 1.0
    with pytest.raises(ValueError, match="at least 2 cases in each group"):
        unpaired_difference(np.ones(5), np.ones(1))
    with pytest.raises(ValueError, match="statistic"):
        unpaired_difference(np.ones(3), np.ones(3), statistic="mode")


# ----------------------------------------------------------------------------- shares


@pytest.mark.parametrize("k, n", [(0, 10), (3, 10), (8, 16), (12, 16), (16, 16), (17, 40), (1, 1)])
@pytest.mark.parametrize("method, scipy_method", [("wilson", "wilson"), ("exact", "exact")])
def test_share_interval_equals_scipy(k, n, method, scipy_method):
    ours = share_interval(k, n, method=method)
    theirs = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method=scipy_method)
    assert ours.estimate == k / n and ours.n == n
    np.testing.assert_allclose([ours.low, ours.high], [theirs.low, theirs.high], rtol=1e-9, atol=1e-12)


def test_share_interval_known_values_and_threshold_verdicts():
    # Wilson's interval for 12 of 16 at 95 %: [0.505, 0.898] (from its closed form) -- most, but only just;
    # 8 of 16 straddles one half; 2 of 16 lies below it.
    twelve = share_interval(12, 16)
    assert twelve.low == pytest.approx(0.5050, abs=5e-4) and twelve.high == pytest.approx(0.8982, abs=5e-4)
    assert twelve.verdict("above", 0.5) == "held"
    assert share_interval(8, 16).verdict("above", 0.5) == "inconclusive"
    assert share_interval(2, 16).verdict("above", 0.5) == "not held"
    flags = np.array([True] * 12 + [False] * 4)
    assert share_interval(flags) == twelve
    assert share_interval(torch.from_numpy(flags)) == twelve


@pytest.mark.parametrize("args, kwargs, match", [
    ((3,), {}, "trials"),
    ((5, 4), {}, "0 <= k <= n"),
    ((0, 0), {}, "n >= 1"),
    ((np.array([1, 0]),), {}, "boolean array"),
    ((np.array([True]), 1), {}, "only with a count"),
    ((True, 2), {}, "got a bool"),
    ((1, 2), {"method": "agresti"}, "method"),
    ((1, 2), {"level": 1.0}, "level"),
])
def test_share_interval_errors(args, kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        share_interval(*args, **kwargs)


# ----------------------------------------------------------------------------- the verdict


def test_verdict_reads_the_side_of_the_threshold():
    interval = Interval(estimate=0.3, low=0.1, high=0.5, level=0.95, n=20, method="test")
    assert interval.verdict("above") == "held" and interval.holds("above")
    assert interval.verdict("below") == "not held" and not interval.holds("below")
    assert interval.verdict("above", 0.2) == "inconclusive"
    assert interval.verdict("above", 0.1) == "inconclusive"                  # touching the threshold straddles it
    assert interval.verdict("below", 0.6) == "held"
    assert set(VERDICTS) == {"held", "inconclusive", "not held"}
    assert interval.format(scale=100, unit="cm") == "30 cm [10, 50]"
    assert "n = 20" in str(interval)
    with pytest.raises(ValueError, match="claimed"):
        interval.verdict("higher")


@pytest.mark.parametrize("n, slope", [(10, 0.3), (40, -1.0), (200, 0.05)])
def test_correlation_interval_equals_scipy(n, slope):
    rng = np.random.default_rng(n)
    x = rng.normal(size=n)
    y = slope * x + rng.normal(size=n)
    found = correlation_interval(x, y)
    expected = stats.pearsonr(x, y)
    ci = expected.confidence_interval(0.95)
    np.testing.assert_allclose([found.estimate, found.low, found.high], [expected.statistic, ci.low, ci.high],
                               rtol=1e-9, atol=1e-12)
    assert found.n == n and found.low < found.estimate < found.high


def test_correlation_interval_verdicts_and_errors():
    x = np.arange(30.0)
    assert correlation_interval(x, 2 * x + np.sin(x)).verdict("above") == "held"
    assert correlation_interval(x, -x + np.sin(x)).verdict("above") == "not held"
    noise = np.random.default_rng(1).normal(size=30)
    assert correlation_interval(x, noise).verdict("above") == "inconclusive"
    with pytest.raises(ValueError, match="at least 4"):
        correlation_interval([1, 2, 3], [1, 2, 3])
    with pytest.raises(ValueError, match="vary"):
        correlation_interval(x, np.ones(30))
    with pytest.raises(ValueError, match="same length"):
        correlation_interval(x, x[:10])


def test_a_claim_that_allows_a_tie_fails_only_wholly_on_the_other_side():
    tie = Interval(0.0, 0.0, 0.0, 0.95, 10, "paired bootstrap (mean)")
    straddles = Interval(0.1, -0.2, 0.3, 0.95, 10, "paired bootstrap (mean)")
    below = Interval(-0.5, -0.8, -0.1, 0.95, 10, "paired bootstrap (mean)")
    assert tie.verdict("above") == "inconclusive" and tie.verdict("above", strict=False) == "held"
    assert straddles.verdict("above", strict=False) == "held"
    assert below.verdict("above", strict=False) == "not held" and below.verdict("below", strict=False) == "held"
