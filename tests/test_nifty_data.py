"""NIFTY's data pipeline: the time-reversed prior's bookkeeping and Algorithm 1's rules.

The tree tests drive ``grow_trees`` with a stub prior whose rollouts the test controls, so the
branching factors, NTries, PruneCheck and the root-to-node paths are checked exactly.
"""
import dataclasses
import math

import numpy as np
import pytest
import torch
from torch import nn

from hoi_tutorial.nifty import motion_prior as mp
from hoi_tutorial.nifty import rollout as ro
from hoi_tutorial.nifty.anchors import Anchor
from hoi_tutorial.world.kinematics import forward_kinematics
from hoi_tutorial.world.mocap import generate_clip
from hoi_tutorial.world.mocap.poses import standing_pose
from hoi_tutorial.world.motion import Motion
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.rotations import matrix_to_rotation_6d
from hoi_tutorial.world.skeleton import bone_offsets, rest_pelvis_height


def _track(motion, idx):
    return mp.PoseTrack(motion.local_rotations[idx], motion.root_position[idx], motion.joints[idx])


@pytest.fixture(scope="module")
def walk():
    return generate_clip("walk", seed=3)


def test_step_target_and_apply_step_are_inverse(walk):
    cur, nxt = _track(walk, slice(10, 40)), _track(walk, slice(11, 41))
    step = mp.step_target(cur, nxt)
    assert step.shape == (30, mp.STEP_SIZE)
    rebuilt = mp.apply_step(cur, step, bone_offsets(walk.betas))
    assert torch.allclose(rebuilt.root_position, nxt.root_position, atol=1e-5)
    assert torch.allclose(rebuilt.joints, nxt.joints, atol=1e-4)


def test_heading_state_is_invariant_to_where_the_motion_happens(walk):
    moved = walk.transformed(yaw=1.3, translation=(2.0, -1.0, 0.0))
    a = mp.heading_state(_track(walk, slice(0, 20)), _track(walk, slice(1, 21)))
    b = mp.heading_state(_track(moved, slice(0, 20)), _track(moved, slice(1, 21)))
    assert a.shape == (20, mp.STATE_SIZE)
    assert torch.allclose(a, b, atol=1e-4)


def test_training_windows_are_time_reversed(walk):
    windows = mp.training_windows([walk], window=4)
    # The first window starts at the clip's last frame: the prior learns to predict the past.
    assert torch.allclose(windows["root_position"][0, 0], walk.root_position[-1])
    assert torch.allclose(windows["root_position"][0, 1], walk.root_position[-2])
    # Reversed velocities flip sign: the reversed pelvis moves opposite to the real walk.
    real = walk.root_position[-1] - walk.root_position[-2]
    rev = windows["root_position"][0, 1] - windows["root_position"][0, 0]
    assert torch.allclose(rev, -real)


def test_prior_trains_and_rolls_out(walk):
    clips = [walk, generate_clip("walk", seed=4)]
    model, result = mp.train_reverse_prior(clips, mp.PriorConfig(steps=150, window=4, width=64, own_prediction_max=0.0, batch_size=32), progress=False)
    # The KL weight anneals up from 0, so compare the reconstruction term.
    rec = result.extra["reconstruction"]
    assert np.mean(rec[-10:]) < 0.5 * np.mean(rec[:10])
    g = torch.Generator().manual_seed(0)
    prev, start = _track(walk, slice(-2, -1)), _track(walk, slice(-1, None))
    out = mp.rollout(model, prev, start, bone_offsets(walk.betas)[None], 12, g)
    assert out.joints.shape == (1, 12, 22, 3)
    assert torch.isfinite(out.joints).all()


# ---------------------------------------------------------------- Algorithm 1 with a stub prior
class StubPrior(nn.Module):
    """Moves 5 cm per frame along its heading; the first ``bad_calls`` rollout calls sink into the floor."""

    def __init__(self, bad_calls=0, sink_all=False):
        super().__init__()
        self.register_buffer("x_mean", torch.zeros(mp.STATE_SIZE))
        self.calls = 0
        self.bad_calls = bad_calls
        self.sink_all = sink_all
        self.frames_per_call = None

    def sample_step(self, x, generator, temperature=1.0):
        n = x.shape[0]
        step = torch.zeros(n, mp.STEP_SIZE)
        rest6d = matrix_to_rotation_6d(torch.eye(3))
        step[:, 3:9] = rest6d
        step[:, 1] = 0.05  # 5 cm forward per frame
        self.calls += 1
        rollout_index = (self.calls - 1) // self.frames_per_call
        sinking = self.sink_all or rollout_index < self.bad_calls
        step[:, 2] = 0.3 if sinking else float(rest_pelvis_height())
        return step


