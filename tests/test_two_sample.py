"""The classifier two-sample test (hoi_tutorial.two_sample) and the motion features it reads (nifty.realism)."""
import numpy as np
import pytest

from hoi_tutorial.nifty.realism import motion_features
from hoi_tutorial.two_sample import classifier_two_sample_test, half_split
from hoi_tutorial.world import mocap


def test_one_distribution_is_told_apart_about_as_often_as_the_level_allows():
    # Under the null hypothesis the held-out count is Binomial(n, 1/2): the verdict "told apart" (interval above
    # 1/2) should come up in about 2.5 % of data sets, never far more.
    rng = np.random.default_rng(0)
    told_apart = 0
    for run in range(120):
        a, b = rng.normal(size=(32, 20)), rng.normal(size=(32, 20))
        found = classifier_two_sample_test(a, b, half_split(32, run), half_split(32, run + 1000))
        told_apart += found.verdict() == "held"
    assert told_apart / 120 <= 0.06, told_apart


def test_a_shift_is_told_apart_and_correct_items_line_up_with_the_held_out_indices():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(40, 10)), rng.normal(size=(40, 10)) + np.r_[1.5, np.zeros(9)]
    train = half_split(40, 0)
    found = classifier_two_sample_test(a, b, train, train)
    assert found.verdict() == "held" and found.accuracy.n == 40 and found.correct_a.shape == (20,)
    assert found.accuracy.estimate == pytest.approx(np.mean(np.r_[found.correct_a, found.correct_b]))
    swapped = classifier_two_sample_test(b, a, train, train)            # the same test with the labels swapped
    np.testing.assert_array_equal(swapped.correct_a, found.correct_b)


def test_half_split_halves_each_group():
    groups = np.array([0] * 10 + [1] * 7)
    train = half_split(17, 3, groups)
    assert train[:10].sum() == 5 and train[10:].sum() == 3                 # the odd group's extra item held out
    assert np.array_equal(train, half_split(17, 3, groups)) and not np.array_equal(train, half_split(17, 4, groups))
    with pytest.raises(ValueError, match="groups"):
        half_split(5, 0, [0, 1])


@pytest.mark.parametrize("kwargs, match", [
    ({"train_b": np.r_[np.ones(5, bool), np.zeros(5, bool)][::-1].copy()[:9]}, "train_b"),
    ({"train_a": np.r_[np.ones(4, bool), np.zeros(6, bool)]}, "as many held-out"),
    ({"regularization": 0.0}, "regularization"),
    ({"a": np.full((10, 3), np.nan)}, "finite"),
    ({"b": np.zeros((10, 4))}, "same features"),
])
def test_classifier_two_sample_test_errors(kwargs, match):
    rng = np.random.default_rng(2)
    args = {"a": rng.normal(size=(10, 3)), "b": rng.normal(size=(10, 3)), "train_a": half_split(10, 0),
            "train_b": half_split(10, 1)}
    args.update(kwargs)
    regularization = args.pop("regularization", 10.0)
    with pytest.raises(ValueError, match=match):
        classifier_two_sample_test(args["a"], args["b"], args["train_a"], args["train_b"],
                                   regularization=regularization)


def test_motion_features_ignore_where_the_motion_happens_and_pad_with_stillness():
    clip = mocap.generate_clip("walk", seed=0)
    found = motion_features([clip], frames=len(clip) + 20, stride=1)
    assert found.shape == (1, (len(clip) + 20) * 66)
    per_frame = found.reshape(len(clip) + 20, 66)
    np.testing.assert_allclose(per_frame[len(clip):, -2:], 0.0)           # the padding stands still
    np.testing.assert_allclose(per_frame[len(clip):, :-2], np.repeat(per_frame[len(clip) - 1:len(clip), :-2], 20, 0))
    assert np.abs(per_frame[: len(clip) - 1, -2:]).max() > 0.3             # a walk moves
    moved = motion_features([clip.transformed(yaw=1.1, translation=(2.0, -3.0, 0.0))], frames=len(clip) + 20, stride=1)
    np.testing.assert_allclose(moved, found, atol=1e-4)                    # canonical frame: where, facing where
    last = motion_features([clip], frames=40, stride=4)                    # the last 40 frames, every 4th
    assert last.shape == (1, 10 * 66)
    with pytest.raises(ValueError, match="stride"):
        motion_features([clip], frames=40, stride=0)
    with pytest.raises(TypeError, match="Motion"):
        motion_features([clip, "walk"], frames=40)
