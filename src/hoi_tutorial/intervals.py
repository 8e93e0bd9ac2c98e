"""Uncertainty for the book's comparisons: one paired bootstrap, one interval for a share, one verdict.

Every chapter that asserts a direction ("NIFTY's D2O is lower than Cond. MDM's") or a share ("most samples end
nearer the object") measures it on a few dozen test cases. Another seed, or another CPU's kernels (which act like
another seed), moves such a number; whether a direction *holds* is therefore read from a 95 % interval:

* :func:`paired_difference` — a paired bootstrap interval for ``statistic(a) - statistic(b)`` where ``a[i]`` and
  ``b[i]`` are two methods scored on the same test case ``i`` (resampling the cases, never the methods apart);
* :func:`bootstrap_interval` — the same bootstrap for one method's statistic alone (a median against a threshold);
* :func:`unpaired_difference` — two groups of different cases (multi-seat against single-seat objects), each
  resampled on its own;
* :func:`share_interval` — the Wilson score interval (or Clopper–Pearson's exact one) for ``k`` successes in ``n``;
* :func:`correlation_interval` — Fisher's interval for a Pearson correlation ("the offsets grow with the distance");
* :meth:`Interval.verdict` — ``"held"`` when the interval lies wholly on the claimed side of a threshold,
  ``"not held"`` when it lies wholly on the other side, ``"inconclusive"`` when it straddles the threshold.

The ledger (:mod:`hoi_tutorial.ledger`) takes these verdicts as they are, so a direction whose interval straddles
zero is recorded as *inconclusive*, neither reproduced nor refuted.

Cross-checked in the tests against :func:`scipy.stats.bootstrap` (paired, percentile) and
:meth:`scipy.stats.binomtest(...).proportion_ci <scipy.stats._result_classes.BinomTestResult.proportion_ci>`.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, Union

import numpy as np
import torch
from scipy import stats

__all__ = ["Interval", "VERDICTS", "paired_difference", "bootstrap_interval", "unpaired_difference", "share_interval",
           "correlation_interval"]

# What a checked direction can come to, in the ledger's words.
VERDICTS = ("held", "inconclusive", "not held")
_SIDES = ("above", "below")
_STATISTICS = ("mean", "median")


@dataclasses.dataclass(frozen=True)
class Interval:
    """A point estimate and a two-sided interval around it.

    estimate: the statistic on the data as measured. low, high: the interval's ends (``low <= high``).
    level: its confidence level (0.95 for 95 %). n: the test cases (pairs) or trials behind it.
    method: how it was computed (``"paired bootstrap (mean)"``, ``"wilson"``, ...).
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


def paired_difference(a, b, *, statistic: Union[str, Callable] = "mean", level: float = 0.95,
                      resamples: int = 4000, seed: int = 0, block: int = 1) -> Interval:
    """Paired bootstrap interval for ``statistic(a) - statistic(b)`` over the same test cases.

    Args:
        a, b: ``(N,)`` one score per test case for two methods (numbers or booleans; bool counts as 0/1, so the
            mean is a share). ``a[i]`` and ``b[i]`` must come from the same case ``i``: the same scene, start or
            clip. ``N >= 2``.
        statistic: ``"mean"`` (the mean of the paired differences), ``"median"`` (the difference of the two
            medians), or a function ``f(values) -> (R,)`` reducing the last axis of an ``(R, N)`` array.
        level: the confidence level. resamples: bootstrap resamples ``R``. seed: the resampling's seed (the
            interval is a deterministic function of the data and the seed).
        block: ``1`` when the cases are independent (scenes, starts, clips). For the frames of one time series,
            whose errors are correlated from frame to frame, the length ``L`` of the blocks of consecutive
            cases that are resampled together (the moving-block bootstrap, Künsch 1989): about the time over
            which the errors stay correlated. Resampling single frames there would make the interval too narrow.

    Returns:
        :class:`Interval` with the estimate on the data as measured and the percentile interval of the
        ``R`` resampled differences (each resample draws ``N`` case indices with replacement, shared by
        ``a`` and ``b``; in blocks of ``L`` consecutive cases when ``block = L``).

    With fewer than about ten cases the percentile interval is too narrow (it cannot see past the few values it
    has): read its verdict with the count beside it.
    """
    return _bootstrap(a, b, statistic, level, resamples, seed, "paired bootstrap", block)


def bootstrap_interval(x, *, statistic: Union[str, Callable] = "mean", level: float = 0.95, resamples: int = 4000,
                       seed: int = 0, block: int = 1) -> Interval:
    """Bootstrap interval for ``statistic(x)`` of one method's scores over its test cases.

    The same percentile bootstrap as :func:`paired_difference`, with nothing subtracted: for a claim about one
    method against a fixed threshold ("the guided walks' median speed lies below the data's 5 % quantile").
    Arguments as there; ``x``: ``(N,)``.
    """
    return _bootstrap(x, None, statistic, level, resamples, seed, "bootstrap", block)


