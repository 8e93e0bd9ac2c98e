"""NIFTY's evaluation protocol (§4.2, Appendix C.2): test scenes, per-motion metrics, Table 1 rows."""
import copy
import dataclasses
import math

import numpy as np
import pytest
import torch

from hoi_tutorial.infra import clear_cache
from hoi_tutorial.nifty import evaluation, scoring, paper_numbers
from hoi_tutorial.nifty.anchors import Anchor
from hoi_tutorial.nifty.data import SyntheticDataset, synthetic_data_config
from hoi_tutorial.nifty.motion_model import final_pelvis_distance, motion_model_config
from hoi_tutorial.nifty.motion_prior import PoseTrack
from hoi_tutorial.nifty.rollout import InteractionSequence
from hoi_tutorial.world.body import body_from_motion
from hoi_tutorial.world.mocap import generate_clip
from hoi_tutorial.world.motion import Motion
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.rotations import axis_angle_to_matrix
from hoi_tutorial.world.skeleton import JOINT_NAMES, NUM_JOINTS

FRAMES = 61


def _anchor_of(clip, frame, obj, subject=0):
    pose = PoseTrack(clip.local_rotations[frame], clip.root_position[frame], clip.joints[frame])
    nxt = PoseTrack(clip.local_rotations[frame + 1], clip.root_position[frame + 1], clip.joints[frame + 1])
    return Anchor("sit", pose, nxt, clip.betas, subject, obj, clip)


@pytest.fixture(scope="module")
def sit_case():
    """Two sit clips cut to end at their settle frame, their chairs and their anchors."""
    records, anchors = [], []
    for seed, (x, y, yaw) in enumerate([(0.5, -1.0, 0.3), (-1.0, 2.0, 2.0)]):
        obj = make_object("chair", seed=seed).placed(x, y, yaw)
        clip = generate_clip("sit", seed=seed, obj=obj)
        a = int(clip.meta["anchor_frame"])
        anchor = _anchor_of(clip, a, obj, subject=seed)
        records.append(InteractionSequence(clip.slice(a - FRAMES + 1, a + 1), obj, anchor))
        anchors.append(anchor)
    return records, anchors


# --------------------------------------------------------------------------- test scenes


def test_scenes_cycle_anchors_and_respect_the_distance_range(sit_case, tmp_cache):
    _, anchors = sit_case
    scenes = scoring.test_scenes(anchors, 5, (1.0, 1.5), seed=3)
    assert [s.anchor for s in scenes] == [0, 1, 0, 1, 0]
    for scene in scenes:
        # A held-out instance: the anchor's category and placement, sizes of its own.
        source = anchors[scene.anchor].obj
        assert scene.obj is not source and scene.obj.category == source.category
        np.testing.assert_array_equal(scene.obj.pose, source.pose)
        assert scene.obj.params != source.params
        assert len(scene.start) == 2
        torch.testing.assert_close(scene.start.betas, anchors[scene.anchor].betas)
        assert 1.0 <= scene.distance <= 1.5
        # The recorded distance is the start pelvis's ground-plane distance to the object's centre.
        _, first = final_pelvis_distance(scene.start, scene.obj)
        assert first == pytest.approx(scene.distance, abs=1e-6)
        assert scene.start.joints[0, :, 2].min() > -0.05  # standing on the ground, not under it
        vertices = body_from_motion(scene.start, frames=[0])[0].double().numpy()
        assert scene.obj.sdf(vertices).min() > 0.05  # clear of the object


def test_scenes_can_use_the_anchors_own_objects(sit_case):
    _, anchors = sit_case
    scenes = scoring.test_scenes(anchors, 3, (1.0, 1.5), seed=3, held_out=False)
    assert all(scene.obj is anchors[scene.anchor].obj for scene in scenes)


def test_scenes_are_deterministic_for_a_seed(sit_case, tmp_cache):
    _, anchors = sit_case
    a = scoring.test_scenes(anchors, 3, (1.0, 2.0), seed=7)
    scoring._SCENES_MADE.clear()  # made again, neither handed out from the scenes made before nor loaded
    clear_cache("nifty_test_scenes")
    b = scoring.test_scenes(anchors, 3, (1.0, 2.0), seed=7)
    c = scoring.test_scenes(anchors, 3, (1.0, 2.0), seed=8)
    for x, y in zip(a, b):
        torch.testing.assert_close(x.start.joints, y.start.joints, rtol=0, atol=0)
    assert not torch.equal(a[0].start.joints, c[0].start.joints)


