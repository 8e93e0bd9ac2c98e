"""Uncertainty for the book's comparisons: intervals that keep their 95 % at a few cases, and one verdict.

Every chapter that asserts a direction ("NIFTY's D2O is lower than Cond. MDM's") or a share ("most samples end
nearer the object") measures it on 8 to a few dozen test cases. Another seed, or another CPU's kernels (which act
like another seed), moves such a number; whether a direction *holds* is therefore read from a 95 % interval, and
the interval must keep that promise at 8 cases, where a bootstrap's percentile interval covers about 88 %
(tests/test_intervals.py simulates it):

* :func:`paired_difference` — two methods scored on the same test cases ``i``: the mean of the differences
  ``a[i] - b[i]`` by the sign-flip interval (:func:`sign_flip_interval`, exact for symmetric differences), their
  median by the sign-test interval (:func:`sign_test_interval`, exact for any continuous differences);
* :func:`one_sample_interval` — the same for one method's scores alone (a median against a threshold);
* :func:`unpaired_difference` — two groups of different cases (multi-seat against single-seat objects): Welch's t
  for the means, the Mann–Whitney interval (:func:`shift_interval`) for a shift;
* :func:`share_interval` — the Wilson score interval (or Clopper–Pearson's exact one) for ``k`` successes in ``n``;
* :func:`correlation_interval` — Fisher's interval for a Pearson correlation ("the offsets grow with the distance");
* :meth:`Interval.verdict` — ``"held"`` when the interval lies wholly on the claimed side of a threshold,
  ``"not held"`` when it lies wholly on the other side, ``"inconclusive"`` when it straddles the threshold.

Intervals that keep their coverage are wider than the percentile bootstrap's at a few cases: with 8 cases the
median's interval runs from the smallest difference to the largest, and below 6 cases no 95 % interval is finite.
The ledger (:mod:`hoi_tutorial.ledger`) takes the verdicts as they are, so a direction whose interval straddles
zero is recorded as *inconclusive*, neither reproduced nor refuted.

Cross-checked in the tests against :func:`scipy.stats.permutation_test` (sign flips), :func:`scipy.stats.ttest_1samp`,
:func:`scipy.stats.mannwhitneyu` and :meth:`scipy.stats.binomtest(...).proportion_ci
<scipy.stats._result_classes.BinomTestResult.proportion_ci>`.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import torch
from scipy import stats

__all__ = ["Interval", "VERDICTS", "paired_difference", "one_sample_interval", "unpaired_difference",
           "share_interval", "correlation_interval", "sign_flip_interval", "sign_test_interval", "shift_interval"]

# What a checked direction can come to, in the ledger's words.
VERDICTS = ("held", "inconclusive", "not held")
_SIDES = ("above", "below")
_STATISTICS = ("mean", "median")


@dataclasses.dataclass(frozen=True)
class Interval:
    """A point estimate and a two-sided interval around it.

    estimate: the statistic on the data as measured. low, high: the interval's ends (``low <= high``).
    level: its confidence level (0.95 for 95 %). n: the test cases (pairs) or trials behind it.
    method: how it was computed (``"paired sign flip (mean)"``, ``"wilson"``, ...).
    """
    estimate: float
    low: float
    high: float
    level: float
    n: int
    method: str

    def side(self, threshold: float = 0.0) -> str:
        """``"above"`` when the whole interval lies above ``threshold``, ``"below"`` when it lies below,
        ``"straddles"`` otherwise (an end that touches the threshold straddles it)."""
        if self.low > threshold:
            return "above"
        if self.high < threshold:
            return "below"
        return "straddles"

    def verdict(self, claimed: str, threshold: float = 0.0, *, strict: bool = True) -> str:
        """Whether a claimed direction held: one of :data:`VERDICTS`.

        claimed: ``"above"`` (the difference or share is claimed to exceed ``threshold``) or ``"below"``.
        strict: ``False`` for a claim that allows a tie ("at least as often"): it is ``"not held"`` only when
            the interval lies wholly on the other side, and ``"held"`` otherwise.
        """
        if claimed not in _SIDES:
            raise ValueError(f"claimed: expected one of {_SIDES}, got {claimed!r}")
        side = self.side(threshold)
        if not strict:
            return "held" if side in ("straddles", claimed) else "not held"
        if side == "straddles":
            return "inconclusive"
        return "held" if side == claimed else "not held"

    def verdict_within(self, margin: float, centre: float = 0.0) -> str:
        """Whether the statistic stays within ``centre ± margin`` ("relatively stable"): an equivalence check.

        ``"held"`` when the whole interval lies within the margin, ``"not held"`` when it lies wholly outside,
        ``"inconclusive"`` otherwise (a wide interval cannot show that a difference is small).
        """
        if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
            raise ValueError(f"margin: expected a finite number >= 0, got {margin!r}")
        if centre - margin <= self.low and self.high <= centre + margin:
            return "held"
        if self.low > centre + margin or self.high < centre - margin:
            return "not held"
        return "inconclusive"

    def holds(self, claimed: str, threshold: float = 0.0) -> bool:
        """True when :meth:`verdict` is ``"held"``: the interval lies wholly on the claimed side."""
        return self.verdict(claimed, threshold) == "held"

    def format(self, scale: float = 1.0, digits: int = 3, unit: str = "") -> str:
        """``"0.12 [0.05, 0.20]"``: the estimate and the interval, each multiplied by ``scale``."""
        unit = f" {unit}" if unit else ""
        e, lo, hi = (f"{scale * v:.{digits}g}" for v in (self.estimate, self.low, self.high))
        return f"{e}{unit} [{lo}, {hi}]"

    def __str__(self) -> str:
        return f"{self.format()} ({100 * self.level:g} % {self.method}, n = {self.n})"


def _as_1d(x, name: str) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    arr = np.asarray(x)
    if arr.dtype == bool:
        arr = arr.astype(np.float64)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name}: expected numbers or booleans, one per test case, got dtype {arr.dtype}")
    arr = arr.astype(np.float64).reshape(-1) if arr.ndim <= 1 else None
    if arr is None:
        raise ValueError(f"{name}: expected a 1-D array with one value per test case, got shape {np.shape(x)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values, one per test case; found NaN or inf (drop or score "
                         "those cases before comparing)")
    return arr


def _check_level(level: float) -> None:
    if not (isinstance(level, (float, int)) and 0.5 <= level < 1.0):
        raise ValueError(f"level: expected a confidence level in [0.5, 1), e.g. 0.95, got {level!r}")


def paired_difference(a, b, *, statistic: str = "mean", level: float = 0.95, resamples: int = 4000, seed: int = 0,
                      block: int = 1) -> Interval:
    """Interval for the paired differences ``d = a - b`` of two methods scored on the same test cases.

    Args:
        a, b: ``(N,)`` one score per test case for two methods (numbers or booleans; bool counts as 0/1, so the
            mean is a share). ``a[i]`` and ``b[i]`` must come from the same case ``i``: the same scene, start or
            clip. ``N >= 2``.
        statistic: ``"mean"``: the mean of ``d``, by the sign-flip interval (:func:`sign_flip_interval`);
            ``"median"``: the median of ``d`` (not the difference of the two medians), by the sign-test interval
            (:func:`sign_test_interval`).
        level: the confidence level. resamples, seed: the random sign patterns of the sign-flip interval when
            there are more than 16 cases (or blocks); with fewer every pattern is used and neither matters.
        block: ``1`` when the cases are independent (scenes, starts, clips). For the frames of one time series,
            whose errors are correlated from frame to frame, the length ``L`` of the runs of consecutive frames
            whose signs flip together: about the time over which the errors stay correlated (the mean only).

    Returns:
        :class:`Interval` whose estimate is the statistic of ``d`` as measured. With too few cases for the level
        (fewer than 6 at 95 %) its ends are infinite and every verdict is *inconclusive*.
    """
    a, b = _as_1d(a, "a"), _as_1d(b, "b")
    if a.shape != b.shape:
        raise ValueError(f"a, b: expected one score per test case for both methods (the same length), got "
                         f"{a.shape[0]} and {b.shape[0]}")
    return _one_sample(a - b, statistic, level, resamples, seed, block, "paired ")


def one_sample_interval(x, *, statistic: str = "mean", level: float = 0.95, resamples: int = 4000, seed: int = 0,
                        block: int = 1) -> Interval:
    """Interval for the mean or median of one method's scores over its test cases.

    For a claim about one method against a fixed threshold ("the guided walks' median speed lies below the data's
    5 % quantile"): the same intervals as :func:`paired_difference` with nothing subtracted. Arguments as there;
    ``x``: ``(N,)``.
    """
    return _one_sample(_as_1d(x, "x"), statistic, level, resamples, seed, block, "")


def _one_sample(d: np.ndarray, statistic, level, resamples, seed, block, kind: str) -> Interval:
    if d.shape[0] < 2:
        raise ValueError(f"expected at least 2 test cases, got {d.shape[0]}")
    _check_resampling(level, resamples)
    name = _check_statistic(statistic)
    if isinstance(block, (bool, np.bool_)) or not isinstance(block, (int, np.integer)) or not 1 <= block <= d.shape[0]:
        raise ValueError(f"block: expected an int from 1 to the number of cases ({d.shape[0]}), got {block!r}")
    if name == "median":
        if block != 1:
            raise ValueError("block: the median's sign-test interval takes independent cases (block = 1); "
                             "use statistic='mean' for the frames of a time series")
        low, high = sign_test_interval(d, level)
        return Interval(float(np.median(d)), low, high, float(level), d.shape[0], f"{kind}sign test (median)")
    low, high = sign_flip_interval(d, level, resamples=resamples, seed=seed, block=int(block))
    method = f"{kind}sign flip (mean)" if block == 1 else f"{kind}sign flip in blocks of {int(block)} (mean)"
    return Interval(float(np.mean(d)), low, high, float(level), d.shape[0], method)


def _check_resampling(level: float, resamples: int) -> None:
    _check_level(level)
    if not isinstance(resamples, int) or isinstance(resamples, bool) or resamples < 100:
        raise ValueError(f"resamples: expected an int of at least 100, got {resamples!r}")


def _check_statistic(statistic) -> str:
    if not isinstance(statistic, str) or statistic not in _STATISTICS:
        raise ValueError(f"statistic: expected one of {_STATISTICS}, got {statistic!r}")
    return statistic


# Up to this many cases (or blocks) every sign pattern is used (2^16 = 65 536); beyond, `resamples` random ones.
_EVERY_PATTERN = 16


@functools.lru_cache(maxsize=_EVERY_PATTERN)
def _every_flip(count: int) -> np.ndarray:
    """``(2**count - 1, count)`` booleans: every pattern of flipped cases except none flipped."""
    codes = np.arange(1, 2 ** count)
    return (codes[:, None] >> np.arange(count)) & 1 == 1


def sign_flip_interval(d, level: float = 0.95, *, resamples: int = 4000, seed: int = 0,
                       block: int = 1) -> tuple[float, float]:
    """The sign-flip (randomization) interval for the centre of ``d``: every ``mu`` the sign-flip test keeps.

    The test of ``mu`` flips the signs of ``d - mu`` at random (a difference is as likely ``+x`` as ``-x`` when
    ``mu`` is the centre of a symmetric distribution) and asks how often the flipped mean is as far out as the
    observed one. Inverting it needs no search: flipping the cases ``S`` moves the mean past the observed one
    exactly when ``mu`` passes the mean of ``d`` over ``S``, so the interval's ends are the ``k``-th smallest and
    largest of those subset means (Hartigan 1969, "Using subsample values as typical values"):

        mu_S = mean(d[S]),   k = floor(alpha M / 2),   interval = [k-th smallest mu_S, k-th largest mu_S]

    with ``M`` the sign patterns tried (all ``2**N`` when ``N <= 16``; else the observed one and ``resamples``
    random ones). Exact under symmetry (the coverage is at least ``level``); for skewed differences it is about
    as good as Student's t (tests/test_intervals.py measures both).

    Args:
        d: ``(N,)`` differences (or one method's scores). level: the confidence level.
        resamples, seed: the random sign patterns when there are more than 16 cases or blocks.
        block: the cases flip in runs of ``block`` consecutive ones (correlated frames of one time series).

    Returns:
        ``(low, high)``; ``(-inf, inf)`` when there are too few patterns for the level (fewer than 6 cases at 95 %).
    """
    d = _as_1d(d, "d")
    sums = np.add.reduceat(d, np.arange(0, d.shape[0], block))              # one sum per block of cases
    sizes = np.add.reduceat(np.ones_like(d), np.arange(0, d.shape[0], block))
    if sums.shape[0] <= _EVERY_PATTERN:
        flipped, none_flipped, patterns = _every_flip(sums.shape[0]), 0, 2 ** sums.shape[0]
    else:  # random patterns; one that flips nothing is the observed one again and counts as at least as far out
        drawn = np.random.default_rng(seed).random((resamples, sums.shape[0])) < 0.5
        keep = drawn.any(axis=1)
        flipped, none_flipped, patterns = drawn[keep], int((~keep).sum()), resamples + 1
    subset_means = np.sort((flipped @ sums) / (flipped @ sizes))           # mu_S = mean(d[S])
    k = math.floor(round((1 - level) * patterns / 2 - 1 - none_flipped, 9)) + 1   # k = floor(alpha M / 2)
    if k < 1:
        return -math.inf, math.inf
    return float(subset_means[k - 1]), float(subset_means[-k])


def sign_test_interval(d, level: float = 0.95) -> tuple[float, float]:
    """The sign-test interval for the median of ``d``: two of its order statistics (Thompson 1936).

    The median ``m`` has each case below it with probability 1/2, so the count below is Binomial(N, 1/2) and
    ``[d_(k), d_(N+1-k)]`` covers ``m`` with probability ``1 - 2 P(B <= k - 1)`` for any continuous distribution:
    ``k`` is the largest with that at least ``level``. Computed by :func:`scipy.stats.quantile_test`.

    Returns:
        ``(low, high)``; ``(-inf, inf)`` when even the smallest and largest case cover less than ``level`` (fewer
        than 6 cases at 95 %).
    """
    d = _as_1d(d, "d")
    found = stats.quantile_test(d, q=0.0, p=0.5).confidence_interval(level)
    low = -math.inf if np.isnan(found.low) else float(found.low)
    high = math.inf if np.isnan(found.high) else float(found.high)
    return low, high


def unpaired_difference(a, b, *, statistic: str = "mean", level: float = 0.95) -> Interval:
    """Interval for a difference between two groups of different cases (two kinds of object).

    Use :func:`paired_difference` whenever the two come from the same cases: pairing removes what the cases share.

    Args:
        a, b: ``(N_a,)`` and ``(N_b,)`` scores, each with at least 2 values.
        statistic: ``"mean"``: ``mean(a) - mean(b)`` by Welch's t interval (Welch 1947; variances not assumed
            equal), computed by :func:`scipy.stats.ttest_ind`; ``"median"``: the shift between the groups by the
            Mann–Whitney (Hodges–Lehmann) interval, which assumes the groups differ by a shift: the estimate is
            the median of all ``a[i] - b[j]`` and the ends are two of them (:func:`shift_interval`).
        level: the confidence level.

    Returns:
        :class:`Interval` with ``n = N_a + N_b``.
    """
    a, b = _as_1d(a, "a"), _as_1d(b, "b")
    if min(a.shape[0], b.shape[0]) < 2:
        raise ValueError(f"a, b: expected at least 2 cases in each group, got {a.shape[0]} and {b.shape[0]}")
    _check_level(level)
    n = a.shape[0] + b.shape[0]
    if _check_statistic(statistic) == "median":
        low, high = shift_interval(a, b, level)
        estimate = float(np.median(a[:, None] - b[None, :]))
        return Interval(estimate, low, high, float(level), n, "Mann–Whitney (shift)")
    estimate = float(a.mean() - b.mean())
    if a.var() == 0 and b.var() == 0:   # no spread in either group: the difference is what it is
        return Interval(estimate, estimate, estimate, float(level), n, "Welch t (mean)")
    found = stats.ttest_ind(a, b, equal_var=False).confidence_interval(level)
    return Interval(estimate, float(found.low), float(found.high), float(level), n, "Welch t (mean)")


def _mann_whitney_counts(m: int, n: int) -> np.ndarray:
    """``(m n + 1,)`` how many of the ``C(m + n, m)`` orderings of two groups give each Mann–Whitney ``U``.

    The coefficients of the Gaussian binomial ``prod_{i=1..m} (1 - q^(n+i)) / (1 - q^i)`` (Mann & Whitney 1947).
    """
    size = m * n + 1
    counts = np.zeros(size)
    counts[0] = 1.0
    for i in range(1, m + 1):
        counts[n + i:] = counts[n + i:] - counts[:size - n - i]                # times (1 - q^(n+i))
        padded = np.zeros(-(-size // i) * i)
        padded[:size] = counts
        counts = padded.reshape(-1, i).cumsum(axis=0).reshape(-1)[:size]    # divided by (1 - q^i)
    return counts


def shift_interval(a, b, level: float = 0.95) -> tuple[float, float]:
    """The Mann–Whitney interval for the shift ``delta`` in ``a ~ b + delta`` (Hodges & Lehmann 1963).

    The ``m n`` differences ``a[i] - b[j]``, sorted, have ``[D_(c+1), D_(mn-c)]`` as the interval, ``c`` the
    largest count with ``P(U <= c - 1) <= (1 - level) / 2`` under no shift: exact for continuous scores up to
    ``m n = 10 000``, the normal approximation of ``U`` beyond.

    Returns:
        ``(low, high)``; ``(-inf, inf)`` when the groups are too small for the level.
    """
    a, b = _as_1d(a, "a"), _as_1d(b, "b")
    m, n = a.shape[0], b.shape[0]
    tail = (1 - level) / 2
    if m * n <= 10_000:
        cdf = np.cumsum(_mann_whitney_counts(min(m, n), max(m, n)))
        cdf /= cdf[-1]
        c = int(np.searchsorted(cdf, tail + 1e-12, side="right"))           # P(U <= c - 1) <= tail
    else:
        z = stats.norm.ppf(1 - tail)
        c = max(0, math.floor(m * n / 2 - z * math.sqrt(m * n * (m + n + 1) / 12)))
    if c < 1:
        return -math.inf, math.inf
    differences = np.sort((a[:, None] - b[None, :]).reshape(-1))
    return float(differences[c - 1]), float(differences[-c])


def share_interval(successes, trials: int | None = None, *, level: float = 0.95,
                   method: str = "wilson") -> Interval:
    """Interval for a share: ``k`` successes in ``n`` trials.

    Args:
        successes: an int count ``k`` (then ``trials`` gives ``n``), or an ``(N,)`` boolean array, one per
            trial (then ``trials`` is ``None``).
        level: the confidence level. method: ``"wilson"`` (the Wilson score interval, good coverage for small
            ``n``) or ``"exact"`` (Clopper–Pearson, conservative).

    Returns:
        :class:`Interval` of the share (0–1), its estimate ``k / n``.
    """
    _check_level(level)
    if method not in ("wilson", "exact"):
        raise ValueError(f"method: expected 'wilson' or 'exact', got {method!r}")
    if isinstance(successes, (bool, np.bool_)):
        raise TypeError("successes: expected a count with trials, or a boolean array (one per trial), got a bool")
    if isinstance(successes, (int, np.integer)):
        if not isinstance(trials, (int, np.integer)) or isinstance(trials, (bool, np.bool_)):
            raise TypeError(f"trials: expected the number of trials (an int) beside a count, got {trials!r}")
        k, n = int(successes), int(trials)
    else:
        if trials is not None:
            raise ValueError("trials: give it only with a count; a boolean array already holds its trials")
        arr = successes.detach().cpu().numpy() if isinstance(successes, torch.Tensor) else np.asarray(successes)
        if arr.dtype != bool:
            raise TypeError(f"successes: expected a boolean array (one per trial) or a count, got dtype {arr.dtype}")
        k, n = int(arr.sum()), int(arr.size)
    if n < 1 or not 0 <= k <= n:
        raise ValueError(f"successes, trials: expected 0 <= k <= n with n >= 1, got k = {k}, n = {n}")
    p = k / n
    if method == "wilson":
        z = stats.norm.ppf(0.5 + level / 2)
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)                              # Wilson (1927)
        half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        low, high = max(0.0, centre - half), min(1.0, centre + half)
    else:
        alpha = 1 - level                                                             # Clopper–Pearson (1934)
        low = 0.0 if k == 0 else float(stats.beta.ppf(alpha / 2, k, n - k + 1))
        high = 1.0 if k == n else float(stats.beta.ppf(1 - alpha / 2, k + 1, n - k))
    return Interval(float(p), float(low), float(high), float(level), n, method)



def correlation_interval(x, y, *, level: float = 0.95) -> Interval:
    """Interval for the Pearson correlation of ``x`` and ``y``, by Fisher's transformation (Fisher 1921).

    x, y: ``(N,)`` paired values, ``N >= 4``, neither constant. The estimate is ``r``; the interval is
    ``tanh(atanh(r) ± z / sqrt(N - 3))``, what :meth:`scipy.stats.pearsonr(...).confidence_interval()
    <scipy.stats._result_classes.PearsonRResult.confidence_interval>` gives. Read "grows with" as
    ``verdict("above", 0)``.
    """
    _check_level(level)
    x, y = _as_1d(x, "x"), _as_1d(y, "y")
    if x.shape != y.shape:
        raise ValueError(f"x, y: expected paired values of the same length, got {x.shape[0]} and {y.shape[0]}")
    n = x.shape[0]
    if n < 4:
        raise ValueError(f"x, y: expected at least 4 pairs for Fisher's interval, got {n}")
    if np.ptp(x) == 0 or np.ptp(y) == 0:
        raise ValueError("x, y: expected values that vary; a constant has no correlation")
    r = float(np.clip(np.corrcoef(x, y)[0, 1], -1.0, 1.0))
    z = stats.norm.ppf(0.5 + level / 2)
    centre, half = np.arctanh(np.clip(r, -1 + 1e-15, 1 - 1e-15)), z / math.sqrt(n - 3)   # atanh(r) ± z/√(N−3)
    return Interval(r, float(np.tanh(centre - half)), float(np.tanh(centre + half)), float(level), n,
                    "Fisher's z (Pearson r)")
