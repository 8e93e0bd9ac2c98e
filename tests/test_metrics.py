"""Hand-made cases with known answers for every metric in hoi_tutorial.metrics."""
import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hoi_tutorial import metrics as M

FPS = 30.0


def sliding_toe(height, speed=1.0, n_frames=31):
    """A toe moving along +x at ``speed`` m/s at a constant ``height``."""
    t = np.arange(n_frames) / FPS
    return np.stack([speed * t, np.zeros_like(t), np.full_like(t, height)], axis=-1)


def unit_sphere_points(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


# ----------------------------------------------------------------------------- NIFTY


class TestFootSkating:
    def test_sliding_on_ground_has_weight_one(self):
        assert M.foot_skating(sliding_toe(0.0)) == pytest.approx(1.0)

    def test_above_threshold_scores_zero(self):
        assert M.foot_skating(sliding_toe(0.05)) == 0.0

    def test_half_threshold_weight(self):
        assert M.foot_skating(sliding_toe(0.0125)) == pytest.approx(2.0 - math.sqrt(2.0))

    def test_below_ground_clamped_to_full_weight(self):
        assert M.foot_skating(sliding_toe(-0.01, speed=2.0)) == pytest.approx(2.0)

    def test_vertical_motion_is_not_skating(self):
        toe = np.zeros((10, 3))
        toe[:, 2] = np.linspace(0.0, 0.02, 10)
        assert M.foot_skating(toe) == 0.0

    def test_batch_and_torch(self):
        batch = np.stack([sliding_toe(0.0), sliding_toe(0.05), sliding_toe(0.0, speed=0.5)])
        out = M.foot_skating(torch.tensor(batch, dtype=torch.float32))
        assert out.shape == (3,)
        np.testing.assert_allclose(out, [1.0, 0.0, 0.5], rtol=1e-5)

    def test_shape_error_names_expected_shape(self):
        with pytest.raises(ValueError, match=r"toe_positions: expected shape \(\.\.\., \*, 3\)"):
            M.foot_skating(np.zeros((10, 2)))
        with pytest.raises(ValueError, match="at least 2 frames"):
            M.foot_skating(np.zeros((1, 3)))


class TestDistanceToObject:
    def test_point_at_distance_two_from_unit_sphere(self):
        sphere = unit_sphere_points()
        body = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 5.0]])
        # sampled sphere: nearest sample lies at most slightly farther than the true surface
        assert M.distance_to_object(body, sphere) == pytest.approx(1.0, abs=0.02)

    def test_exact_with_point_on_surface_sample(self):
        sphere = unit_sphere_points()
        body = sphere[:1] * 2.0
        assert M.distance_to_object(body, sphere) == pytest.approx(1.0, abs=1e-12)

    def test_batch_and_chunking(self):
        obj = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        body = np.zeros((3, 5, 3))
        body[..., 1] = np.arange(1, 4)[:, None] + np.arange(5)[None, :]  # y offsets 1.., 2.., 3..
        out = M.distance_to_object(body, obj, chunk_size=2)
        np.testing.assert_allclose(out, [1.0, 2.0, 3.0])

    def test_shape_errors(self):
        with pytest.raises(ValueError, match=r"object_points: expected shape \(\*, 3\)"):
            M.distance_to_object(np.zeros((4, 3)), np.zeros((2, 5, 3)))


def test_d2o_summary():
    d2o = np.array([0.0, 0.01, 0.02, 0.03, 0.5])
    summary = M.d2o_summary(d2o)
    assert summary["pct_within"] == pytest.approx(60.0)
    assert summary["p95"] == pytest.approx(np.percentile(d2o, 95))
    assert M.d2o_summary(d2o, threshold=0.005)["pct_within"] == pytest.approx(20.0)