def _anchor(obj):
    local, root = standing_pose()
    _, joints = forward_kinematics(local, root)
    pose = mp.PoseTrack(local, root, joints)
    clip = Motion(local[None].repeat(3, 1, 1, 1), root[None].repeat(3, 1))
    return Anchor("sit", pose, pose, torch.zeros(10), 0, obj, clip)


@pytest.fixture(scope="module")
def far_object():
    return make_object("box", seed=0).placed(-8.0, -8.0, 0.0)


def test_tree_branching_when_every_rollout_is_valid(far_object):
    config = ro.TreeConfig(max_depth=3, frames_per_node=6, min_start_distance=0.0)
    stub = StubPrior()
    stub.frames_per_call = config.frames_per_node
    trees = ro.grow_trees(stub, [_anchor(far_object)], torch.Generator().manual_seed(0), config)
    tree = trees[0]
    depths = [n.depth for n in tree.nodes]
    # B = 6 for the nodes at depths 1 and 2, B = 2 deeper: 6, 36, 72 nodes.
    assert depths.count(1) == 6 and depths.count(2) == 36 and depths.count(3) == 72
    assert all(len(tree.nodes[i].children) == 6 for i, d in enumerate(depths) if d == 1)
    assert all(len(tree.nodes[i].children) == 2 for i, d in enumerate(depths) if d == 2)
    assert tree.survival_rate() == {1: 1.0, 2: 1.0, 3: 1.0}
    # Every child took exactly one try (the first passes).
    assert tree.tries_per_depth == {1: 6, 2: 36, 3: 72}


def test_paths_end_exactly_in_the_anchor(far_object):
    config = ro.TreeConfig(max_depth=2, frames_per_node=5, min_start_distance=0.0)
    stub = StubPrior()
    stub.frames_per_call = config.frames_per_node
    anchor = _anchor(far_object)
    tree = ro.grow_trees(stub, [anchor], torch.Generator().manual_seed(0), config)[0]
    paths = ro.tree_paths(tree)
    assert len(paths) == 6 + 36  # one per node (root excluded)
    for motion in paths:
        assert len(motion) == 1 + config.frames_per_node * motion.meta["depth"]
        assert torch.equal(motion.local_rotations[-1], anchor.pose.local_rotations)
        assert torch.equal(motion.root_position[-1], anchor.pose.root_position)
        # The stub moves along +Y in reversed time, so played forwards the path starts further out.
        assert motion.root_position[0, 1] > motion.root_position[-1, 1]
    leaves = ro.tree_paths(tree, leaves_only=True)
    assert len(leaves) == 36


def test_rollout_tries_until_prune_check_passes(far_object):
    # The first 5 tries of every child sink (PruneCheck fails); the 6th passes.
    config = ro.TreeConfig(max_depth=1, frames_per_node=4, tries_per_chunk=1, n_tries=20, min_start_distance=0.0)
    stub = StubPrior(bad_calls=5)  # one rollout call per chunk covers the 6 children's next try
    stub.frames_per_call = config.frames_per_node
    tree = ro.grow_trees(stub, [_anchor(far_object)], torch.Generator().manual_seed(0), config)[0]
    assert tree.created_per_depth == {1: 6}
    assert tree.tries_per_depth == {1: 36}
    assert tree.failures["sinking"] == 30


def test_rollout_gives_up_after_n_tries(far_object):
    config = ro.TreeConfig(max_depth=2, frames_per_node=4, n_tries=7, tries_per_chunk=3, min_start_distance=0.0)
    stub = StubPrior(sink_all=True)
    stub.frames_per_call = config.frames_per_node
    tree = ro.grow_trees(stub, [_anchor(far_object)], torch.Generator().manual_seed(0), config)[0]
    assert len(tree.nodes) == 1  # only the root: RollOut returned null for every child
    assert tree.tries_per_depth == {1: 6 * 7}
    assert tree.survival_rate() == {1: 0.0}


