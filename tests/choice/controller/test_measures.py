"""CHOICE Table 4's motion measures and Table 2's label distribution (``choice.controller.measures``), and the
transcribed paper numbers they are set beside."""
import dataclasses

import numpy as np
import pytest
import torch

from hoi_tutorial.choice import paper_numbers
from hoi_tutorial.choice.controller import measures
from hoi_tutorial.world import mocap
from hoi_tutorial.world.motion import ACTIONS


@pytest.fixture(scope="module")
def clips():
    return ([mocap.generate_clip("walk", seed=s) for s in range(3)]
            + [mocap.generate_clip("reach_grasp", seed=s) for s in range(3)])


def test_window_features_ignore_where_the_clip_stands_and_faces(clips):
    walk = clips[0]
    moved = walk.transformed(yaw=1.1, translation=(2.0, -1.5, 0.0))
    a, b = measures.pose_window_features(walk), measures.pose_window_features(moved)
    assert a.shape == b.shape and a.shape[1] == 66 * 7
    np.testing.assert_allclose(a, b, atol=1e-4)
    with pytest.raises(ValueError, match="sample_every: expected a divisor"):
        measures.pose_window_features(walk, sample_every=7)


def test_detected_foot_contacts_agree_with_the_mocap_labels(clips):
    for walk in clips[:3]:
        detected = measures.foot_contacts(walk)
        labelled = np.asarray(walk.contacts)[:, 1:3] > 0.5  # left_foot, right_foot
        assert np.mean(detected == labelled) > 0.95  # measured: 0.979-0.986


def test_a_wobble_raises_unsmoothness_sliding_and_the_distance_to_the_data(clips):
    walk = clips[1]
    data = np.concatenate([measures.pose_window_features(c) for c in clips[:3]])
    t = torch.arange(len(walk.root_position), dtype=walk.root_position.dtype) / walk.fps
    # the whole body shaken sideways at 3 Hz: feet slide while planted, every joint accelerates
    shaken = dataclasses.replace(walk, root_position=walk.root_position + 0.03 * torch.stack(
        [torch.sin(2 * np.pi * 3 * t), torch.zeros_like(t), torch.zeros_like(t)], -1))
    clean = measures.motion_measures(walk, data)
    wobbly = measures.motion_measures(shaken, data)
    assert wobbly["Unsmth."] > clean["Unsmth."] and wobbly["Slid."] > clean["Slid."]
    assert wobbly["FD"] > clean["FD"]


def test_wrist_curvature_is_read_on_the_given_segments(clips):
    reach = clips[3]
    hand = reach.meta["hand"]
    segment = (int(reach.meta["interaction_start"]), int(reach.meta["anchor_frame"]) + 1)
    out = measures.motion_measures(reach, wrist_segments=[segment], hand=hand)
    assert np.isnan(out["FD"]) and out["EE RMSC"] > 0
    with pytest.raises(ValueError, match="wrist_segments"):
        measures.motion_measures(reach, wrist_segments=[(5, 6)])
    with pytest.raises(ValueError, match="hand: expected"):
        measures.motion_measures(reach, hand="middle")


def test_label_distribution_counts_seconds_per_key_joint_task(clips):
    rows = measures.label_distribution(clips)
    assert [(r[0], r[1]) for r in rows] == [(r[0], r[1]) for r in paper_numbers.TABLE2]
    total = sum(len(c.actions) for c in clips) / 30.0
    hip = [r for r, spec in zip(rows, measures.KEY_JOINT_TASKS) if spec[0] == "hip"]
    assert sum(r[2] for r in hip) == pytest.approx(total) and sum(r[3] for r in hip) == pytest.approx(100.0)
    walking = sum(int(np.sum(np.isin(np.asarray(c.actions), [ACTIONS.index("walk"), ACTIONS.index("run"),
                                                                  ACTIONS.index("side_step")]))) for c in clips) / 30.0
    assert hip[1][2] == pytest.approx(walking)
    grasp = rows[0]
    assert 0 < grasp[2] < total  # the reaches' reach, grasp and lift frames
    with pytest.raises(ValueError, match="motions: expected"):
        measures.label_distribution([])


def test_transcribed_tables_have_the_printed_shape():
    assert list(paper_numbers.TABLE4) == ["w/ KF + cuRobo", "w/o goal phase", "w/ matched goal", "w/ predicted goal",
                                          "w/ KF goal", "Dataset"]
    assert paper_numbers.TABLE4["w/ KF goal"]["FD"] == 670 and paper_numbers.TABLE4["Dataset"]["FD"] == "-"
    assert sum(r[3] for r in paper_numbers.TABLE2 if r[0] in ("Idle", "Walk")) == pytest.approx(100.0)