def test_scenes_made_before_from_the_same_anchors_are_handed_out_as_copies(sit_case, tmp_cache):
    _, anchors = sit_case
    scoring._SCENES_MADE.clear()
    first = scoring.test_scenes(anchors, 3, (1.0, 2.0), seed=5)
    same = [dataclasses.replace(a, obj=copy.deepcopy(a.obj), betas=a.betas.clone()) for a in anchors]  # equal, not the same
    again = scoring.test_scenes(same, 3, (1.0, 2.0), seed=5)
    scoring._SCENES_MADE.clear()
    fresh = scoring.test_scenes(anchors, 3, (1.0, 2.0), seed=5)
    for x, y, z in zip(first, again, fresh):
        assert y.obj is not x.obj and y.start is not x.start  # a copy: a caller changing it changes no other's
        for scene in (y, z):
            torch.testing.assert_close(scene.start.joints, x.start.joints, rtol=0, atol=0)
            assert scene.obj.params == x.obj.params and scene.distance == x.distance and scene.anchor == x.anchor
    moved = [dataclasses.replace(anchors[0], obj=anchors[0].obj.placed(0.5, 0.0, 0.0)), *anchors[1:]]
    elsewhere = scoring.test_scenes(moved, 3, (1.0, 2.0), seed=5)
    assert not np.array_equal(elsewhere[0].obj.pose, first[0].obj.pose)  # another placement: other scenes
    assert scoring.test_scenes(anchors, 3, (1.0, 2.0), seed=6)[0].distance != first[0].distance


def _same_scenes(xs, ys, assert_same_motion):
    points = np.random.default_rng(0).uniform(-1.0, 1.0, (64, 3))
    assert len(xs) == len(ys)
    for x, y in zip(xs, ys):
        assert (x.anchor, x.distance, x.obj.category, x.obj.params) == (y.anchor, y.distance, y.obj.category, y.obj.params)
        np.testing.assert_array_equal(x.obj.pose, y.obj.pose)
        np.testing.assert_array_equal(x.obj.sdf(points), y.obj.sdf(points))
        assert_same_motion(x.start, y.start)


def test_held_out_scenes_come_back_from_the_cache_as_made(sit_case, tmp_cache, capsys, assert_same_motion):
    _, anchors = sit_case
    made = scoring._make_scenes(anchors, 4, 1.0, 2.0, 9, ("idle", "walk"), True)
    scoring._SCENES_MADE.clear()
    built = scoring.test_scenes(anchors, 4, (1.0, 2.0), seed=9)
    scoring._SCENES_MADE.clear()
    capsys.readouterr()
    loaded = scoring.test_scenes(anchors, 4, (1.0, 2.0), seed=9)
    assert "[cache] loaded nifty_test_scenes" in capsys.readouterr().out
    _same_scenes(made, built, assert_same_motion)
    _same_scenes(made, loaded, assert_same_motion)


def test_scenes_reject_bad_input(sit_case):
    _, anchors = sit_case
    with pytest.raises(ValueError, match="distance_range"):
        scoring.test_scenes(anchors, 2, (1.5, 1.0))
    with pytest.raises(ValueError, match="n_scenes"):
        scoring.test_scenes(anchors, 0, (1.0, 1.5))
    with pytest.raises(ValueError, match="anchors"):
        scoring.test_scenes([], 2, (1.0, 1.5))
    with pytest.raises(ValueError, match="kinds"):
        scoring.test_scenes(anchors, 2, (1.0, 1.5), kinds=("dance",))


# --------------------------------------------------------------------------- per-motion metrics


def test_a_motion_ending_in_its_anchor_scores_like_the_data(sit_case):
    records, anchors = sit_case
    scores = scoring.evaluate_motions([r.motion for r in records], [r.obj for r in records], anchors,
                                         n_approach=30, n_object_points=500)
    np.testing.assert_allclose(scores.skeleton_distance, 0.0, atol=1e-9)
    assert scores.nearest_anchor.tolist() == [0, 1]
    np.testing.assert_allclose(scores.contact_iou, 1.0)
    assert (scores.d2o <= 0.02).all()  # seated: the body touches the seat
    assert np.isfinite(scores.penetration).all()  # reached, so the approach is scored
    assert (scores.final_distance < scores.start_distance).all()
    assert (scores.foot_skating >= 0).all()


def test_a_pose_shifted_one_metre_is_22_metres_of_skeleton_distance(sit_case):
    records, anchors = sit_case
    record = records[0]
    away = record.motion.transformed(0.0, torch.tensor([1.0, 0.0, 0.0], dtype=record.motion.root_position.dtype))
    scores = scoring.evaluate_motions([away], [record.obj], anchors[:1], n_approach=30, n_object_points=500)
    # Every joint is exactly 1 m from the anchor's: the sum over the 22 joints is 22 m.
    assert scores.skeleton_distance[0] == pytest.approx(NUM_JOINTS * 1.0, abs=1e-4)
    assert scores.d2o[0] > 0.3
    assert math.isnan(scores.penetration[0])  # not reaching: Table 1 does not score its approach


