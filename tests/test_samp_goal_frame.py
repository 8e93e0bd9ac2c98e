"""SAMP's goal features as the run-time loop computes them (``samp.goal_frame``): complex ground
vectors checked against rotation matrices, the fused step against the two public steps."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hoi_tutorial.samp import goal_frame as gf, motion_data as md, runtime as rt
from hoi_tutorial.world.features import SAMP_STATE_LAYOUT


def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def test_entering_a_frame_is_rotating_by_minus_its_heading():
    for heading in (0.0, 0.7, -2.4, math.pi):
        forward = torch.tensor([-math.sin(heading), math.cos(heading)])  # heading 0 faces +Y
        factor = gf.entering_frame(gf.as_complex(forward))
        vector = np.array([0.3, -1.2])
        expected = _rotation(-heading) @ vector
        turned = torch.view_as_real(gf.as_complex(torch.tensor(vector, dtype=torch.float32)) * factor)
        np.testing.assert_allclose(turned.numpy(), expected, atol=1e-6)
    # a zero facing has heading 0: the identity, as atan2(0, 0) = 0 gives
    assert complex(gf.entering_frame(torch.zeros((), dtype=torch.complex64))) == 1


def test_as_complex_reads_slices_at_any_offset():
    y = torch.arange(12.0).reshape(2, 6)
    odd = y[:, 3:5]  # starts at an odd element: no complex view of it exists
    np.testing.assert_array_equal(gf.as_complex(odd).numpy(), np.array([3 + 4j, 9 + 10j]))
    assert gf.as_complex(y[:, :2]).data_ptr() == y.data_ptr()  # a view where the memory allows


def test_root_update_and_voxels_match_rotation_matrices():
    generator = torch.Generator().manual_seed(0)
    roots = torch.randn(5, 3, generator=generator)
    step = torch.randn(5, 3, generator=generator) * 0.1
    moved = md.apply_root_displacement(roots, step)
    for b in range(5):
        expected = roots[b, :2].numpy() + _rotation(float(roots[b, 2])) @ step[b, :2].numpy()
        np.testing.assert_allclose(moved[b, :2].numpy(), expected, atol=1e-5)
    torch.testing.assert_close(md.root_displacement(torch.stack([roots, moved], 1))[:, 0], step, atol=1e-5, rtol=0)
    centres, occupancy = torch.randn(4, 7, 3, generator=generator), torch.rand(4, 7, generator=generator)
    local = md.voxels_in_root_frame(centres, occupancy, roots[:4]).reshape(4, 7, 4)
    for b in range(4):
        offset = (centres[b, :, :2] - roots[b, :2]).numpy()
        np.testing.assert_allclose(local[b, :, :2].numpy(), offset @ _rotation(-float(roots[b, 2])).T, atol=1e-5)
    torch.testing.assert_close(local[..., 2], centres[..., 2])
    torch.testing.assert_close(local[..., 3], occupancy)


def _sit_clip():
    clip, _ = md.make_clip("sit", 3)
    positions, directions, actions = md.clip_goals(clip)
    states, roots = md.clip_states(clip)
    return (states.float(), roots.float(), torch.as_tensor(positions).float(), torch.as_tensor(directions).float(),
            torch.as_tensor(actions))


def test_the_fused_step_is_the_correction_then_the_goal_features():
    states, roots, goal_p, goal_d, actions = _sit_clip()
    shifted = states.clone()  # a goal-frame prediction that disagrees, so that the correction acts
    shifted[:, SAMP_STATE_LAYOUT["goal_trajectory_positions"]] += 0.1
    two_steps = rt.with_goal(rt.correct_towards_goal(shifted, roots, goal_p, goal_d), roots, goal_p, goal_d, actions)
    goals = rt.GoalSequence(goal_p[:, None], goal_d[:, None], actions[:, None], torch.zeros(len(roots), 1),
                            torch.ones(len(roots), dtype=torch.int64))
    index = torch.zeros(len(roots), dtype=torch.int64)
    seen = goals.seen_from(index, roots)
    fused = gf.recomputed_state(shifted, goal=seen, correct_towards=seen)
    torch.testing.assert_close(fused, two_steps, atol=1e-5, rtol=1e-5)
    assert (fused - shifted)[:, SAMP_STATE_LAYOUT["trajectory_positions"]].abs().max() > 0.02  # it did act


def test_far_from_the_goal_the_correction_only_normalises_the_facings():
    states, roots, goal_p, goal_d, actions = _sit_clip()
    far = goal_p.clone()
    far[:, 0] += 5.0  # every sample at least ~3.5 m from it: weights below 0.75^(100 * 3.5²)
    scaled = states.clone()
    scaled[:, SAMP_STATE_LAYOUT["trajectory_directions"]] *= 1.3
    scaled[:, SAMP_STATE_LAYOUT["goal_trajectory_positions"]] += 0.5
    out = rt.correct_towards_goal(scaled, roots, far, goal_d)
    torch.testing.assert_close(out[:, SAMP_STATE_LAYOUT["trajectory_positions"]],
                               scaled[:, SAMP_STATE_LAYOUT["trajectory_positions"]], atol=0, rtol=0)
    torch.testing.assert_close(out[:, SAMP_STATE_LAYOUT["trajectory_directions"]],
                               states[:, SAMP_STATE_LAYOUT["trajectory_directions"]], atol=1e-5, rtol=1e-5)


def test_goal_features_check_their_inputs():
    states, roots, goal_p, goal_d, actions = _sit_clip()
    with pytest.raises(ValueError, match="goal_position"):
        rt.with_goal(states, roots, goal_p[:, :2], goal_d, actions)
    with pytest.raises(ValueError, match="trajectory_positions"):
        gf.goal_features(states[:, :10], states[:, :14], goal_p, goal_d, actions)
