"""The capsule body: index-stable vertices, the toe vertex, and the exact body SDF."""
import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from hoi_tutorial.world import body as B
from hoi_tutorial.world import skeleton as S
from hoi_tutorial.world.kinematics import forward_kinematics
from hoi_tutorial.world.mocap.poses import standing_pose
from hoi_tutorial.world.motion import Motion
from hoi_tutorial.world.rotations import axis_angle_to_matrix, rotation_about_z

seeds = st.integers(0, 2**31 - 1)


def _standing(betas=None, heading=0.0, position=(0.0, 0.0)):
    local, root = standing_pose(betas, position=position, heading=heading)
    return forward_kinematics(local, root, S.bone_offsets(betas))


def _t_pose(betas=None):
    return torch.eye(3).repeat(S.NUM_JOINTS, 1, 1), S.rest_joint_positions(betas)


def _random_pose(seed, batch=2):
    gen = torch.Generator().manual_seed(seed)
    local = axis_angle_to_matrix(0.6 * torch.randn(batch, S.NUM_JOINTS, 3, generator=gen, dtype=torch.float64))
    root = torch.randn(batch, 3, generator=gen, dtype=torch.float64)
    betas = torch.randn(S.NUM_BETAS, generator=gen, dtype=torch.float64)
    glob, pos = forward_kinematics(local, root, S.bone_offsets(betas))
    return glob, pos, betas, gen


def test_capsule_table_is_consistent():
    assert B.NUM_CAPSULES == len(B.CAPSULE_NAMES) == len(B.CAPSULE_JOINTS) == len(B.CAPSULE_PARTS)
    a, b, r = B.capsule_local_segments()
    assert a.shape == b.shape == (B.NUM_CAPSULES, 3) and r.shape == (B.NUM_CAPSULES,)
    radius = dict(zip(B.CAPSULE_NAMES, r.tolist()))
    assert radius["right_foot"] == pytest.approx(0.03)
    assert 0.06 < radius["right_thigh"] < 0.09 and 0.04 < radius["right_shin"] < 0.06
    assert 0.10 <= radius["lower_torso"] <= 0.14
    # Limb capsules run from their joint to the child joint.
    off = S.bone_offsets()
    thigh = B.CAPSULE_NAMES.index("right_thigh")
    torch.testing.assert_close(b[thigh], off[S.joint_index("right_knee")])


def test_girth_betas_scale_radii_in_the_documented_direction():
    base = B.capsule_local_segments()[2]
    limb, torso = torch.zeros(S.NUM_BETAS), torch.zeros(S.NUM_BETAS)
    limb[6], torso[9] = 1.0, 1.0
    thigh, chest = B.CAPSULE_NAMES.index("left_thigh"), B.CAPSULE_NAMES.index("upper_torso")
    r_limb, r_torso = B.capsule_local_segments(limb)[2], B.capsule_local_segments(torso)[2]
    assert r_limb[thigh] > base[thigh] and r_limb[chest] == pytest.approx(float(base[chest]))
    assert r_torso[chest] > base[chest] and r_torso[thigh] == pytest.approx(float(base[thigh]))


def test_vertex_set_is_fixed_and_index_stable():
    assert 300 <= B.NUM_VERTICES <= 600
    assert B.VERTEX_CAPSULE.shape == B.VERTEX_PART.shape == (B.NUM_VERTICES,)
    assert set(np.unique(B.VERTEX_CAPSULE)) == set(range(B.NUM_CAPSULES))
    assert B.VERTEX_PART.max() < len(B.PART_NAMES)
    thin = torch.zeros(S.NUM_BETAS)
    big = torch.zeros(S.NUM_BETAS)
    big[[0, 6, 9]] = 1.5
    v_thin = B.body_vertices(*_t_pose(thin), thin)
    v_big = B.body_vertices(*_t_pose(big), big)
    assert v_thin.shape == v_big.shape == (B.NUM_VERTICES, 3)
    # Same index, same body spot: vertices move a little with the shape, never across the body.
    assert float((v_big - v_thin).norm(dim=-1).max()) < 0.15
    # Each vertex lies on its own capsule's surface for any shape.
    for betas, verts in ((thin, v_thin), (big, v_big)):
        a, b, r = B.capsule_segments(*_t_pose(betas), betas)
        cap = torch.as_tensor(B.VERTEX_CAPSULE)
        d = B._segment_distance(verts[:, None], a[cap][:, None], b[cap][:, None])[:, 0] - r[cap]
        assert float(d.abs().max()) < 1e-5


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_toe_and_heel_vertices_touch_the_ground_when_standing(seed):
    betas = None if seed == 0 else torch.empty(S.NUM_BETAS).uniform_(-2, 2, generator=torch.Generator().manual_seed(seed))
    glob, pos = _standing(betas, heading=0.7 * seed, position=(seed, -seed))
    verts = B.body_vertices(glob, pos, betas)
    for index in (B.RIGHT_TOE_VERTEX, B.LEFT_TOE_VERTEX, B.RIGHT_HEEL_VERTEX, B.LEFT_HEEL_VERTEX):
        assert abs(float(verts[index, 2])) < 0.005
    assert float(verts[:, 2].min()) > -0.005
    # No capsule dips below the ground (the feet rest on it).
    a, b, r = B.capsule_segments(glob, pos, betas)
    assert float((torch.minimum(a[:, 2], b[:, 2]) - r).min()) > -1e-4
    # The toe vertex is in front of the foot joint, the heel vertex behind the ankle.
    forward = rotation_about_z(torch.tensor(0.7 * seed)) @ torch.tensor([0.0, 1.0, 0.0])
    for toe, heel, side in ((B.RIGHT_TOE_VERTEX, B.RIGHT_HEEL_VERTEX, "right"), (B.LEFT_TOE_VERTEX, B.LEFT_HEEL_VERTEX, "left")):
        assert float((verts[toe] - pos[S.joint_index(f"{side}_foot")]) @ forward) > 0.02
        assert float((verts[heel] - pos[S.joint_index(f"{side}_ankle")]) @ forward) < -0.02