def test_pose_only_distance_ignores_where_the_body_stands_and_sees_a_moved_joint(sit_case):
    records, anchors = sit_case
    record = records[0]
    dtype = record.motion.root_position.dtype
    # The anchor's own pose, carried (turned 2 rad and moved 3 m) anywhere in the room, away from its chair.
    elsewhere = record.motion.transformed(2.0, torch.tensor([3.0, -2.0, 0.0], dtype=dtype))
    # The same pose with the right elbow bent a further 0.8 rad at the last frame.
    rotations = record.motion.local_rotations.clone()
    elbow = JOINT_NAMES.index("right_elbow")
    rotations[-1, elbow] = rotations[-1, elbow] @ axis_angle_to_matrix(torch.tensor([0.0, 0.0, 0.8], dtype=dtype))
    bent = Motion(rotations, record.motion.root_position, record.motion.betas)
    scores = scoring.evaluate_motions([record.motion, elsewhere, bent], [record.obj] * 3, anchors[:1], n_approach=30,
                                      n_object_points=500)
    np.testing.assert_allclose(scores.pose_distance[:2], 0.0, atol=1e-4)  # float32 joints
    assert scores.skeleton_distance[1] > 10.0  # the object-frame distance sees where it stands
    # The elbow moves the forearm and hand: the pose-only distance grows by their displacement, about 2 x 0.2 m.
    assert 0.1 < scores.pose_distance[2] < 1.0
    assert scores.pose_distance[2] == pytest.approx(scores.skeleton_distance[2], abs=1e-6)


def test_pose_threshold_is_a_quantile_of_the_training_scores_and_pose_row_counts_under_it():
    training = _scores([0.1] * 5, [1.0] * 5, [0.0] * 5, pose=[0.5, 0.8, 1.0, 1.3, 2.0])
    assert scoring.pose_threshold(training) == pytest.approx(1.0)
    assert scoring.pose_threshold(training, quantile=0.25) == pytest.approx(0.8)
    row = scoring.pose_row(_scores([0.1] * 4, [1.0] * 4, [0.0] * 4, pose=[0.4, 1.0, 1.01, 3.0]), 1.0)
    assert row == {"Pose Dist. ↓": pytest.approx(1.3525), "% Pose Dist. ≤ 100cm ↑": 50.0, "count": "2 / 4"}
    with pytest.raises(ValueError, match="quantile"):
        scoring.pose_threshold(training, quantile=1.0)
    with pytest.raises(TypeError, match="MotionScores"):
        scoring.pose_row({"pose_distance": [1.0]}, 1.0)


def test_evaluate_motions_rejects_bad_input(sit_case):
    records, anchors = sit_case
    with pytest.raises(ValueError, match="motions, objects"):
        scoring.evaluate_motions([records[0].motion], [], anchors, n_approach=10)
    with pytest.raises(ValueError, match="n_approach"):
        scoring.evaluate_motions([records[0].motion], [records[0].obj], anchors, n_approach=0)
    with pytest.raises(ValueError, match="anchors"):
        scoring.evaluate_motions([records[0].motion], [records[0].obj], [], n_approach=10)


def test_approach_length_of_motions_that_never_touch_is_the_whole_motion(sit_case):
    records, _ = sit_case
    far = [r.motion.slice(0, 20).transformed(0.0, torch.tensor([5.0, 5.0, 0.0], dtype=torch.float64))
           for r in records]
    assert scoring.approach_length(far, [r.obj for r in records], "sit", max_frames=30,
                                      n_object_points=300) == 30
    with pytest.raises(ValueError, match="action"):
        scoring.approach_length(far, [r.obj for r in records], "dance")


def test_approach_length_of_sitting_ends_before_the_seat_is_reached(sit_case):
    records, _ = sit_case
    n = scoring.approach_length([r.motion for r in records], [r.obj for r in records], "sit",
                                   n_object_points=500)
    assert 0 < n < FRAMES  # the penetration only grows once the person sits down


# --------------------------------------------------------------------------- Table 1


def test_table_row_known_answer():
    unused = np.zeros(4)
    results = scoring.MotionScores(
        foot_skating=np.array([0.1, 0.3, 0.2, 0.4]),
        d2o=np.array([0.0, 0.01, 0.5, 1.0]),
        penetration=np.array([0.01, 0.03, np.nan, np.nan]),
        skeleton_distance=np.array([1.0, 2.0, 3.0, 6.0]),
        nearest_anchor=unused.astype(int), contact_iou=np.array([1.0, 0.5, 0.0, 0.0]), pose_distance=unused,
        start_distance=unused, final_distance=unused)
    row = scoring.table_row(results)
    assert list(row) == list(scoring.TABLE1_COLUMNS)
    assert row["Foot Skating ↓"] == pytest.approx(0.25)
    assert row["% D2O ≤ 2cm ↑"] == pytest.approx(50.0)
    assert row["D2O 95th % ↓"] == pytest.approx(np.percentile(results.d2o, 95))
    assert row["Skel. Dist. ↓"] == pytest.approx(3.0)
    assert row["Contact IoU ↑"] == pytest.approx(0.375)
    assert row["% Pen. ≤ 2cm ↑"] == pytest.approx(50.0)  # of the two that reach, one penetrates ≤ 2 cm
    with pytest.raises(TypeError, match="MotionScores"):
        scoring.table_row({"d2o": results.d2o})
    supplement = scoring.table_row(results, columns=paper_numbers.SUPPLEMENT_COLUMNS)
    assert list(supplement) == list(paper_numbers.SUPPLEMENT_COLUMNS)
    assert supplement["% Skel. Dist. ≤ 25cm ↑"] == pytest.approx(0.0)  # every summed distance is ≥ 1 m here
    near = dataclasses.replace(results, skeleton_distance=np.array([0.1, 0.25, 0.3, 6.0]))
    assert scoring.table_row(near, columns=("% Skel. Dist. ≤ 25cm ↑",))["% Skel. Dist. ≤ 25cm ↑"] == 50.0
    assert scoring.table_counts(near) == {"D2O ≤ 2cm": "2 / 4", "Skel. Dist. ≤ 25cm": "2 / 4",
                                             "Pen. ≤ 2cm": "1 / 2"}
    with pytest.raises(ValueError, match="columns"):
        scoring.table_row(results, columns=("Speed ↑",))