def test_prune_check_flags_each_failure(walk):
    box = make_object("box", seed=0)
    n = 5
    seg = mp.PoseTrack(walk.local_rotations[None, :30].repeat(n, 1, 1, 1, 1),
                       walk.root_position[None, :30].repeat(n, 1, 1), walk.joints[None, :30].repeat(n, 1, 1, 1))
    seg.root_position = seg.root_position.clone()
    seg.local_rotations = seg.local_rotations.clone()
    seg.root_position[1, :, 2] -= 0.2  # sinks
    seg.root_position[2, :, 2] += 0.5  # floats
    seg.local_rotations[3, :, 4] = torch.tensor([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])  # knee turned 180°
    still = walk.local_rotations[0:1].repeat(30, 1, 1, 1)
    seg.local_rotations[4] = still
    seg.root_position[4] = walk.root_position[0:1].repeat(30, 1)
    _, joints = forward_kinematics(seg.local_rotations, seg.root_position, bone_offsets(None))
    seg.joints = joints
    far = box.placed(20.0, 20.0, 0.0)
    checks = ro.prune_check(seg, torch.zeros(n, 10), [far] * n, torch.zeros(n))
    assert checks["valid"].tolist() == [True, False, False, False, False]
    assert bool(checks["sinking"][1]) and bool(checks["floating"][2])
    assert bool(checks["unnatural"][3]) and bool(checks["stationary"][4])
    # The same walk through a box placed on its path collides.
    on_path = box.placed(float(walk.root_position[15, 0]), float(walk.root_position[15, 1]), 0.0)
    hit = ro.prune_check(seg, torch.zeros(n, 10), [on_path] * n, torch.zeros(n))
    assert bool(hit["collision"][0])


def test_branching_factor_follows_the_paper():
    config = ro.TreeConfig()
    assert [ro.branching_factor(d, config) for d in range(5)] == [6, 6, 2, 2, 2]


def test_joint_limits_from_data_accept_the_data(walk):
    limits = ro.joint_limits_from([walk])
    assert limits.shape == (22,)
    assert math.isclose(float(limits[0]), math.pi, rel_tol=1e-6)
    seg = mp.PoseTrack(walk.local_rotations[None, :30], walk.root_position[None, :30], walk.joints[None, :30])
    far = make_object("box", seed=0).placed(20.0, 20.0, 0.0)
    checks = ro.prune_check(seg, walk.betas[None], [far], torch.zeros(1), ro.PruneConfig(joint_limits=limits))
    assert not bool(checks["unnatural"][0])


def test_prior_training_does_not_depend_on_the_global_rng(walk):
    config = mp.PriorConfig(steps=3, window=4, width=32, batch_size=8)
    torch.manual_seed(1)
    first, _ = mp.train_reverse_prior([walk], config, progress=False)
    torch.manual_seed(2)
    second, _ = mp.train_reverse_prior([walk], config, progress=False)
    for a, b in zip(first.state_dict().values(), second.state_dict().values()):
        assert torch.equal(a, b)


def test_prune_check_flags_a_sliding_planted_foot(walk):
    # A standing pose dragged across the floor at 1 m/s: the toes rest on the ground and slide.
    local, root = standing_pose()
    F = 30
    rots = local[None, None].repeat(2, F, 1, 1, 1)
    roots = root[None, None].repeat(2, F, 1).clone()
    roots[1, :, 0] += torch.arange(F, dtype=roots.dtype) / 30.0
    _, joints = forward_kinematics(rots, roots, bone_offsets(None))
    seg = mp.PoseTrack(rots, roots, joints)
    far = make_object("box", seed=0).placed(20.0, 20.0, 0.0)
    limit = ro.skating_limit_from([walk])
    config = ro.PruneConfig(skating=limit, stationary=-1.0)
    checks = ro.prune_check(seg, torch.zeros(2, 10), [far] * 2, torch.zeros(2), config)
    assert checks["skating"].tolist() == [False, True]
    # Without a limit the check is off.
    assert not ro.prune_check(seg, torch.zeros(2, 10), [far] * 2, torch.zeros(2),
                              ro.PruneConfig(stationary=-1.0))["skating"].any()


def test_skating_limit_is_the_worst_window_of_the_data(walk):
    from hoi_tutorial import metrics
    from hoi_tutorial.world import body

    limit = ro.skating_limit_from([walk], frames=30)
    windows = [max(float(metrics.foot_skating(body.toe_positions(walk.slice(s, s + 30), side)))
                   for side in ("right", "left")) for s in range(0, len(walk) - 29, 30)]
    assert limit == pytest.approx(max(windows))
    assert limit > 0.0
    # Every node-long window of the data itself passes a check with that limit.
    far = make_object("box", seed=0).placed(20.0, 20.0, 0.0)
    for s in range(0, len(walk) - 29, 30):
        seg = mp.PoseTrack(walk.local_rotations[None, s:s + 30], walk.root_position[None, s:s + 30],
                           walk.joints[None, s:s + 30])
        checks = ro.prune_check(seg, walk.betas[None], [far], torch.zeros(1), ro.PruneConfig(skating=limit))
        assert not bool(checks["skating"][0])
    with pytest.raises(ValueError, match="frames"):
        ro.skating_limit_from([walk], frames=1)
    with pytest.raises(ValueError, match="at least one"):
        ro.skating_limit_from([])