def test_toes_bend_with_the_foot_joint_and_the_heel_does_not():
    local, root = standing_pose()
    bent = local.clone()
    # Toe break: the toes pitch up about the ball of the foot (+X is the right-handed pitch axis).
    bent[S.joint_index("right_foot")] = axis_angle_to_matrix(torch.tensor([0.5, 0.0, 0.0]))
    offsets = S.bone_offsets()
    flat = B.body_vertices(*forward_kinematics(local, root, offsets))
    broken = B.body_vertices(*forward_kinematics(bent, root, offsets))
    assert float(broken[B.RIGHT_TOE_VERTEX, 2]) > 0.01
    torch.testing.assert_close(broken[B.RIGHT_HEEL_VERTEX], flat[B.RIGHT_HEEL_VERTEX])
    torch.testing.assert_close(broken[B.LEFT_TOE_VERTEX], flat[B.LEFT_TOE_VERTEX])


def test_hand_vertices_are_on_the_palm_side():
    verts = B.body_vertices(*_t_pose())
    for side in ("left", "right"):
        ids = B.HAND_VERTICES[side]
        assert len(ids) >= 4
        assert np.all(B.VERTEX_CAPSULE[ids] == B.CAPSULE_NAMES.index(f"{side}_hand"))
        # T-pose palms face down: palm vertices are below the hand's axis.
        wrist = S.rest_joint_positions()[S.joint_index(f"{side}_wrist")]
        assert torch.all(verts[ids, 2] < wrist[2])


def test_sdf_sign_at_torso_joints_and_far_away():
    glob, pos = _standing()
    torso = [S.joint_index(n) for n in ("pelvis", "spine1", "spine2", "spine3", "neck", "head")]
    assert torch.all(B.body_sdf(pos[torso], glob, pos) < -0.03)
    pelvis = pos[0]
    away = pelvis + torch.tensor([[0.0, 0.5, 0.0], [0.0, -0.5, 0.0], [0.0, 0.0, 1.3], [0.8, 0.0, 0.0]])
    assert torch.all(B.body_sdf(away, glob, pos) > 0.3)


def test_sdf_is_zero_at_the_surface_vertices_in_the_t_pose():
    glob, pos = _t_pose()
    sdf = B.body_sdf(B.body_vertices(glob, pos), glob, pos)
    assert float(sdf.abs().max()) < 1e-3


@settings(max_examples=10)
@given(seeds)
def test_sdf_is_one_lipschitz_with_unit_gradients(seed):
    glob, pos, betas, gen = _random_pose(seed)
    p = (pos[:, :1] + 0.6 * torch.randn(2, 200, 3, generator=gen, dtype=torch.float64)).requires_grad_(True)
    q = p.detach() + 0.05 * torch.randn(2, 200, 3, generator=gen, dtype=torch.float64)
    sdf_p = B.body_sdf(p, glob, pos, betas)
    sdf_q = B.body_sdf(q, glob, pos, betas)
    assert sdf_p.shape == (2, 200)
    assert torch.all((sdf_p - sdf_q).abs() <= (p - q).norm(dim=-1) + 1e-9)
    (grad,) = torch.autograd.grad(sdf_p.sum(), p)
    torch.testing.assert_close(grad.norm(dim=-1), torch.ones(2, 200, dtype=torch.float64), atol=1e-6, rtol=1e-5)


def test_sdf_agrees_with_trimesh_containment():
    glob, pos = _standing(heading=0.4)
    mesh = B.body_mesh(glob, pos, sections=32)
    rng = np.random.default_rng(0)
    points = rng.uniform(mesh.bounds[0] - 0.05, mesh.bounds[1] + 0.05, size=(3000, 3))
    # Add points near the body so both signs are well represented.
    verts = B.body_vertices(glob, pos).numpy()
    points = np.concatenate([points, verts[rng.integers(0, len(verts), 1000)] + rng.normal(0, 0.03, (1000, 3))])
    sdf = B.body_sdf(torch.tensor(points), glob, pos).numpy()
    inside = np.zeros(len(points), dtype=bool)
    parts = mesh.split(only_watertight=False)
    assert len(parts) == B.NUM_CAPSULES
    for part in parts:
        inside |= part.contains(points)
    clear = np.abs(sdf) > 0.002
    assert clear.sum() > 3000 and inside[clear].sum() > 200
    np.testing.assert_array_equal(sdf[clear] < 0, inside[clear])