def _scores(d2o, skel, iou, pose=None):
    n = len(d2o)
    unused = np.zeros(n)
    return scoring.MotionScores(foot_skating=unused, d2o=np.asarray(d2o, float), penetration=unused,
                                skeleton_distance=np.asarray(skel, float), nearest_anchor=unused.astype(int),
                                contact_iou=np.asarray(iou, float),
                                pose_distance=np.asarray(skel if pose is None else pose, float),
                                start_distance=unused, final_distance=unused)


def test_ablation_row_puts_the_pose_only_share_in_place_of_the_all_zero_column():
    from hoi_tutorial.nifty import ablation_tables
    results = _scores([0.01, 0.5, 0.0, 0.3], [3.0, 4.0, 5.0, 6.0], [0.2] * 4, pose=[0.4, 1.0, 1.01, 3.0])
    row = ablation_tables.ablation_row(results, 1.0)
    assert "% Skel. Dist. ≤ 25cm ↑" not in row
    assert row["% Pose Dist. ≤ 100cm ↑"] == 50.0 and row["% D2O ≤ 2cm ↑"] == 50.0
    assert row["Skel. Dist. ↓"] == pytest.approx(4.5)
    columns = ablation_tables.ablation_columns(1.0)
    at = columns.index("% Skel. Dist. ≤ 25cm ↑")
    assert columns[at + 1] == "% Pose Dist. ≤ 100cm ↑" and set(row) <= set(columns)
    assert ablation_tables.ablation_counts(results, 1.0) == {"D2O ≤ 2cm": "2 / 4", "Pose Dist. ≤ 100cm": "2 / 4",
                                                             "Pen. ≤ 2cm": "2 / 2"}
    with pytest.raises(ValueError, match="columns"):
        ablation_tables.ablation_columns(1.0, columns=("Skel. Dist. ↓",))


def test_paired_comparison_known_answers_and_verdicts():
    # Ours reaches 4 of 6 scenes and theirs 1; ours is 2 m nearer the anchors in every scene.
    ours = _scores([0.0, 0.01, 0.015, 0.4, 0.005, 0.03], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [0.5] * 6)
    theirs = _scores([0.3, 0.01, 0.6, 0.9, 0.3, 0.5, 5.0], [3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], [0.5] * 6 + [0.0])
    found = scoring.paired_comparison(ours, theirs, n_scenes=6)
    assert set(found) == {"reach", "d2o", "skel", "pose", "contact_iou"}
    assert found["reach"].estimate == pytest.approx(0.5)
    assert found["d2o"].estimate == pytest.approx(np.median(ours.d2o - theirs.d2o[:6]))   # the median difference
    assert found["skel"].estimate == pytest.approx(-2.0)
    assert (found["skel"].low, found["skel"].high) == pytest.approx((-2.0, -2.0))   # every pair differs by 2 m
    assert found["skel"].verdict("below") == "held" and found["contact_iou"].verdict("above") == "inconclusive"
    assert found["skel"].n == 6
    # the seventh scene of theirs (9 m) changes nothing when only the first six are compared
    assert scoring.paired_comparison(ours, _scores(theirs.d2o[:6], theirs.skeleton_distance[:6],
                                                   theirs.contact_iou[:6]))["skel"] == found["skel"]
    # four scenes are too few for any 95 % interval: every direction is inconclusive, even 2 m in every scene
    few = scoring.paired_comparison(ours, theirs, n_scenes=4)
    assert few["skel"].verdict("below") == "inconclusive"


def test_comparison_table_shows_each_difference_and_its_verdict():
    ours = _scores([0.0, 0.01, 0.015, 0.4, 0.005, 0.03], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [0.5] * 6)
    theirs = _scores([0.3, 0.01, 0.6, 0.9, 0.3, 0.5], [3.0, 4.0, 5.0, 6.0, 7.0, 8.0], [0.5] * 6)
    table = scoring.comparison_table({"ours vs theirs": scoring.paired_comparison(ours, theirs),
                                      "theirs vs ours": scoring.paired_comparison(theirs, ours)})
    assert list(table.index) == ["ours vs theirs", "theirs vs ours"]
    assert table.loc["ours vs theirs", "mean Skel. Dist. (m): better"] == "held"
    assert table.loc["theirs vs ours", "mean Skel. Dist. (m): better"] == "not held"
    assert table.loc["ours vs theirs", "% D2O ≤ 2cm (points)"].startswith("50 [")
    with pytest.raises(ValueError, match="columns"):
        scoring.comparison_table({}, columns=("speed",))