class TestPenetration:
    def test_known_depths(self):
        sdf = np.array([[0.1, -0.02, -0.01],   # depth 0.03
                        [-0.05, 0.0, 0.2],    # depth 0.05
                        [-1.0, -1.0, -1.0]])  # depth 3.0, outside the approach below
        assert M.penetration_score(sdf, n_approach=2) == pytest.approx(0.08 / 2)
        assert M.penetration_score(sdf) == pytest.approx(3.08 / 3)

    def test_positive_sdf_is_no_penetration(self):
        assert M.penetration_score(np.full((2, 10, 50), 0.3)).tolist() == [0.0, 0.0]

    def test_bad_n_approach(self):
        with pytest.raises(ValueError, match="n_approach"):
            M.penetration_score(np.zeros((5, 3)), n_approach=6)
        with pytest.raises(ValueError, match="n_approach"):
            M.penetration_score(np.zeros((5, 3)), n_approach=0)

    def test_pass_rate_ignores_sequences_that_do_not_reach(self):
        pen = np.array([0.0, 0.05, 0.01, 0.0])
        d2o = np.array([0.01, 0.0, 0.015, 0.5])  # the last never reaches the object
        assert M.penetration_pass_rate(pen, d2o) == pytest.approx(100.0 * 2 / 3)

    def test_pass_rate_nan_when_none_reach(self):
        assert math.isnan(M.penetration_pass_rate([0.0, 0.0], [0.3, 0.4]))

    def test_pass_rate_shape_mismatch(self):
        with pytest.raises(ValueError, match="d2o"):
            M.penetration_pass_rate([0.0, 0.0], [0.0])


class TestApproachFrames:
    def test_flat_then_rising(self):
        # zero penetration while walking up, rises from frame 3 on
        curve = [0.0, 0.0, 0.0, 0.0, 0.1, 0.3, 0.3, 0.6]
        assert M.approach_frames(curve) == 3

    def test_dip_then_rising(self):
        curve = [0.0, 0.2, 0.1, 0.1, 0.4, 0.5]
        assert M.approach_frames(curve) == 3

    def test_rising_from_start(self):
        assert M.approach_frames([0.0, 0.1, 0.2]) == 0

    def test_never_rising_is_all_approach(self):
        assert M.approach_frames(np.zeros(10)) == 10
        assert M.approach_frames([0.5, 0.4, 0.3]) == 3

    def test_tolerance_ignores_noise(self):
        curve = [0.0, 0.0, 0.2, 0.1999, 0.5]
        assert M.approach_frames(curve) == 3
        assert M.approach_frames(curve, tolerance=1e-3) == 1

    def test_quantile(self):
        curves = [np.r_[np.zeros(k + 1), np.arange(1, 5)] for k in (2, 4, 6, 8, 10)]
        assert [M.approach_frames(c) for c in curves] == [2, 4, 6, 8, 10]
        assert M.approach_length_quantile(curves, 0.5) == 6
        assert M.approach_length_quantile(curves, 0.15) == 2
        with pytest.raises(ValueError, match="q"):
            M.approach_length_quantile(curves, 1.5)


class TestSkeletonDistance:
    def test_picks_nearest_anchor_under_the_sum(self):
        anchors = np.zeros((3, 22, 3))
        anchors[1] += [0.0, 0.0, 1.0]
        anchors[2] += [0.0, 0.5, 0.0]
        pose = np.zeros((22, 3)) + [0.0, 0.4, 0.0]
        dist, idx = M.skeleton_distance(pose, anchors)
        assert idx == 2
        assert dist == pytest.approx(22 * 0.1)

    def test_sum_not_mean_of_errors(self):
        anchors = np.zeros((1, 22, 3))
        pose = np.zeros((22, 3))
        pose[5] = [3.0, 4.0, 0.0]
        dist, idx = M.skeleton_distance(pose, anchors)
        assert (dist, idx) == (pytest.approx(5.0), 0)

    def test_batch_matches_loop(self):
        rng = np.random.default_rng(1)
        anchors = rng.normal(size=(7, 22, 3))
        poses = rng.normal(size=(2, 4, 22, 3))
        dist, idx = M.skeleton_distance(poses, anchors)
        assert dist.shape == idx.shape == (2, 4)
        for b in range(2):
            for k in range(4):
                sums = np.linalg.norm(poses[b, k] - anchors, axis=-1).sum(axis=-1)
                assert idx[b, k] == sums.argmin()
                assert dist[b, k] == pytest.approx(sums.min())

    def test_joint_count_mismatch(self):
        with pytest.raises(ValueError, match=r"anchor_joints: expected shape \(\*, 22, 3\)"):
            M.skeleton_distance(np.zeros((22, 3)), np.zeros((2, 21, 3)))


