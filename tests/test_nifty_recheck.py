"""The independent PruneCheck re-check of synthetic sequences (``nifty.data.recheck_sequences``)."""
import pytest
import torch

from hoi_tutorial.nifty.anchors import Anchor
from hoi_tutorial.nifty.data import SyntheticDataset, recheck_failures, recheck_sequences, synthetic_data_config
from hoi_tutorial.nifty.motion_prior import PoseTrack
from hoi_tutorial.nifty.rollout import InteractionSequence
from hoi_tutorial.world.mocap import generate_clip
from hoi_tutorial.world.motion import Motion
from hoi_tutorial.world.objects import make_object

F = 30  # frames per node (NIFTY: one second)


@pytest.fixture(scope="module")
def case():
    """A sit clip cut to end in its anchor with two nodes before it, its chair and anchor."""
    obj = make_object("chair", seed=0).placed(0.5, -1.0, 0.3)
    clip = generate_clip("sit", seed=0, obj=obj)
    a = int(clip.meta["anchor_frame"])
    pose = PoseTrack(clip.local_rotations[a], clip.root_position[a], clip.joints[a])
    nxt = PoseTrack(clip.local_rotations[a + 1], clip.root_position[a + 1], clip.joints[a + 1])
    anchor = Anchor("sit", pose, nxt, clip.betas, 0, obj, clip)
    motion = clip.slice(a - 2 * F, a + 1)  # 1 + 2F frames, real time
    config = synthetic_data_config("sit", "toy")
    return config, anchor, obj, motion


def _sunk_first_node(motion: Motion) -> Motion:
    """The same motion with its first second (the deepest node) pushed 20 cm into the floor."""
    root = motion.root_position.clone()
    root[:F, 2] -= 0.2
    return Motion(motion.local_rotations, root, motion.betas, motion.fps)


def test_recheck_flags_only_the_sequences_with_a_bad_node(case):
    config, anchor, obj, motion = case
    good = InteractionSequence(motion, obj, anchor)
    bad = InteractionSequence(_sunk_first_node(motion), obj, anchor)
    # The bad sequence shares its anchor-side node with the good one: shared nodes are checked once,
    # and each sequence still gets the verdict of its own nodes.
    short = InteractionSequence(motion.slice(F, 2 * F + 1), obj, anchor)
    dataset = SyntheticDataset(config, [anchor], [good, bad, short], [], [], [], {})
    assert recheck_sequences(dataset).tolist() == [True, False, True]
    assert recheck_sequences(dataset, [bad]).tolist() == [False]
    assert recheck_sequences(dataset, []).shape == (0,)
    # The reasons: only the sunk node fails, and only by sinking.
    failures = recheck_failures(dataset)
    assert failures["sinking"].tolist() == [False, True, False]
    assert not any(flags.any() for reason, flags in failures.items() if reason != "sinking")


def test_recheck_rejects_a_length_that_is_not_whole_nodes(case):
    config, anchor, obj, motion = case
    ragged = InteractionSequence(motion.slice(0, F + 5), obj, anchor)
    dataset = SyntheticDataset(config, [anchor], [ragged], [], [], [], {})
    with pytest.raises(ValueError, match="depth"):
        recheck_sequences(dataset)