def test_paired_comparison_rejects_scores_of_other_scenes():
    a, b = _scores([0.0] * 3, [1.0] * 3, [0.0] * 3), _scores([0.0] * 5, [1.0] * 5, [0.0] * 5)
    with pytest.raises(ValueError, match="same scenes"):
        scoring.paired_comparison(a, b)
    with pytest.raises(ValueError, match="n_scenes"):
        scoring.paired_comparison(a, b, n_scenes=4)
    with pytest.raises(ValueError, match="n_scenes"):
        scoring.paired_comparison(a, b, n_scenes=1)


# --------------------------------------------------------------------------- a model, end to end


def _tiny_dataset_and_model(sit_case):
    """The two sit clips as a dataset, and a motion model small enough to train in a second."""
    records, anchors = sit_case
    dataset = SyntheticDataset(config=synthetic_data_config("sit", "toy"), anchors=anchors, sequences=records,
                               leaves=[], all_paths=[], tree_stats=[], stats={})
    model_config = motion_model_config("sit", "toy", max_frames=FRAMES, width=32, layers=1, heads=4, n_points=64,
                                       pointnet_hidden=(32,), diffusion_steps=10, steps=3, batch_size=2,
                                       warmup_steps=0)
    return dataset, model_config


def test_evaluate_motion_model_samples_scores_and_caches(sit_case, tmp_cache):
    dataset, model_config = _tiny_dataset_and_model(sit_case)
    config = evaluation.EvaluationConfig(n_scenes=3, n_training=2, n_approach_sequences=2, n_object_points=200)
    result = evaluation.evaluate_motion_model(dataset, model_config, config)
    assert len(result.test_scenes) == 3 and result.training_index == [0, 1]
    assert 0 < result.n_approach <= FRAMES
    assert len(result.scenes.motions) == 3 and len(result.training.motions) == 2
    assert all(len(m) == FRAMES for m in result.scenes.motions)
    # The data set's own motions score as the data.
    np.testing.assert_allclose(result.data.metrics.skeleton_distance, 0.0, atol=1e-9)
    for name in ("scenes", "training", "data"):
        assert len(getattr(result, name).metrics) == len(getattr(result, name).motions)
    assert all(torch.isfinite(m.joints).all() for m in result.scenes.motions)
    assert result.training.metrics.final_distance_positions.shape == (2,)
    assert result.data.metrics.final_distance_positions is None
    again = evaluation.evaluate_motion_model(dataset, model_config, config)
    assert len(list(tmp_cache.glob("nifty_sit_motion_model_evaluation-*.pt"))) == 1
    for name in ("scenes", "training"):
        np.testing.assert_array_equal(getattr(result, name).metrics.d2o, getattr(again, name).metrics.d2o)
        torch.testing.assert_close(getattr(result, name).motions[0].joints, getattr(again, name).motions[0].joints)


def test_penetration_depths_match_the_full_body_sdf(sit_case):
    # The bounding-box shortcut leaves every penetration depth exactly as the full body SDF gives it.
    from hoi_tutorial.world import body

    records, _ = sit_case
    for record in records:
        points = torch.as_tensor(np.asarray(record.obj.surface_points(2000, seed=0)))
        fast = scoring._penetration_per_frame(record.motion, points)
        full = body.body_sdf(points.float(), record.motion.global_rotations.float(), record.motion.joints.float(),
                             record.motion.betas.float()).numpy()
        assert fast.shape == full.shape
        np.testing.assert_array_equal(np.clip(-fast, 0.0, None), np.clip(-full, 0.0, None))
        assert (np.clip(-full, 0.0, None) > 0).any()  # the seated body does reach into the chair
        finite = np.isfinite(fast)
        np.testing.assert_array_equal(fast[finite], full[finite])


def test_paper_numbers_fill_table1_for_every_method_and_action():

    assert scoring.TABLE1_COLUMNS is paper_numbers.TABLE1_COLUMNS
    for action in ("sit", "lift"):
        assert tuple(paper_numbers.TABLE1[action]) == paper_numbers.TABLE1_METHODS
        for row in paper_numbers.TABLE1[action].values():
            assert tuple(row) == scoring.TABLE1_COLUMNS
            assert 0 <= row["% D2O ≤ 2cm ↑"] <= 100 and 0 <= row["Contact IoU ↑"] <= 1
    with pytest.raises(TypeError):
        paper_numbers.TABLE1["sit"]["NIFTY"]["Foot Skating ↓"] = 0.0  # read-only