class TestContacts:
    def test_contact_set(self):
        sdf = np.array([0.1, 0.0, -0.01, 0.005])
        assert M.contact_set(sdf).tolist() == [False, True, True, False]
        assert M.contact_set(sdf, threshold=0.01).tolist() == [False, True, True, True]

    def test_iou_known_sets(self):
        a = np.array([1, 1, 1, 0, 0], dtype=bool)
        b = np.array([0, 1, 1, 1, 0], dtype=bool)
        assert M.contact_iou(a, b) == pytest.approx(2 / 4)
        assert M.contact_iou(a, a) == 1.0
        assert M.contact_iou(a, ~a) == 0.0

    def test_iou_both_empty_is_one(self):
        empty = np.zeros((2, 6), dtype=bool)
        full = np.ones((2, 6), dtype=bool)
        np.testing.assert_array_equal(M.contact_iou(empty, empty), [1.0, 1.0])
        np.testing.assert_array_equal(M.contact_iou(empty, full), [0.0, 0.0])

    def test_iou_shape_mismatch(self):
        with pytest.raises(ValueError, match="contacts_b"):
            M.contact_iou(np.zeros(5, bool), np.zeros(4, bool))


# ----------------------------------------------------------------------------- SAMP


def brute_force_apd(x):
    n = len(x)
    total = sum(np.sum((x[i] - x[j]) ** 2) for i in range(n) for j in range(n) if i != j)
    return total / (n * (n - 1))


class TestAPD:
    def test_two_points(self):
        assert M.average_pairwise_distance([[0.0, 0.0], [3.0, 4.0]]) == pytest.approx(25.0)

    def test_identical_is_zero(self):
        assert M.average_pairwise_distance(np.ones((6, 4)) * 1e3) == pytest.approx(0.0, abs=1e-9)

    @settings(max_examples=40, deadline=None)
    @given(arrays(np.float64, st.tuples(st.integers(2, 8), st.integers(1, 5)),
                  elements=st.floats(-100, 100)))
    def test_matches_brute_force(self, x):
        expected = brute_force_apd(x)
        assert M.average_pairwise_distance(x) == pytest.approx(expected, rel=1e-9, abs=1e-7)

    def test_batched(self):
        rng = np.random.default_rng(2)
        x = rng.normal(size=(3, 5, 2))
        np.testing.assert_allclose(M.average_pairwise_distance(x), [brute_force_apd(v) for v in x])

    def test_needs_two_vectors(self):
        with pytest.raises(ValueError, match="at least 2"):
            M.average_pairwise_distance(np.zeros((1, 3)))


class TestGoalAPD:
    def test_opposite_directions(self):
        pos = np.array([[[0.0, 0.0, 0.0], [0.3, 0.4, 0.0]]])
        dirs = np.array([[[0.0, 1.0, 0.0], [0.0, -2.0, 0.0]]])  # not unit: normalised inside
        out = M.goal_apd(pos, dirs)
        assert out["apd_pos"] == pytest.approx(0.5)
        assert out["apd_rot"] == pytest.approx(180.0)

    def test_mean_over_objects_and_pairs(self):
        pos = np.zeros((2, 3, 3))
        pos[1, 1, 0] = 1.0  # object 1: pair distances 1,1,0 each counted twice -> mean 2/3
        dirs = np.zeros((2, 3, 3))
        dirs[..., 1] = 1.0
        dirs[0, 0] = [1.0, 0.0, 0.0]  # object 0: angles 90, 90, 0 -> mean 60
        out = M.goal_apd(pos, dirs)
        assert out["apd_pos"] == pytest.approx((0.0 + 2 / 3) / 2)
        assert out["apd_rot"] == pytest.approx((60.0 + 0.0) / 2)

    def test_shape_error(self):
        with pytest.raises(ValueError, match=r"directions: expected shape \(1, 2, 3\)"):
            M.goal_apd(np.zeros((1, 2, 3)), np.ones((1, 3, 3)))


