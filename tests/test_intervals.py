"""The book's intervals (hoi_tutorial.intervals) at cases with known answers, against scipy's, and by coverage."""
import math

import numpy as np
import pytest
import torch
from scipy import stats

from hoi_tutorial.intervals import (VERDICTS, Interval, correlation_interval, one_sample_interval, paired_difference,
                                    share_interval, shift_interval, sign_flip_interval, sign_test_interval,
                                    unpaired_difference)


# ----------------------------------------------------------------------------- coverage at the book's sample sizes

# The differences the book meets, each with its true mean and median: normal, heavy-tailed (t, 3 degrees of
# freedom) and moderately skewed (a lognormal with sigma = 0.5, centred on its mean).
_SKEW_MEAN = math.exp(0.125)
_DIFFERENCES = {
    "normal": (lambda rng, n: rng.normal(size=n), 0.0, 0.0),
    "t3": (lambda rng, n: rng.standard_t(3, size=n), 0.0, 0.0),
    "skewed": (lambda rng, n: rng.lognormal(0.0, 0.5, size=n) - _SKEW_MEAN, 0.0, 1.0 - _SKEW_MEAN),
}
_RUNS = 1000  # simulated comparisons per cell: a coverage of 95 % is measured to about +-0.7 %


def _coverage(interval_of, kind: str, n: int, statistic: str, seed: int) -> float:
    """The share of ``_RUNS`` simulated data sets whose interval holds the true ``statistic`` of the differences."""
    draw, mean, median = _DIFFERENCES[kind]
    truth = mean if statistic == "mean" else median
    rng = np.random.default_rng(seed)
    held = 0
    for _ in range(_RUNS):
        low, high = interval_of(draw(rng, n), statistic)
        held += low <= truth <= high
    return held / _RUNS


def _paired(d, statistic):
    found = paired_difference(d + 1.0, np.ones_like(d), statistic=statistic)   # a paired design, b = 1
    return found.low, found.high


def _percentile_bootstrap(d, statistic):
    """The interval the book used before: the percentile bootstrap (scipy's), for the control below."""
    found = stats.bootstrap((d,), np.mean if statistic == "mean" else np.median, n_resamples=2000,
                            method="percentile", random_state=np.random.default_rng(1)).confidence_interval
    return found.low, found.high


@pytest.mark.parametrize("n", [8, 12, 20, 32])
@pytest.mark.parametrize("statistic", ["mean", "median"])
def test_paired_intervals_keep_their_95_percent_at_the_books_sizes(n, statistic):
    # The floors the book needs (scripts/interval_coverage.py prints every cell beside Student's t and the percentile
    # bootstrap): the sign flip is exact for symmetric differences, the sign test for any continuous ones.
    for kind, floor in (("normal", 0.93), ("t3", 0.93), ("skewed", 0.90)):
        coverage = _coverage(_paired, kind, n, statistic, seed=100 + n)
        assert coverage >= floor, f"{statistic}, n = {n}, {kind}: coverage {coverage:.3f} < {floor}"


def test_the_percentile_bootstrap_falls_short_at_eight_cases():
    # The control: the same simulation finds the percentile bootstrap's 95 % interval near 89 % at n = 8, so the
    # test above can tell a method that keeps its promise from one that does not.
    coverage = _coverage(_percentile_bootstrap, "normal", 8, "mean", seed=108)
    assert coverage < 0.93, coverage


