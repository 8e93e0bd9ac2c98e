"""Can a classifier tell two sets apart? The classifier two-sample test, a stand-in for asking people.

NIFTY asked people which of two motions looks more realistic (Fig. 5) and how realistic one motion looks (A.1).
The book has no people to ask. It asks a small classifier instead (Lopez-Paz & Oquab 2017, "Revisiting classifier
two-sample tests"): train it to tell set ``a`` from set ``b`` on half of each, and count how often it is right on
the other half.

    accuracy = (1 / n) * sum_i 1[f(z_i) = l_i]     over the n held-out items z_i with their set labels l_i

When the two sets come from one distribution, no classifier beats a coin on items it has not seen: with as many
held-out items of each set, the count of correct answers is Binomial(n, 1/2) and the accuracy's Wilson interval
(:func:`~hoi_tutorial.intervals.share_interval`) says whether it lies above 1/2. An accuracy near 1/2 means *this*
classifier, with these features and this much data, cannot tell the sets apart; it does not mean people could not.
The classifier is L2-regularised logistic regression on standardised features (scikit-learn's), a choice of ours.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .intervals import Interval, share_interval

__all__ = ["TwoSampleResult", "classifier_two_sample_test", "half_split"]


@dataclasses.dataclass(frozen=True)
class TwoSampleResult:
    """What :func:`classifier_two_sample_test` found.

    accuracy: the held-out accuracy (0-1) with its 95 % Wilson interval; n is the held-out items of both sets.
    correct_a, correct_b: ``(n / 2,)`` booleans, whether each held-out item of ``a`` (of ``b``) was classified right,
        in the order of their indices; two tests that share held-out items can be compared item by item.
    """
    accuracy: Interval
    correct_a: np.ndarray
    correct_b: np.ndarray

    def verdict(self) -> str:
        """``"held"`` when the classifier tells the sets apart (the interval lies above 1/2), ``"inconclusive"``
        when the interval holds 1/2, ``"not held"`` when it lies below (worse than a coin: a sign of a bug)."""
        return self.accuracy.verdict("above", 0.5)


def half_split(n: int, seed: int, groups=None) -> np.ndarray:
    """``(n,)`` booleans, True for the items a classifier trains on: half of the items, chosen at random (``seed``),
    half of each group when ``groups`` (``(n,)`` labels such as the action) is given; an odd group's extra item
    is held out."""
    if not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n: expected at least 2 items, got {n!r}")
    groups = np.zeros(n, dtype=int) if groups is None else np.asarray(groups)
    if groups.shape != (n,):
        raise ValueError(f"groups: expected one label per item, shape ({n},), got {groups.shape}")
    rng = np.random.default_rng(seed)
    train = np.zeros(n, dtype=bool)
    for group in np.unique(groups):
        members = np.flatnonzero(groups == group)
        train[rng.permutation(members)[:len(members) // 2]] = True
    return train


def classifier_two_sample_test(a, b, train_a, train_b, *, regularization: float = 10.0) -> TwoSampleResult:
    """Train a classifier to tell ``a`` from ``b`` on the items marked for training; score it on the others.

    Args:
        a, b: ``(N_a, D)`` and ``(N_b, D)`` features, one row per item (a motion).
        train_a, train_b: ``(N_a,)`` and ``(N_b,)`` booleans, True for the items it trains on (:func:`half_split`).
            The held-out items of ``a`` and ``b`` must be as many (so that a coin scores 1/2 whatever it guesses),
            and each set needs at least one training item.
        regularization: the L2 penalty's strength (scikit-learn's ``C = 1 / regularization``), > 0.

    Returns:
        :class:`TwoSampleResult`. Deterministic for given inputs.
    """
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    a, b = _features(a, "a"), _features(b, "b")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"a, b: expected the same features per item, got {a.shape[1]} and {b.shape[1]}")
    train_a, train_b = _mask(train_a, len(a), "train_a"), _mask(train_b, len(b), "train_b")
    if (~train_a).sum() != (~train_b).sum() or not (~train_a).any():
        raise ValueError(f"train_a, train_b: expected as many held-out items of a as of b, at least one, got "
                         f"{int((~train_a).sum())} and {int((~train_b).sum())}")
    if not train_a.any() or not train_b.any():
        raise ValueError("train_a, train_b: expected at least one training item of each set")
    if not (isinstance(regularization, (int, float)) and np.isfinite(regularization) and regularization > 0):
        raise ValueError(f"regularization: expected a finite number > 0, got {regularization!r}")
    classifier = make_pipeline(StandardScaler(), LogisticRegression(C=1.0 / regularization, max_iter=5000))
    classifier.fit(np.concatenate([a[train_a], b[train_b]]),
                   np.concatenate([np.zeros(train_a.sum()), np.ones(train_b.sum())]))
    correct_a = classifier.predict(a[~train_a]) == 0          # 1[f(z_i) = l_i], set a labelled 0
    correct_b = classifier.predict(b[~train_b]) == 1
    return TwoSampleResult(share_interval(np.concatenate([correct_a, correct_b])), correct_a, correct_b)


def _features(x, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or len(x) < 2:
        raise ValueError(f"{name}: expected (N, D) features with N >= 2, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: expected finite features, found NaN or inf")
    return x


def _mask(mask, n: int, name: str) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.dtype != bool or mask.shape != (n,):
        raise ValueError(f"{name}: expected ({n},) booleans (True: trains on it), got {mask.dtype} {mask.shape}")
    return mask