def test_goal_reconstruction_error():
    pred_pos = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    true_pos = np.array([[0.06, 0.0, 0.0], [1.0, 1.0, 1.0]])
    pred_dir = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    true_dir = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    out = M.goal_reconstruction_error(pred_pos, pred_dir, true_pos, true_dir)
    assert out["position_error"] == pytest.approx(0.03)
    assert out["angle_error"] == pytest.approx(45.0)


def test_penetration_frame_rate():
    sdf = np.array([[0.1, -0.01, 0.0, -0.2], [0.1, 0.1, 0.1, 0.1]])
    np.testing.assert_allclose(M.penetration_frame_rate(sdf), [50.0, 0.0])
    np.testing.assert_allclose(M.penetration_frame_rate(sdf, threshold=0.05), [25.0, 0.0])


class TestExecutionTime:
    def test_switch_at_frame_45(self):
        labels = ["walk"] * 45 + ["sit"] * 20
        assert M.execution_time(labels, "sit") == pytest.approx(1.5)

    def test_int_labels_torch(self):
        labels = torch.cat([torch.zeros(45, dtype=torch.long), torch.full((5,), 3)])
        assert M.execution_time(labels, 3, fps=15.0) == pytest.approx(3.0)

    def test_never_is_inf(self):
        assert M.execution_time(["walk"] * 10, "sit") == math.inf


class TestGoalPrecision:
    def test_ninety_degree_turn(self):
        out = M.goal_precision([0.0, 0.0, 0.9], [0.0, 1.0, 0.0], [0.3, 0.4, 0.45], [1.0, 0.0, 0.0])
        assert out["position_error"] == pytest.approx(0.5)  # horizontal only
        assert out["rotation_error"] == pytest.approx(90.0)

    def test_full_3d(self):
        out = M.goal_precision([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 3.0, 4.0], [0.0, 1.0, 1.0],
                               horizontal=False)
        assert out["position_error"] == pytest.approx(5.0)
        assert out["rotation_error"] == pytest.approx(45.0)

    def test_batched(self):
        root = np.zeros((2, 3))
        fwd = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
        goal_dir = np.array([[0.0, 1.0, 0.3], [0.0, -1.0, 0.0]])  # tilt ignored horizontally
        out = M.goal_precision(root, fwd, root, goal_dir)
        np.testing.assert_allclose(out["rotation_error"], [0.0, 180.0], atol=1e-6)
        np.testing.assert_allclose(out["position_error"], [0.0, 0.0])