def unpaired_difference(a, b, *, statistic: Union[str, Callable] = "mean", level: float = 0.95,
                        resamples: int = 4000, seed: int = 0) -> Interval:
    """Two-sample bootstrap interval for ``statistic(a) - statistic(b)`` when ``a`` and ``b`` are different cases.

    Use :func:`paired_difference` whenever the two come from the same cases: pairing removes what the cases share.
    Here each group is resampled on its own (``N_a`` and ``N_b`` indices with replacement), for groups that share
    no case, such as two kinds of object. Arguments as :func:`paired_difference`; ``a``: ``(N_a,)``, ``b``:
    ``(N_b,)``, each with at least 2 values. The interval's ``n`` is ``N_a + N_b``.
    """
    a, b = _as_1d(a, "a"), _as_1d(b, "b")
    if min(a.shape[0], b.shape[0]) < 2:
        raise ValueError(f"a, b: expected at least 2 cases in each group, got {a.shape[0]} and {b.shape[0]}")
    _check_resampling(level, resamples)
    reduce, name = _reducer(statistic)
    rng = np.random.default_rng(seed)
    index_a = rng.integers(0, a.shape[0], size=(resamples, a.shape[0]))
    index_b = rng.integers(0, b.shape[0], size=(resamples, b.shape[0]))
    resampled = _reduced(reduce, a[index_a]) - _reduced(reduce, b[index_b])   # each group on its own
    estimate = float((_reduced(reduce, a[None]) - _reduced(reduce, b[None]))[0])
    return _percentile_interval(estimate, resampled, level, a.shape[0] + b.shape[0], f"unpaired bootstrap ({name})")


def _check_resampling(level: float, resamples: int) -> None:
    _check_level(level)
    if not isinstance(resamples, int) or resamples < 100:
        raise ValueError(f"resamples: expected an int of at least 100, got {resamples!r}")


def _reduced(reduce, x: np.ndarray) -> np.ndarray:
    """``reduce`` over the last axis of an ``(R, N)`` array, checked to give ``(R,)`` float64."""
    found = np.asarray(reduce(x, axis=-1), dtype=np.float64)
    if found.shape != x.shape[:1]:
        raise ValueError(f"statistic: expected it to reduce the last axis of an (R, N) array to (R,), got "
                         f"{x.shape} -> {found.shape}")
    return found


def _percentile_interval(estimate: float, resampled: np.ndarray, level: float, n: int, method: str) -> Interval:
    """The percentile interval of the resampled statistics around ``estimate``."""
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(resampled, [tail, 100 - tail])
    return Interval(float(estimate), float(low), float(high), float(level), int(n), method)


def _reducer(statistic) -> tuple:
    """``(function reducing an axis, its name)`` for a statistic given by name or as a function."""
    if isinstance(statistic, str):
        if statistic not in _STATISTICS:
            raise ValueError(f"statistic: expected one of {_STATISTICS} or a function, got {statistic!r}")
        return (np.mean if statistic == "mean" else np.median), statistic
    if callable(statistic):
        return statistic, getattr(statistic, "__name__", "statistic")
    raise TypeError(f"statistic: expected one of {_STATISTICS} or a function, got {type(statistic).__name__}")


def _resampled_indices(n: int, resamples: int, block: int, rng: np.random.Generator) -> np.ndarray:
    """``(resamples, n)`` case indices: drawn one by one, or as blocks of ``block`` consecutive cases whose starts
    are drawn uniformly from ``0 .. n - block`` (the moving-block bootstrap), cut to ``n``."""
    if block == 1:
        return rng.integers(0, n, size=(resamples, n))
    starts = rng.integers(0, n - block + 1, size=(resamples, -(-n // block)))
    return (starts[..., None] + np.arange(block)).reshape(resamples, -1)[:, :n]


def _bootstrap(a, b, statistic, level, resamples, seed, kind, block=1) -> Interval:
    a = _as_1d(a, "a")
    b = np.zeros_like(a) if b is None else _as_1d(b, "b")   # one sample: subtract nothing
    if a.shape != b.shape:
        raise ValueError(f"a, b: expected one score per test case for both methods (the same length), got "
                         f"{a.shape[0]} and {b.shape[0]}")
    if a.shape[0] < 2:
        raise ValueError(f"expected at least 2 test cases, got {a.shape[0]}")
    _check_resampling(level, resamples)
    if isinstance(block, (bool, np.bool_)) or not isinstance(block, (int, np.integer)) or not 1 <= block <= a.shape[0]:
        raise ValueError(f"block: expected an int from 1 to the number of cases ({a.shape[0]}), got {block!r}")
    reduce, name = _reducer(statistic)
    estimate = float((_reduced(reduce, a[None]) - _reduced(reduce, b[None]))[0])
    index = _resampled_indices(a.shape[0], resamples, int(block), np.random.default_rng(seed))
    resampled = _reduced(reduce, a[index]) - _reduced(reduce, b[index])   # the cases resampled together: pairs stay
    kind = kind if block == 1 else f"{kind} in blocks of {int(block)}"
    return _percentile_interval(estimate, resampled, level, a.shape[0], f"{kind} ({name})")


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