def test_evaluate_guided_keeps_the_best_candidate_and_caches(sit_case, tmp_cache):
    from hoi_tutorial.nifty.interaction_field import interaction_field_config

    dataset, model_config = _tiny_dataset_and_model(sit_case)
    field_config = interaction_field_config("sit", "toy", width=32, layers=1, pointnet_hidden=(32,),
                                            copies_per_sequence=2, steps=5, batch_size=4)
    config = evaluation.EvaluationConfig(n_scenes=3, n_training=2, n_approach_sequences=2, n_object_points=200)
    result = evaluation.evaluate_guided(dataset, model_config, field_config, config, n_samples=2, alpha=0.5,
                                        n_scenes=2)
    unguided = evaluation.evaluate_motion_model(dataset, model_config, config)
    for scene, same in zip(result.test_scenes, unguided.test_scenes):  # the same scenes as Cond. MDM's
        torch.testing.assert_close(scene.start.joints, same.start.joints, rtol=0, atol=0)
    assert len(result.samples.motions) == 2 and len(result.samples.metrics) == 2
    assert result.all_objectives.shape == (2, 2)
    np.testing.assert_allclose(result.objective, result.all_objectives.min(axis=1))
    again = evaluation.evaluate_guided(dataset, model_config, field_config, config, n_samples=2, alpha=0.5,
                                       n_scenes=2)
    assert len(list(tmp_cache.glob("nifty_sit_guided_evaluation-*.pt"))) == 1
    np.testing.assert_array_equal(result.samples.metrics.d2o, again.samples.metrics.d2o)
    with pytest.raises(ValueError, match="n_scenes"):
        evaluation.evaluate_guided(dataset, model_config, field_config, config, n_scenes=0)


def test_penetration_by_approach_length_agrees_with_the_per_motion_score(sit_case):
    records, anchors = sit_case
    motions, objects = [r.motion for r in records], [r.obj for r in records]
    values = [10, 30, 60, 10_000]  # the last is clamped to each motion's length
    for n_approach in (10, 30, 60):
        scores = scoring.evaluate_motions(motions, objects, anchors, n_approach=n_approach, n_object_points=500)
        curve = scoring.penetration_by_approach_length(motions, objects, scores.d2o, values, n_object_points=500,
                                                          threshold=0.02)
        assert curve["n_scored"] == int((scores.d2o <= 0.02).sum()) == len(records)
        expected = 100.0 * np.mean(scores.penetration <= 0.02)
        assert curve["pct"][values.index(n_approach)] == pytest.approx(expected)
    # A threshold no score passes and one every score passes bound the curve.
    assert (scoring.penetration_by_approach_length(motions, objects, scores.d2o, values, n_object_points=500,
                                                      threshold=-1.0)["pct"] == 0).all()
    assert (scoring.penetration_by_approach_length(motions, objects, scores.d2o, values, n_object_points=500,
                                                      threshold=1e9)["pct"] == 100).all()
    # Nothing reaches the object: nothing is scored.
    far = scoring.penetration_by_approach_length(motions, objects, np.ones(len(motions)), values)
    assert far["n_scored"] == 0 and np.isnan(far["pct"]).all()
    with pytest.raises(ValueError, match="n_approach_values"):
        scoring.penetration_by_approach_length(motions, objects, scores.d2o, [0, 10])
    with pytest.raises(ValueError, match="d2o"):
        scoring.penetration_by_approach_length(motions, objects, scores.d2o[:1], values)


def test_controls_select_by_the_same_objective_and_guide_one_sample(sit_case, tmp_cache):
    from hoi_tutorial.nifty.interaction_field import interaction_field_config

    dataset, model_config = _tiny_dataset_and_model(sit_case)
    field_config = interaction_field_config("sit", "toy", width=32, layers=1, pointnet_hidden=(32,),
                                            copies_per_sequence=2, steps=5, batch_size=4)
    config = evaluation.EvaluationConfig(n_scenes=2, n_training=2, n_approach_sequences=2, n_object_points=200)
    controls = evaluation.evaluate_controls(dataset, model_config, field_config, config, n_samples=3, alpha=0.5)
    assert tuple(controls) == evaluation.CONTROLS
    selection, guided = controls["selection only"], controls["guidance only"]
    assert (selection.n_samples, selection.alpha) == (3, 0.0) and (guided.n_samples, guided.alpha) == (1, 0.5)
    assert selection.all_objectives.shape == (2, 3) and guided.all_objectives.shape == (2, 1)
    np.testing.assert_allclose(selection.objective, selection.all_objectives.min(axis=1))
    assert len(selection.samples.metrics) == len(guided.samples.metrics) == 2


def test_guided_blocks_are_cached_apart_and_reused(sit_case, tmp_cache, monkeypatch):
    from hoi_tutorial.nifty.interaction_field import interaction_field_config

    monkeypatch.setattr(evaluation, "GUIDED_SCENE_BLOCK", 1)
    dataset, model_config = _tiny_dataset_and_model(sit_case)
    field_config = interaction_field_config("sit", "toy", width=32, layers=1, pointnet_hidden=(32,),
                                            copies_per_sequence=2, steps=5, batch_size=4)
    config = evaluation.EvaluationConfig(n_scenes=3, n_training=2, n_approach_sequences=2, n_object_points=200)
    first = evaluation.evaluate_guided(dataset, model_config, field_config, config, n_samples=2, alpha=0.5, n_scenes=1)
    both = evaluation.evaluate_guided(dataset, model_config, field_config, config, n_samples=2, alpha=0.5, n_scenes=2)
    assert len(list(tmp_cache.glob("nifty_sit_guided_evaluation-*.pt"))) == 2  # one block each, the first reused
    torch.testing.assert_close(first.samples.motions[0].joints, both.samples.motions[0].joints, rtol=0, atol=0)
    assert len(both.samples.metrics) == 2 and both.all_objectives.shape == (2, 2)