class TestFrechet:
    def test_identical_samples_zero(self):
        x = np.random.default_rng(3).normal(size=(200, 4))
        assert M.frechet_distance(x, x) == pytest.approx(0.0, abs=1e-6)

    def test_one_dimensional_closed_form(self):
        rng = np.random.default_rng(4)
        a = rng.normal(1.0, 2.0, size=(500, 1))
        b = rng.normal(-0.5, 0.5, size=(300, 1))
        mu_a, mu_b = a.mean(), b.mean()
        sd_a, sd_b = a.std(ddof=1), b.std(ddof=1)
        expected = (mu_a - mu_b) ** 2 + (sd_a - sd_b) ** 2
        assert M.frechet_distance(a, b) == pytest.approx(expected, rel=1e-9)

    def test_diagonal_closed_form_and_symmetry(self):
        rng = np.random.default_rng(5)
        a = rng.normal(size=(400, 3)) * [1.0, 2.0, 0.5] + [0.0, 1.0, 2.0]
        b = rng.normal(size=(300, 3)) * [0.5, 1.0, 1.5]
        fd_ab = M.frechet_distance(a, b)
        fd_ba = M.frechet_distance(b, a)
        assert fd_ab == pytest.approx(fd_ba, rel=1e-8)
        # population parameters give the closed form up to sampling noise
        expected = (0.0 + 1.0 + 4.0) + ((1.0 - 0.5) ** 2 + (2.0 - 1.0) ** 2 + (0.5 - 1.5) ** 2)
        assert fd_ab == pytest.approx(expected, rel=0.2)

    def test_singular_covariance_is_finite_and_non_negative(self):
        a = np.zeros((10, 3))
        a[:, 0] = np.arange(10)  # rank-1 covariance
        value = M.frechet_distance(a, a + 1.0)
        assert np.isfinite(value) and value >= 0.0
        assert value == pytest.approx(3.0, abs=1e-3)  # only the mean shift remains

    def test_dimension_mismatch(self):
        with pytest.raises(ValueError, match=r"features_b: expected shape \(\*, 2\)"):
            M.frechet_distance(np.zeros((5, 2)), np.zeros((5, 3)))


def test_sliding_windows():
    x = np.arange(12.0).reshape(6, 2)  # frame t = [2t, 2t+1]
    out = M.sliding_windows(x, window=3)
    assert out.shape == (4, 6)
    np.testing.assert_array_equal(out[1], [2, 3, 4, 5, 6, 7])
    strided = M.sliding_windows(np.stack([x, -x]), window=2, stride=2)
    assert strided.shape == (2, 3, 4)
    np.testing.assert_array_equal(strided[1, 2], [-8, -9, -10, -11])
    with pytest.raises(ValueError, match="window"):
        M.sliding_windows(x, window=7)


# ----------------------------------------------------------------------------- CHOICE


class TestUnsmoothness:
    def test_constant_velocity_is_zero(self):
        t = np.arange(20)[:, None, None] / FPS
        joints = np.zeros((20, 22, 3)) + t * [1.0, -2.0, 0.5]
        assert M.unsmoothness(joints) == pytest.approx(0.0, abs=1e-9)

    def test_parabola_gives_its_acceleration(self):
        a = 3.0
        t = np.arange(40) / FPS
        path = np.stack([a * t ** 2 / 2, np.zeros_like(t), np.zeros_like(t)], axis=-1)
        assert M.unsmoothness(path) == pytest.approx(a)  # 2-D input: one track
        batch = np.stack([path, 2 * path])
        np.testing.assert_allclose(M.unsmoothness(batch, has_joint_axis=False), [a, 2 * a])

    def test_mean_over_joints(self):
        t = np.arange(10) / FPS
        joints = np.zeros((10, 2, 3))
        joints[:, 1, 2] = 4.0 * t ** 2 / 2  # one joint accelerates at 4, the other rests
        assert M.unsmoothness(joints) == pytest.approx(2.0)