@pytest.mark.parametrize("kind", ["normal", "t3", "skewed"])
def test_unpaired_intervals_keep_their_95_percent_at_eight_cases_a_group(kind):
    draw, _, _ = _DIFFERENCES[kind]
    rng = np.random.default_rng(7)
    held = {"mean": 0, "median": 0}
    for _ in range(_RUNS // 2):
        a, b = draw(rng, 8) + 0.3, draw(rng, 8)          # the same distribution, shifted by 0.3
        for statistic in held:
            found = unpaired_difference(a, b, statistic=statistic)
            held[statistic] += found.low <= 0.3 <= found.high
    for statistic, count in held.items():
        assert count / (_RUNS // 2) >= 0.92, f"{statistic}, {kind}: {count / (_RUNS // 2):.3f}"


# ----------------------------------------------------------------------------- known answers, references


def test_sign_flip_ends_are_where_scipys_permutation_test_turns():
    # Exact sign flips for 10 differences: at the lower end the one-sided p-value is just above 2.5 %, just below
    # it at or under 2.5 % (scipy.stats.permutation_test with every sign pattern).
    d = np.random.default_rng(0).normal(0.5, 1.0, 10)
    low, high = sign_flip_interval(d)

    def p_greater(mu):
        return stats.permutation_test((d - mu,), np.mean, permutation_type="samples", alternative="greater",
                                      n_resamples=np.inf).pvalue

    def p_less(mu):
        return stats.permutation_test((d - mu,), np.mean, permutation_type="samples", alternative="less",
                                      n_resamples=np.inf).pvalue

    assert p_greater(low + 1e-9) > 0.025 >= p_greater(low - 1e-9)
    assert p_less(high - 1e-9) > 0.025 >= p_less(high + 1e-9)
    assert low < d.mean() < high


def test_sign_flip_with_random_patterns_agrees_with_student_t_for_many_normal_cases():
    # 400 normal differences: the randomization interval of the mean is close to mean +- t s / sqrt(N).
    rng = np.random.default_rng(0)
    b = rng.normal(0.0, 2.0, 400)
    a = b + rng.normal(0.3, 1.0, 400)
    found = paired_difference(a, b, resamples=8000, seed=1)
    t = stats.ttest_1samp(a - b, 0.0).confidence_interval(0.95)
    half = (t.high - t.low) / 2
    assert found.estimate == pytest.approx((a - b).mean(), abs=1e-12)
    assert found.low == pytest.approx(t.low, abs=0.1 * half) and found.high == pytest.approx(t.high, abs=0.1 * half)
    assert found.n == 400 and found.level == 0.95 and found.verdict("above") == "held"
    assert found.method == "paired sign flip (mean)"


def test_sign_test_interval_is_two_order_statistics():
    # n = 8: P(B <= 0) = 1/256 <= 2.5 % < P(B <= 1) = 9/256, so [d_(1), d_(8)]; n = 12: P(B <= 2) = 79/4096, so
    # [d_(3), d_(10)]; n = 5: even [min, max] covers only 1 - 2/32 = 93.75 %: no finite 95 % interval.
    assert sign_test_interval(np.arange(8.0)) == (0.0, 7.0)
    assert sign_test_interval(np.arange(12.0)[::-1]) == (2.0, 9.0)
    assert sign_test_interval(np.arange(5.0)) == (-math.inf, math.inf)
    found = paired_difference(np.arange(12.0), np.zeros(12), statistic="median")
    assert (found.estimate, found.low, found.high) == (5.5, 2.0, 9.0) and found.method == "paired sign test (median)"


def test_shift_interval_ends_are_where_mann_whitney_turns():
    rng = np.random.default_rng(1)
    a, b = rng.normal(1.0, 1.0, 7), rng.normal(0.0, 1.0, 9)
    low, high = shift_interval(a, b)
    p = lambda delta: stats.mannwhitneyu(a - delta, b, method="exact").pvalue   # two-sided, exact
    assert p(low - 1e-9) <= 0.05 < p(low + 1e-9) and p(high + 1e-9) <= 0.05 < p(high - 1e-9)
    found = unpaired_difference(a, b, statistic="median")
    assert found.estimate == pytest.approx(np.median(a[:, None] - b[None, :]))
    assert (found.low, found.high, found.n) == (low, high, 16)
    assert shift_interval(np.arange(2.0), np.arange(2.0)) == (-math.inf, math.inf)   # 6 orderings: too few
    big = shift_interval(rng.normal(0.5, 1, 150), rng.normal(0, 1, 120))            # the normal approximation
    assert big[0] < 0.5 < big[1]


def test_welch_interval_is_scipys():
    rng = np.random.default_rng(9)
    a, b = rng.normal(1.0, 1.0, 30), rng.normal(0.7, 2.0, 50)
    found = unpaired_difference(a, b)
    theirs = stats.ttest_ind(a, b, equal_var=False).confidence_interval(0.95)
    assert (found.low, found.high) == (pytest.approx(theirs.low), pytest.approx(theirs.high))
    assert found.estimate == pytest.approx(a.mean() - b.mean()) and found.n == 80 and found.method == "Welch t (mean)"
    constant = unpaired_difference(np.ones(4), np.zeros(5))                           # no spread: a point
    assert (constant.low, constant.high) == (1.0, 1.0) and constant.verdict("above") == "held"
    with pytest.raises(ValueError, match="at least 2 cases in each group"):
        unpaired_difference(np.ones(5), np.ones(1))
    with pytest.raises(ValueError, match="statistic"):
        unpaired_difference(np.ones(3), np.ones(3), statistic="mode")


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


def test_median_statistic_is_the_median_of_the_differences():
    a = np.array([1.0, 2.0, 3.0, 4.0, 100.0, 5.0])
    b = np.array([0.0, 0.0, 1.0, 1.0, 1.0, 9.0])
    assert paired_difference(a, b, statistic="median").estimate == np.median(a - b)   # not median(a) - median(b)
    assert paired_difference(a, b).estimate == pytest.approx(np.mean(a - b))
    with pytest.raises(ValueError, match="statistic"):
        paired_difference(a, b, statistic=lambda x, axis: np.mean(x, axis=axis))


def test_constant_differences_give_a_point_and_zero_is_inconclusive():
    a = np.linspace(0, 1, 20)
    same = paired_difference(a, a)
    assert same.low == same.high == same.estimate == 0.0
    assert same.verdict("above") == "inconclusive" and same.verdict("below") == "inconclusive"
    shifted = paired_difference(a + 0.5, a)
    assert shifted.low == pytest.approx(0.5) and shifted.high == pytest.approx(0.5)
    assert shifted.verdict("above") == "held" and shifted.verdict("below") == "not held"


def test_too_few_cases_give_an_infinite_interval_and_no_verdict():
    found = paired_difference(np.arange(5.0) + 10, np.zeros(5))   # five large gains: 1/32 > 2.5 % a side
    assert (found.low, found.high) == (-math.inf, math.inf) and found.verdict("above") == "inconclusive"
    assert paired_difference(np.arange(6.0) + 10, np.zeros(6)).verdict("above") == "held"   # 1/64 < 2.5 %


def test_booleans_torch_and_determinism():
    a = torch.tensor([True, True, False, True, True, False, True, True])
    b = np.array([False, True, False, False, True, False, False, False])
    found = paired_difference(a, b, seed=7)
    assert found.estimate == pytest.approx(6 / 8 - 2 / 8)
    assert found == paired_difference(a.numpy(), b, seed=7)
    x = np.random.default_rng(0).normal(size=30)   # 30 cases: random sign patterns, drawn from the seed
    assert paired_difference(x, 0 * x, seed=7) == paired_difference(x, 0 * x, seed=7)
    assert paired_difference(x, 0 * x, seed=7) != paired_difference(x, 0 * x, seed=8)


@pytest.mark.parametrize("a, b, match", [
    (np.ones(5), np.ones(4), "the same length"),
    (np.ones(1), np.ones(1), "at least 2 test cases"),
    (np.array([1.0, np.nan]), np.ones(2), "finite"),
    (np.ones((2, 3)), np.ones((2, 3)), "1-D"),
    (np.array(["a", "b"]), np.ones(2), "numbers or booleans"),
])
def test_paired_difference_errors(a, b, match):
    with pytest.raises((ValueError, TypeError), match=match):
        paired_difference(a, b)


def test_paired_difference_argument_errors():
    with pytest.raises(ValueError, match="statistic"):
        paired_difference(np.ones(3), np.ones(3), statistic="mode")
    with pytest.raises(ValueError, match="level"):
        paired_difference(np.ones(3), np.ones(3), level=95)
    with pytest.raises(ValueError, match="resamples"):
        paired_difference(np.ones(3), np.ones(3), resamples=10)
    with pytest.raises(ValueError, match="block"):
        paired_difference(np.ones(8), np.ones(8), statistic="median", block=2)


def test_one_sample_interval_of_a_mean_and_a_median():
    rng = np.random.default_rng(6)
    x = rng.normal(1.5, 0.5, 500)
    found = one_sample_interval(x, resamples=8000, seed=2)
    t = stats.ttest_1samp(x, 0.0).confidence_interval(0.95)
    half = (t.high - t.low) / 2
    assert found.low == pytest.approx(t.low, abs=0.1 * half) and found.high == pytest.approx(t.high, abs=0.1 * half)
    assert found.method == "sign flip (mean)" and found.verdict("above", 1.4) == "held"
    paired = paired_difference(x, np.zeros_like(x), resamples=8000, seed=2)   # nothing subtracted: the same
    assert (paired.low, paired.high, paired.estimate) == (found.low, found.high, found.estimate)
    median = one_sample_interval(x, statistic="median")
    assert median.estimate == np.median(x) and median.low < np.median(x) < median.high
    with pytest.raises(ValueError, match="at least 2"):
        one_sample_interval([1.0])


def test_blocks_widen_the_interval_of_a_correlated_series():
    # An AR(1) series with phi = 0.9: the variance of its mean is (1 + phi) / (1 - phi) = 19 times that of as many
    # independent values, so the honest interval is about sqrt(19) = 4.4 times wider than one that flips single
    # values. Blocks of 100 values recover most of it.
    rng = np.random.default_rng(8)
    phi, n = 0.9, 4000
    x = np.zeros(n)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + rng.normal()
    single = one_sample_interval(x, seed=1)
    blocks = one_sample_interval(x, seed=1, block=100)
    ratio = (blocks.high - blocks.low) / (single.high - single.low)
    assert 3.0 < ratio < 5.5, ratio
    assert blocks.estimate == single.estimate and blocks.method == "sign flip in blocks of 100 (mean)"
    y = rng.normal(size=n)   # independent values: blocks change little
    wide = one_sample_interval(y, seed=1, block=50)
    narrow = one_sample_interval(y, seed=1)
    assert 0.8 < (wide.high - wide.low) / (narrow.high - narrow.low) < 1.25
    paired = paired_difference(x + 1.0, x, block=100)   # a constant shift stays exact, in blocks too
    assert paired.low == pytest.approx(1.0) and paired.high == pytest.approx(1.0)
    for bad in (0, n + 1, 2.5, True):
        with pytest.raises(ValueError, match="block"):
            one_sample_interval(x, block=bad)


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
    tie = Interval(0.0, 0.0, 0.0, 0.95, 10, "paired sign flip (mean)")
    straddles = Interval(0.1, -0.2, 0.3, 0.95, 10, "paired sign flip (mean)")
    below = Interval(-0.5, -0.8, -0.1, 0.95, 10, "paired sign flip (mean)")
    assert tie.verdict("above") == "inconclusive" and tie.verdict("above", strict=False) == "held"
    assert straddles.verdict("above", strict=False) == "held"
    assert below.verdict("above", strict=False) == "not held" and below.verdict("below", strict=False) == "held"


def test_verdict_within_a_margin_is_an_equivalence_check():
    inside = Interval(0.01, -0.02, 0.03, 0.95, 20, "test")
    assert inside.verdict_within(0.05) == "held" and inside.verdict_within(0.025) == "inconclusive"
    assert Interval(0.3, 0.2, 0.4, 0.95, 20, "test").verdict_within(0.1) == "not held"
    assert Interval(0.0, -math.inf, math.inf, 0.95, 5, "test").verdict_within(1.0) == "inconclusive"
    assert inside.verdict_within(0.05, centre=1.0) == "not held"
    with pytest.raises(ValueError, match="margin"):
        inside.verdict_within(-1.0)
