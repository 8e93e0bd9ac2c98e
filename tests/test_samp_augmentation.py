"""SAMP's data augmentation (§4.2, Supp. F): contacts projected onto a new object and kept by IK."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from hoi_tutorial.samp import augmentation as aug, motion_data as md
from hoi_tutorial.world.motion import CONTACT_JOINTS
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.skeleton import JOINT_NAMES, PARENTS

CASES = [("sit", 3), ("sit", 4), ("lie", 5)]


def _switched(kind, seed):
    motion, obj = md.make_clip(kind, seed)
    new = make_object(obj.category, 99 + seed).with_pose(obj.pose)
    return motion, obj, new


def test_closest_surface_point_lands_on_the_surface():
    obj = make_object("stool", 1).placed(0.5, -0.2, 0.3)
    rng = np.random.default_rng(0)
    points = obj.translation + rng.uniform(-0.6, 0.6, size=(64, 3)) + np.array([0.0, 0.0, 0.5])
    closest = aug.closest_surface_point(obj, points)
    np.testing.assert_allclose(obj.sdf(closest), 0.0, atol=1e-4)
    outside = obj.sdf(points) > 0
    # outside the object the distance to the closest point is the signed distance itself
    np.testing.assert_allclose(np.linalg.norm(points - closest, axis=1)[outside], obj.sdf(points)[outside], atol=1e-3)


@pytest.mark.parametrize("kind, seed", CASES)
def test_augmentation_keeps_the_contacts_on_the_new_object(kind, seed):
    motion, obj, new = _switched(kind, seed)
    out = aug.augment_clip(motion, obj, new)
    before, after = motion.joints.double().numpy(), out.joints.double().numpy()
    contacts = np.asarray(motion.contacts)
    pelvis = np.flatnonzero(contacts[:, CONTACT_JOINTS.index("pelvis")])
    assert len(pelvis) > 0
    # the pelvis keeps its distance to the seat: within 5 mm on the new object
    kept = np.abs(new.sdf(after[pelvis, 0]) - obj.sdf(before[pelvis, 0]))
    assert kept.max() < 0.005
    # feet on the ground stay where they were (ankles, the IK chain's end)
    for name, ankle in (("left_foot", JOINT_NAMES.index("left_ankle")), ("right_foot", JOINT_NAMES.index("right_ankle"))):
        frames = np.flatnonzero(contacts[:, CONTACT_JOINTS.index(name)])
        assert np.linalg.norm(after[frames, ankle] - before[frames, ankle], axis=1).max() < 0.005
    # bones keep their lengths, and the start of the approach is untouched
    bones, parents = list(range(1, 22)), [PARENTS[j] for j in range(1, 22)]
    np.testing.assert_allclose(np.linalg.norm(after[:, bones] - after[:, parents], axis=-1),
                               np.linalg.norm(before[:, bones] - before[:, parents], axis=-1), atol=1e-4)
    np.testing.assert_allclose(after[0], before[0], atol=1e-6)
    assert out.meta["augmented_from"] == obj.category and len(out) == len(motion)


def test_the_original_clip_does_not_fit_the_new_object_and_the_same_object_changes_nothing():
    worst = 0.0
    for kind, seed in CASES:
        motion, obj, new = _switched(kind, seed)
        J = motion.joints.double().numpy()
        pelvis = np.flatnonzero(np.asarray(motion.contacts)[:, 0])
        worst = max(worst, float(np.abs(new.sdf(J[pelvis, 0]) - obj.sdf(J[pelvis, 0])).max()))
        same = aug.augment_clip(motion, obj, obj)
        torch.testing.assert_close(same.joints, motion.joints, atol=1e-4, rtol=1e-5)
    assert worst > 0.02  # without augmentation the seated pelvis floats above or sinks into a new seat


def test_augmentation_errors_are_clear():
    motion, obj, new = _switched("sit", 3)
    with pytest.raises(ValueError, match="contact labels"):
        aug.augment_clip(dataclasses.replace(motion, contacts=None), obj, new)
    with pytest.raises(TypeError, match="new_obj: expected a ToyObject"):
        aug.augment_clip(motion, obj, "sofa")
    with pytest.raises(ValueError, match="blend"):
        aug.augment_clip(motion, obj, new, blend=-1.0)


def test_a_contact_point_under_a_higher_thin_seat_lands_on_its_top():
    # a captured seat 0.44 m high moved onto a chair whose 0.49 m seat is thinner than the difference:
    # the old contact point lies under the new seat, whose nearest face is its underside
    seed = next(s for s in range(100, 200) if md.make_clip("sit", s)[1].category == "chair")
    motion, obj = md.make_clip("sit", seed)
    new = make_object("chair", 2002).with_pose(obj.pose)
    assert new.params["seat_height"] - obj.params["seat_height"] > new.params["seat_thickness"]
    out = aug.augment_clip(motion, obj, new)
    pelvis = np.flatnonzero(np.asarray(motion.contacts)[:, 0])
    before, after = motion.joints.double().numpy()[pelvis, 0], out.joints.double().numpy()[pelvis, 0]
    np.testing.assert_allclose(new.sdf(after), obj.sdf(before), atol=0.005)
    assert (after[:, 2] - before[:, 2]).mean() > 0.03  # raised with the seat, not lowered under it


@pytest.mark.parametrize("kind, seed", CASES)
def test_an_augmented_clip_heads_for_the_goal_on_the_new_object(kind, seed):
    motion, obj, new = _switched(kind, seed)
    out = aug.augment_clip(motion, obj, new)
    key = "sit_goal" if kind == "sit" else "lie_goal"
    old_goal = np.asarray(motion.meta[key]["position"])
    new_goal = np.asarray(out.meta[key]["position"])
    # the goal keeps its distance to the seat, now the new object's, and the seated pelvis its offset to the goal
    assert abs(float(new.sdf(new_goal[None])[0]) - float(obj.sdf(old_goal[None])[0])) < 0.005
    assert abs(float(new.sdf(old_goal[None])[0]) - float(obj.sdf(old_goal[None])[0])) > 0.02  # the old one is off it
    np.testing.assert_allclose(out.joints[-1, 0].double().numpy() - new_goal,
                               motion.joints[-1, 0].double().numpy() - old_goal, atol=1e-5)
    positions, _, _ = md.clip_goals(out)
    np.testing.assert_allclose(positions[0], new_goal)
    np.testing.assert_allclose(out.meta[key]["direction"], motion.meta[key]["direction"])
    np.testing.assert_allclose(motion.meta[key]["position"], old_goal)  # the original clip is left as it was