class TestFootSliding:
    def stepping_feet(self):
        """Two feet: foot 0 planted all the time; foot 1 swings during frames 5..9."""
        n = 20
        feet = np.zeros((n, 2, 3))
        feet[:, 1, 0] = 0.3
        swing = np.arange(5, 10)
        feet[swing, 1, 1] = np.linspace(0.1, 0.5, 5)
        feet[swing, 1, 2] = 0.05
        feet[10:, 1, 1] = 0.6
        contacts = np.ones((n, 2), dtype=bool)
        contacts[swing, 1] = False
        return feet, contacts

    def test_planted_feet_are_zero(self):
        feet, contacts = self.stepping_feet()
        assert M.foot_sliding(feet, contacts) == 0.0
        assert M.foot_slide_speed(feet, contacts) == 0.0

    def test_sliding_foot_speed(self):
        feet, contacts = self.stepping_feet()
        feet[:, 0, 0] += 0.5 * np.arange(20) / FPS  # foot 0 slides at 0.5 m/s while in contact
        n_pairs = 19 + 4 + 9  # contact intervals: foot 0, then foot 1 before and after its swing
        assert M.foot_slide_speed(feet, contacts) == pytest.approx(0.5 * 19 / n_pairs)
        assert M.foot_sliding(feet, contacts) == pytest.approx(0.0, abs=1e-9)  # constant speed

    def test_accelerating_foot(self):
        t = np.arange(10) / FPS
        feet = np.zeros((10, 1, 3))
        feet[:, 0, 0] = 2.0 * t ** 2 / 2
        contacts = np.ones((10, 1), dtype=bool)
        assert M.foot_sliding(feet, contacts) == pytest.approx(2.0)

    def test_no_contact_is_nan(self):
        assert math.isnan(M.foot_sliding(np.zeros((5, 2, 3)), np.zeros((5, 2), bool)))

    def test_contact_shape(self):
        with pytest.raises(ValueError, match=r"contacts: expected shape \(5, 2\)"):
            M.foot_sliding(np.zeros((5, 2, 3)), np.zeros((5, 3), bool))


class TestCurvature:
    @pytest.mark.parametrize("radius", [0.25, 2.0])
    def test_circle(self, radius):
        theta = np.linspace(0, 2 * np.pi, 301)
        circle = radius * np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=-1)
        assert M.rms_curvature(circle) == pytest.approx(1.0 / radius, rel=1e-3)

    def test_straight_line_and_resting_frames(self):
        line = np.zeros((12, 3))
        line[6:, 0] = np.arange(6) * 0.1  # rests, then moves straight
        assert M.rms_curvature(line) == pytest.approx(0.0, abs=1e-9)
        assert math.isnan(M.rms_curvature(np.zeros((5, 3))))


class TestSafety:
    def test_masked_mean(self):
        clearance = np.array([0.5, 0.4, 0.1, 0.05])
        mask = np.array([False, False, True, True])
        assert M.safety_distance(clearance, mask) == pytest.approx(0.075)
        assert M.safety_distance(clearance) == pytest.approx(0.2625)
        assert math.isnan(M.safety_distance(clearance, np.zeros(4, bool)))

    def test_near_endpoint_mask(self):
        path = np.zeros((5, 3))
        path[:, 0] = [0.0, 0.5, 0.85, 0.95, 1.0]
        mask = M.near_endpoint_mask(path, path[-1])
        assert mask.tolist() == [False, False, True, True, True]
        with pytest.raises(ValueError, match=r"endpoint: expected shape \(3\)"):
            M.near_endpoint_mask(path, np.zeros((2, 3)))


def test_success_rate():
    assert M.success_rate([True, False, True, True]) == pytest.approx(75.0)
    assert M.success_rate(np.array([1, 0])) == pytest.approx(50.0)
    assert math.isnan(M.success_rate([]))


def test_vertical_forward_has_no_heading():
    with pytest.raises(ValueError, match="root_forward \\(horizontal part\\)"):
        M.goal_precision([0, 0, 0], [0, 0, 1.0], [1.0, 0, 0], [1.0, 0, 0])


def test_torch_inputs_match_numpy():
    rng = np.random.default_rng(6)
    sdf = rng.normal(scale=0.05, size=(2, 8, 30))
    expected = M.penetration_score(sdf, n_approach=5)
    got = M.penetration_score(torch.tensor(sdf, requires_grad=True), n_approach=5)
    np.testing.assert_allclose(got, expected)
    feats = rng.normal(size=(50, 3))
    assert M.frechet_distance(torch.tensor(feats), feats + 1.0) == pytest.approx(
        M.frechet_distance(feats, feats + 1.0))
