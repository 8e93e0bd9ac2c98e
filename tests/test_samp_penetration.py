"""The body's penetration into a room (samp.penetration): capsules against objects, the target apart."""
import numpy as np
import pytest
import torch

from hoi_tutorial.samp import penetration, pipeline
from hoi_tutorial.world.body import capsule_segments
from hoi_tutorial.world.features import SAMP_STATE_LAYOUT, SAMP_STATE_SIZE
from hoi_tutorial.world.kinematics import forward_kinematics
from hoi_tutorial.world.mocap.poses import standing_pose
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.rotations import matrix_to_rotation_6d
from hoi_tutorial.world.scenes import Room


def _walk(xs, y=3.0, heading=-np.pi / 2):
    """A standing body carried along x at height y: (global rotations (T, 22, 3, 3), joints (T, 22, 3))."""
    poses = [forward_kinematics(*(t[None] for t in standing_pose(position=(x, y), heading=heading))) for x in xs]
    return torch.cat([g for g, _ in poses]).double(), torch.cat([j for _, j in poses]).double()


@pytest.fixture(scope="module")
def table_room():
    table = make_object("table", 0).placed(3.0, 3.0, 0.0)
    chair = make_object("chair", 0).placed(1.0, 5.0, 0.0)
    return Room(np.array([6.0, 6.0]), [chair, table], target_index=0)


def test_a_body_walked_through_a_table_penetrates_on_every_frame_where_joint_centres_do_not(table_room):
    xs = np.linspace(1.0, 5.0, 41)
    rotations, joints = _walk(xs)
    depth = penetration.body_depths(table_room, rotations, joints)
    table = table_room.objects[1]
    over = (xs > table.bounds[0, 0]) & (xs < table.bounds[1, 0])   # the pelvis above the table's footprint
    assert over.sum() >= 5
    assert (depth["clutter"][over] > 0.02).all()                  # the body: every frame over the table
    joint_centres = pipeline.penetrating_frames(table_room, joints.numpy())
    assert joint_centres[over].sum() < over.sum()                  # the joint centres miss frames (here all)
    assert (depth["clutter"][:3] < 0).all()                        # clear of everything at the start
    shares = penetration.penetration_shares(table_room, rotations, joints)
    assert shares["clutter"] >= over.mean() and shares["target"] == 0.0


def test_a_capsule_depth_is_its_radius_less_the_signed_distance_of_its_segment(table_room):
    rotations, joints = _walk([3.0])
    a, b, radius = capsule_segments(rotations, joints)
    t = torch.linspace(0, 1, penetration.CAPSULE_SAMPLES, dtype=a.dtype)
    points = (a[..., None, :] + t[:, None] * (b - a)[..., None, :]).numpy()
    table = table_room.objects[1]
    by_hand = (radius.numpy() - table.sdf(points).min(axis=-1)).max()
    walls = (radius.numpy() - np.minimum.reduce([points[..., 0], 6 - points[..., 0], points[..., 1],
                                                 6 - points[..., 1]]).min(axis=-1)).max()
    np.testing.assert_allclose(penetration.body_depths(table_room, rotations, joints)["clutter"],
                               [max(by_hand, walls)], rtol=1e-9)


def test_the_target_is_measured_apart(table_room):
    chair = table_room.objects[0]
    rotations, joints = _walk([chair.pose[0, 3]], y=chair.pose[1, 3])  # standing inside the chair
    depth = penetration.body_depths(table_room, rotations, joints)
    assert depth["target"][0] > 0.05 and depth["clutter"][0] < 0.02
    with pytest.raises(ValueError, match="tolerance"):
        penetration.penetration_shares(table_room, rotations, joints, tolerance=-1.0)


def test_rollout_pose_places_the_states_pose_at_the_root():
    local, root = standing_pose(heading=0.0)
    rotations, joints = forward_kinematics(local[None], root[None])
    # SAMP's j^p and j^r are in the root frame; a root at (1, 2) turned by 90° moves and turns them
    state = torch.zeros(1, SAMP_STATE_SIZE)
    state[0, SAMP_STATE_LAYOUT["joint_positions"]] = joints[0].reshape(-1)
    state[0, SAMP_STATE_LAYOUT["joint_rotations"]] = matrix_to_rotation_6d(rotations[0]).reshape(-1)
    g, p = penetration.rollout_pose(state, torch.tensor([[1.0, 2.0, np.pi / 2]]))
    expected_rot, expected_pos = forward_kinematics(*(t[None] for t in standing_pose(position=(1.0, 2.0),
                                                                                      heading=np.pi / 2)))
    expected_pos[..., 2] = joints[..., 2]
    torch.testing.assert_close(p.float(), expected_pos, atol=1e-4, rtol=0)
    torch.testing.assert_close(g.float(), expected_rot, atol=1e-4, rtol=0)