def test_sdf_gradients_are_finite_on_a_segment_and_for_the_pose():
    glob, pos, betas, _ = _random_pose(3, batch=1)
    glob, pos = glob[0].requires_grad_(True), pos[0].requires_grad_(True)
    # Joint centres lie exactly on capsule segments (the distance's kink).
    points = pos.detach()[[0, 4, 5, 18]].clone().requires_grad_(True)
    B.body_sdf(points, glob, pos, betas).sum().backward()
    for t in (points, glob, pos):
        assert torch.isfinite(t.grad).all()
    assert float(pos.grad.abs().sum()) > 0


@settings(max_examples=10)
@given(seeds, st.floats(-3.1, 3.1))
def test_sdf_is_equivariant_under_rigid_motion(seed, yaw):
    glob, pos, betas, gen = _random_pose(seed)
    rot = axis_angle_to_matrix(torch.randn(3, generator=gen, dtype=torch.float64)) @ rotation_about_z(torch.tensor(yaw, dtype=torch.float64))
    shift = torch.randn(3, generator=gen, dtype=torch.float64)
    points = pos[:, :1] + 0.5 * torch.randn(2, 100, 3, generator=gen, dtype=torch.float64)
    before = B.body_sdf(points, glob, pos, betas)
    after = B.body_sdf(points @ rot.T + shift, rot @ glob, pos @ rot.T + shift, betas)
    torch.testing.assert_close(after, before, atol=1e-9, rtol=1e-12)
    v_before = B.body_vertices(glob, pos, betas)
    v_after = B.body_vertices(rot @ glob, pos @ rot.T + shift, betas)
    torch.testing.assert_close(v_after, v_before @ rot.T + shift, atol=1e-9, rtol=1e-12)


def test_sdf_broadcasts_object_points_over_a_clip():
    glob, pos, betas, gen = _random_pose(5, batch=4)
    points = torch.randn(50, 3, generator=gen, dtype=torch.float64)
    sdf = B.body_sdf(points, glob, pos, betas)
    assert sdf.shape == (4, 50)
    torch.testing.assert_close(sdf[2], B.body_sdf(points, glob[2], pos[2], betas))


def test_motion_helpers():
    local, root = standing_pose()
    T = 5
    root = root.repeat(T, 1) + torch.linspace(0, 0.4, T)[:, None] * torch.tensor([0.0, 1.0, 0.0])
    motion = Motion(local.repeat(T, 1, 1, 1), root)
    verts = B.body_from_motion(motion)
    assert verts.shape == (T, B.NUM_VERTICES, 3)
    assert B.body_from_motion(motion, frames=[0, 4]).shape == (2, B.NUM_VERTICES, 3)
    toes = B.toe_positions(motion)
    torch.testing.assert_close(toes, verts[:, B.RIGHT_TOE_VERTEX])
    torch.testing.assert_close(B.toe_positions(motion, "left"), verts[:, B.LEFT_TOE_VERTEX])
    with pytest.raises(ValueError, match="side"):
        B.toe_positions(motion, "middle")
    # A floor 1 cm thick as the object: exactly the vertices at the bottom of the feet touch it.
    contact = B.object_contact_vertices(verts[0], lambda p: p[:, 2] - 0.01)
    assert contact.dtype == bool and contact.shape == (B.NUM_VERTICES,)
    parts = {B.PART_NAMES[i] for i in np.unique(B.VERTEX_PART[contact])}
    assert contact[B.RIGHT_TOE_VERTEX] and parts == {"left_foot", "right_foot"}
    assert B.object_contact_vertices(verts, lambda p: p[:, 2] - 0.01).shape == (T, B.NUM_VERTICES)


def test_numpy_inputs_are_accepted():
    glob, pos = _t_pose()
    points = np.array([[0.0, 0.0, 1.0], [3.0, 0.0, 1.0]])
    sdf = B.body_sdf(points, glob.numpy(), pos.numpy())
    assert isinstance(sdf, torch.Tensor) and sdf.shape == (2,)
    assert float(sdf[0]) < 0 < float(sdf[1])
    assert B.body_vertices(glob.numpy(), pos.numpy(), np.zeros(10)).shape == (B.NUM_VERTICES, 3)


def test_bad_inputs_raise():
    glob, pos = _t_pose()
    with pytest.raises(ValueError, match="expected shape"):
        B.body_sdf(torch.zeros(10, 2), glob, pos)
    with pytest.raises(ValueError, match="expected shape"):
        B.body_vertices(glob[:21], pos)
    with pytest.raises(ValueError, match="expected shape"):
        B.body_vertices(glob, pos, torch.zeros(9))
    with pytest.raises(ValueError, match="batch shape"):
        B.capsule_segments(glob.expand(2, -1, -1, -1), pos)