def test_evaluate_cond_vae_scores_one_sample_per_scene(sit_case, tmp_cache):
    from hoi_tutorial.nifty import baselines

    dataset, model_config = _tiny_dataset_and_model(sit_case)
    vae_config = baselines.cond_vae_config("sit", "toy", max_frames=FRAMES, width=32, layers=1, heads=4, latent=4,
                                           n_points=64, pointnet_hidden=(32,), steps=3, batch_size=2)
    config = evaluation.EvaluationConfig(n_scenes=3, n_training=2, n_approach_sequences=2, n_object_points=200)
    result = evaluation.evaluate_cond_vae(dataset, model_config, vae_config, config)
    assert len(result.motions) == 3 and len(result.metrics) == 3
    assert all(len(m) == FRAMES and torch.isfinite(m.joints).all() for m in result.motions)
    again = evaluation.evaluate_cond_vae(dataset, model_config, vae_config, config)
    np.testing.assert_array_equal(result.metrics.d2o, again.metrics.d2o)
    assert len(list(tmp_cache.glob("nifty_sit_cond_vae_evaluation-*.pt"))) == 1
    with pytest.raises(ValueError, match="max_frames"):
        evaluation.evaluate_cond_vae(dataset, model_config, dataclasses.replace(vae_config, max_frames=FRAMES + 1),
                                     config)


def test_supplementary_tables_are_transcribed_in_their_columns():
    for table, columns in ((paper_numbers.TABLE2, paper_numbers.TABLE1_COLUMNS),
                           (paper_numbers.TABLE3, paper_numbers.SUPPLEMENT_COLUMNS),
                           (paper_numbers.TABLE4, paper_numbers.SUPPLEMENT_COLUMNS),
                           (paper_numbers.TABLE5, paper_numbers.TABLE5_COLUMNS),
                           (paper_numbers.TABLE6, paper_numbers.SUPPLEMENT_COLUMNS),
                           (paper_numbers.TABLE7, paper_numbers.SUPPLEMENT_COLUMNS),
                           (paper_numbers.TABLE8, paper_numbers.SUPPLEMENT_COLUMNS)):
        assert set(table) == {"sit", "lift"}
        for rows in table.values():
            for row in rows.values():
                assert tuple(row) == columns
                assert 0 <= row["% D2O ≤ 2cm ↑"] <= 100 and 0 <= row["Contact IoU ↑"] <= 1
    assert set(paper_numbers.TABLE5_COLUMNS) == set(paper_numbers.SUPPLEMENT_COLUMNS)
    # NIFTY's own sitting row is the same in Tables 3, 4, 6 and 7 (the supplement's 10 samples, 1 frame, canonical).
    nifty_sit = paper_numbers.TABLE4["sit"]["10"]
    for row in (paper_numbers.TABLE3["sit"]["Parametric"], paper_numbers.TABLE6["sit"]["1"],
                paper_numbers.TABLE7["sit"]["Canonical"]):
        assert dict(row) == dict(nifty_sit)


def test_guided_by_the_nearest_anchor_needs_no_field(sit_case, tmp_cache):
    dataset, model_config = _tiny_dataset_and_model(sit_case)
    config = evaluation.EvaluationConfig(n_scenes=3, n_training=2, n_approach_sequences=2, n_object_points=200)
    result = evaluation.evaluate_guided(dataset, model_config, None, config, n_samples=2, alpha=0.5, n_scenes=1,
                                        objective="nearest_anchor")
    assert len(result.samples.motions) == 1 and result.all_objectives.shape == (1, 2)
    np.testing.assert_allclose(result.objective, result.all_objectives.min(axis=1))
    assert not list(tmp_cache.glob("nifty_sit_interaction_field-*.pt"))  # no field was trained
    with pytest.raises(ValueError, match="field_config"):
        evaluation.evaluate_guided(dataset, model_config, None, config, n_scenes=1)
    with pytest.raises(ValueError, match="objective"):
        evaluation.evaluate_guided(dataset, model_config, None, config, n_scenes=1, objective="random")


