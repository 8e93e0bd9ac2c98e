"""The NSM-like model's environment sensor (SAMP Table 5): lattice look-up, layout, invariance, the model kind."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from scipy.spatial import cKDTree

from hoi_tutorial.samp import core, motion_data as md, motionnet as mn, sensor
from hoi_tutorial.world.objects import make_object

pytestmark = pytest.mark.usefixtures("one_cpu_thread")


def _cells(obj):
    centres, occupancy = md.object_voxel_cells(obj)
    return torch.as_tensor(centres), torch.as_tensor(occupancy)


def test_the_lookup_returns_an_objects_own_cells():
    centres, occupancy = _cells(make_object("armchair", seed=4).placed(0.7, -1.1, 0.6))
    sensed = sensor.lattice_occupancy(centres[None], centres[None], occupancy[None])
    torch.testing.assert_close(sensed[0], occupancy, atol=1e-6, rtol=1e-5)
    assert float(sensor.lattice_occupancy(torch.tensor([[[9.0, 9.0, 0.5]]]), centres[None], occupancy[None])) == 0.0


def test_the_lookup_is_the_nearest_cell_found_by_a_kd_tree():
    obj = make_object("sofa", seed=1).placed(-0.4, 0.9, -1.3)
    centres, occupancy = _cells(obj)
    rng = np.random.default_rng(0)
    lo, hi = centres.numpy().min(0), centres.numpy().max(0)
    points = rng.uniform(lo - 0.3, hi + 0.3, size=(400, 3))
    ours = sensor.lattice_occupancy(torch.as_tensor(points, dtype=torch.float32)[None], centres[None],
                                    occupancy[None])[0].numpy()
    # reference: the nearest cell centre (scipy), counted only where the point lies within the grid's box
    _, nearest = cKDTree(centres.numpy()).query(points)
    canonical = (points - obj.translation) @ obj.rotation  # object frame: its grid is axis-aligned there
    c_lo, c_hi = obj.canonical_bounds
    inside = np.all((canonical >= c_lo - 1e-6) & (canonical <= c_hi + 1e-6), axis=1)
    reference = np.where(inside, occupancy.numpy()[nearest], 0.0)
    assert inside.sum() > 50 and (~inside).sum() > 50
    assert np.mean(np.abs(ours - reference) < 1e-5) > 0.98  # ties between two cells may round either way


def test_several_objects_are_sensed_together_and_padding_senses_nothing():
    a, b = make_object("chair", seed=0).placed(0.0, 0.0, 0.0), make_object("stool", seed=1).placed(3.0, 0.0, 0.0)
    (ca, oa), (cb, ob) = _cells(a), _cells(b)
    both_c, both_o = torch.cat([ca, cb])[None], torch.cat([oa, ob])[None]
    torch.testing.assert_close(sensor.lattice_occupancy(ca[None], both_c, both_o)[0], oa)
    torch.testing.assert_close(sensor.lattice_occupancy(cb[None], both_c, both_o)[0], ob)
    padded_o = torch.cat([oa, torch.zeros_like(oa)])[None]
    torch.testing.assert_close(sensor.lattice_occupancy(ca[None], torch.cat([ca, ca])[None], padded_o)[0], oa)


def test_sensor_layout_and_an_empty_scene():
    roots = torch.tensor([[0.3, 2.0, 0.4], [-1.5, 0.2, -2.8]])
    empty = sensor.sensor_voxels(None, None, roots)
    assert empty.shape == (2, core.VOXEL_SIZE)
    cells = empty.reshape(2, 512, 4)
    torch.testing.assert_close(cells[0, :, :3], sensor.sensor_cells())
    assert float(cells[..., 3].abs().sum()) == 0.0
    lo = torch.tensor([r[0] for r in sensor.SENSOR_EXTENT])
    hi = torch.tensor([r[1] for r in sensor.SENSOR_EXTENT])
    assert bool(((sensor.sensor_cells() > lo) & (sensor.sensor_cells() < hi)).all())


def test_sensor_reads_the_same_when_character_and_scene_move_together():
    obj = make_object("chair", seed=2).placed(0.8, 0.3, 0.5)
    root = torch.tensor([[0.2, -0.1, 0.3]])
    before = sensor.sensor_voxels(*_cells(obj), root)
    assert float(before.reshape(512, 4)[:, 3].sum()) > 1.0, "the chair stands inside the sensor"
    angle, shift = 1.1, np.array([2.0, -0.5])
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    moved = obj.placed(*(rot @ obj.pose[:2, 3] + shift), float(np.arctan2(obj.pose[1, 0], obj.pose[0, 0]) + angle))
    moved_root = torch.tensor([[*(rot @ root[0, :2].numpy() + shift), float(root[0, 2]) + angle]], dtype=torch.float32)
    torch.testing.assert_close(sensor.sensor_voxels(*_cells(moved), moved_root), before, atol=1e-4, rtol=1e-5)
    # the character turning alone changes what it senses
    turned = root + torch.tensor([[0.0, 0.0, 1.5]])
    assert not torch.allclose(sensor.sensor_voxels(*_cells(obj), turned)[:, 3::4], before[:, 3::4])


def test_bad_input_is_named():
    centres, occupancy = _cells(make_object("chair", seed=0))
    with pytest.raises(ValueError, match="multiple of 512"):
        sensor.lattice_occupancy(centres[None, :100], centres[None, :100], occupancy[None, :100])
    with pytest.raises(ValueError, match="roots"):
        sensor.sensor_voxels(centres, occupancy, torch.zeros(3))


def test_the_nsm_like_model_kind_senses_and_is_deterministic():
    config = mn.motionnet_config("toy", model="nsm", state_hidden=(32, 16, 16), interaction_hidden=(16, 16),
                                 interaction_out=8, gating_hidden=(16, 8), prediction_hidden=32, n_experts=3)
    model = mn.build_motion_model(config)
    assert model.environment_sensor and model.latent == 0
    assert not mn.build_motion_model(mn.motionnet_config("toy", model="moe")).environment_sensor


def test_motion_data_senses_the_clips_object_and_nothing_without_one(tmp_cache):
    config = md.motion_data_config("toy", clips=(("idle", 1), ("sit", 1)), test_clips=1)
    data = md.motion_data(config, "train")
    idle, sit = data.kind_frames("idle")[:5], data.kind_frames("sit")[-5:]
    empty = data.voxels(idle, sensor=True).reshape(5, 512, 4)
    assert float(empty[..., 3].abs().sum()) == 0.0
    obj = data.clip_object[data.frame_clip()[sit[0]]]
    expected = sensor.sensor_voxels(data.voxel_centres[obj], data.voxel_occupancy[obj], data.roots[sit])
    torch.testing.assert_close(data.voxels(sit, sensor=True), expected)
    assert float(expected.reshape(5, 512, 4)[..., 3].sum()) > 0.0, "a seated character senses its seat"
    # the interaction voxels are unchanged by the option's existence
    torch.testing.assert_close(data.voxels(sit), md.voxels_in_root_frame(data.voxel_centres[obj],
                                                                         data.voxel_occupancy[obj], data.roots[sit]))


def test_sensor_points_are_the_cells_carried_by_the_root():
    roots = torch.tensor([[0.3, 2.0, 0.4], [-1.5, 0.2, -2.8]])
    points = sensor.sensor_points(roots)
    back = md.voxels_in_root_frame(points, torch.zeros(2, 512), roots).reshape(2, 512, 4)[..., :3]
    torch.testing.assert_close(back, sensor.sensor_cells().expand(2, -1, -1), atol=1e-5, rtol=1e-5)