# --------------------------------------------------------------------------- anchor rounds


def test_anchor_rounds_extend_each_subject_without_changing_the_first_round():
    from hoi_tutorial.nifty.anchors import collect_anchors

    one = collect_anchors("sit", 2, 1, seed=5)
    three = collect_anchors("sit", 2, 1, seed=5, rounds=3)
    assert len(three) == 6
    for a, b in zip(one, three[:2]):  # round 0 is the same whatever follows
        torch.testing.assert_close(a.pose.joints, b.pose.joints, rtol=0, atol=0)
    # Round-major, then subject-major: the same two subjects (body shapes) in every round.
    assert [a.subject for a in three] == [0, 1, 0, 1, 0, 1]
    for r in range(3):
        torch.testing.assert_close(three[2 * r].betas, one[0].betas)
    with pytest.raises(ValueError, match="rounds: expected a positive int"):
        collect_anchors("sit", 2, 1, seed=5, rounds=0)


def test_synthesize_grows_rounds_of_anchors_until_the_minimum(tmp_cache, monkeypatch):
    """Stub the prior and the trees: each tree of round r keeps ``r`` sequences, so a minimum of 20
    with 2 anchors per round needs rounds 0..4 (0 + 2 + 4 + 6 + 8 = 20)."""
    import types

    from hoi_tutorial.infra import TrainedModel
    from hoi_tutorial.nifty import data

    config = data.synthetic_data_config("sit", n_subjects=2, anchors_per_subject=1, min_sequences=20,
                                        max_anchor_rounds=6)
    monkeypatch.setattr(data, "trained_prior", lambda *a, **k: TrainedModel(None, torch.zeros(1), 0.0, {}))
    monkeypatch.setattr(data, "prune_settings", lambda config: None)
    grown = []

    def fake_grow_trees(prior, anchors, generator, tree, prune):
        grown.append(len(anchors))
        return [types.SimpleNamespace(anchor=a, round=len(grown) - 1) for a in anchors]

    monkeypatch.setattr(data, "grow_trees", fake_grow_trees)
    monkeypatch.setattr(data.rollout, "tree_paths", lambda tree: [tree.round] * tree.round)
    monkeypatch.setattr(data, "start_distance", lambda path, obj: 1.0)
    empty = {"local_rotations": [], "root_position": [], "anchor": np.zeros(0, dtype=np.int64),
             "depth": np.zeros(0, dtype=np.int64), "leaf": np.zeros(0, dtype=bool), "trees": []}
    monkeypatch.setattr(data, "_paths_payload", lambda trees: dict(empty))
    with pytest.warns(RuntimeWarning, match="fewer than min_sequences=20"):  # the stub payload keeps no paths
        dataset = data.synthesize(config, progress=False)
    assert grown == [2, 2, 2, 2, 2]
    assert dataset.stats["anchor_rounds"] == 5 and len(dataset.anchors) == 10
    grown.clear()
    monkeypatch.setattr(data.rollout, "tree_paths", lambda tree: [])  # never enough: stops at the cap
    with pytest.warns(RuntimeWarning):
        data.synthesize(dataclasses.replace(config, seed=1), progress=False)
    assert grown == [2] * 6


def test_synthetic_data_config_checks_the_minimum():
    from hoi_tutorial.nifty import data

    with pytest.raises(ValueError, match="min_sequences"):
        data.synthetic_data_config("sit", min_sequences=0)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_the_reverse_prior_trains_on_cuda(tmp_cache):
    # the state helpers' ground-plane masks are made on the batch's device (own-prediction steps use them)
    clips = [generate_clip("walk", seed=0), generate_clip("sit", seed=0)]
    config = mp.prior_config(steps=6, width=32, latent=4, batch_size=8)
    model, result = mp.train_reverse_prior(clips, config, device="cuda", progress=False)
    assert next(model.parameters()).device.type == "cuda" and np.isfinite(result.losses).all()