def test_guided_evaluation_defaults_to_its_variants_alpha_and_the_sweep_scores_training_conditions(sit_case, tmp_cache):
    from hoi_tutorial.nifty import guidance
    from hoi_tutorial.nifty.interaction_field import interaction_field_config

    dataset, model_config = _tiny_dataset_and_model(sit_case)
    field_config = interaction_field_config("sit", "toy", width=32, layers=1, pointnet_hidden=(32,),
                                            copies_per_sequence=2, steps=5, batch_size=4, n_frames=5)
    config = evaluation.EvaluationConfig(n_scenes=2, n_training=2, n_approach_sequences=2, n_object_points=200)
    result = evaluation.evaluate_guided(dataset, model_config, field_config, config, n_samples=1, n_scenes=1)
    assert result.alpha == guidance.GUIDANCE_ALPHA["5 frames"]  # the variant's own α, not NIFTY's
    assert result.alpha != guidance.GUIDANCE_ALPHA["offset"]

    sweep = evaluation.guidance_alpha_sweep(dataset, model_config, field_config, config, alphas=(0.1, 3.0))
    unguided = evaluation.evaluate_motion_model(dataset, model_config, config)
    assert sweep.alphas == (0.1, 3.0) and not sweep.guide_last_step and sweep.n_samples == 1
    for alpha in sweep.alphas:  # one sample per training condition of the unguided evaluation
        assert len(sweep.scores[alpha]) == len(unguided.training_index) == 2
        assert sweep.objective[alpha].shape == (2,)
    assert not np.array_equal(sweep.objective[0.1], sweep.objective[3.0])  # α moves the samples
    assert set(sweep.summary()) == {0.1, 3.0}
    # Best of N by the final objective, as the tables sample.
    best = evaluation.guidance_alpha_sweep(dataset, model_config, field_config, config, alphas=(3.0,), n_samples=3)
    assert best.n_samples == 3 and best.objective[3.0].shape == (2,)
    with pytest.raises(ValueError, match="alphas"):
        evaluation.guidance_alpha_sweep(dataset, model_config, field_config, config, alphas=(0.0,))
    with pytest.raises(ValueError, match="n_samples"):
        evaluation.guidance_alpha_sweep(dataset, model_config, field_config, config, n_samples=0)


def _skeleton_sweep(distances):
    """An AlphaSweep whose kept samples have these skeleton distances: ``{α: [metres per condition]}``."""
    scores = {alpha: scoring.MotionScores(*(np.zeros(len(d)) for _ in range(3)), np.asarray(d, float),
                                          *(np.zeros(len(d)) for _ in range(5)))
              for alpha, d in distances.items()}
    return evaluation.AlphaSweep(alphas=tuple(distances), scores=scores,
                                 objective={a: np.zeros(len(d)) for a, d in distances.items()},
                                 guide_last_step=False)


def test_chosen_alpha_is_the_lowest_pooled_median_skeleton_distance():
    sit = _skeleton_sweep({3.0: [1.0, 1.2, 1.4], 30.0: [0.5, 0.6, 2.0]})
    lift = _skeleton_sweep({3.0: [1.0, 1.1, 1.3], 30.0: [2.0, 2.1, 2.2]})
    assert evaluation.chosen_alpha([sit]) == 30.0  # sit alone: medians 1.2 and 0.6
    assert evaluation.chosen_alpha([sit, lift]) == 3.0  # pooled: medians 1.15 and 2.05
    tie = _skeleton_sweep({3.0: [1.0, 1.0], 30.0: [1.0, 1.0]})
    assert evaluation.chosen_alpha([tie]) == 3.0  # a tie: the smaller α
    with pytest.raises(ValueError, match="same alphas"):
        evaluation.chosen_alpha([sit, _skeleton_sweep({10.0: [1.0]})])


def test_chosen_alpha_over_seeds_takes_the_worst_seed():
    # As measured for the offset field: seeds 1 and 2 end nearer at α = 100, seed 0 falls apart there. Pooled, the
    # two carry the median to 100; by the worst seed, 30.
    stable = _skeleton_sweep({30.0: [1.6, 1.6, 1.6], 100.0: [10.0, 10.1, 10.2]})
    better = [_skeleton_sweep({30.0: [0.8, 0.8, 0.8], 100.0: [0.7, 0.7, 0.7]}) for _ in range(2)]
    assert evaluation.chosen_alpha([stable, *better]) == 100.0
    assert evaluation.chosen_alpha_over_seeds({0: [stable], 1: [better[0]], 2: [better[1]]}) == 30.0
    # One seed: the same as chosen_alpha, its sweeps pooled
    assert evaluation.chosen_alpha_over_seeds({1: better}) == evaluation.chosen_alpha(better) == 100.0
    with pytest.raises(ValueError, match="at least one seed"):
        evaluation.chosen_alpha_over_seeds({})
    with pytest.raises(ValueError, match="same alphas"):
        evaluation.chosen_alpha_over_seeds({0: [stable], 1: [_skeleton_sweep({10.0: [1.0]})]})


def test_the_start_distance_read_from_the_root_is_final_pelvis_distance_bit_for_bit():
    # final_pelvis_distance reads the pelvis without forward kinematics: joint 0, the pelvis, sits at root_position;
    # the same floats as the pelvis of the motion's joints, whatever the dtypes
    obj = make_object("chair", seed=3).placed(0.4, -0.2, 0.7)
    for kind, seed in (("walk", 1), ("sit", 2), ("idle", 5)):
        clip = generate_clip(kind, seed=seed) if kind != "sit" else generate_clip(kind, seed=seed, obj=obj)
        for motion in (clip, Motion(clip.local_rotations.float(), clip.root_position.double(), clip.betas),
                       Motion(clip.local_rotations.double(), clip.root_position.float(), clip.betas)):
            pelvis = motion.joints[:, JOINT_NAMES.index("pelvis"), :2]
            centre = torch.as_tensor(obj.pose[:2, 3], dtype=pelvis.dtype)
            assert final_pelvis_distance(motion, obj) == (float((pelvis[-1] - centre).norm()),
                                                          float((pelvis[0] - centre).norm()))
