"""Table 4's runs (``choice.pick_and_place.table4``): goals matched by §6.1 in the goal library, never taken from the
clip under test; the keyframe window carried rigidly onto the scene's grasp point; the cuRobo row's straight approach."""
import numpy as np
import pytest
import torch

from hoi_tutorial.choice.controller import phase
from hoi_tutorial.choice.controller.features import WINDOW, WINDOW_OFFSETS, key_joint_transforms
from hoi_tutorial.choice.controller.runtime import KeyJointGoal
from hoi_tutorial.choice.pick_and_place import environment, hand_paths, table4
from hoi_tutorial.choice.planner import interactions, intp
from hoi_tutorial.world import mocap

pytestmark = pytest.mark.usefixtures("one_cpu_thread", "module_cache")
CENTRE = WINDOW // 2


@pytest.fixture(scope="module")
def tiny():
    """A briefly trained PAE and environment autoencoder, a library of eight reaches, two unseen reaches."""
    config = environment.environment_config("toy", n_kitchens=2, channels=(4, 8, 16), steps=150)
    model = environment.trained_environment_autoencoder(config).model
    pae = phase.trained_phase_autoencoder("toy", 0, steps=30).model
    train = mocap.generate_dataset(8, seed=0, kinds=("reach_grasp",))
    library, windows = table4.reach_library(train, model, pae, config)
    test = mocap.generate_dataset(2, seed=10_000, kinds=("reach_grasp",))
    assert {c.meta["hand"] for c in test} <= {c.meta["hand"] for c in train}  # a guard on the data as built
    return config, model, train, library, pae, windows, test


def test_the_matched_goal_phase_never_comes_from_the_clip_under_test(tiny):
    config, model, train, library, pae, windows, test = tiny
    matched = table4.matched_goals([table4.reach_scene(c) for c in test], library, model, windows, config)
    assert set(matched.seeds.tolist()).isdisjoint(int(c.meta["seed"]) for c in test)
    for b, (clip, row) in enumerate(zip(test, matched.rows)):
        source = train[int(row)]
        assert source.meta["hand"] == clip.meta["hand"] and int(source.meta["seed"]) == matched.seeds[b]
        # the phase is the library clip's at its grasp, recomputed here ...
        stored = phase.clip_phase(pae, source).state()[int(source.meta["anchor_frame"])]
        assert torch.allclose(matched.goal.phase[b], stored.float(), atol=1e-6)
        # due as the library clip's grasp was after its start (the rollouts carry the phase by goal_phase_at)
        assert int(matched.goal.due[b]) == int(source.meta["anchor_frame"]) == windows[int(row)].anchor
        # ... and not the clip under test's own
        own = phase.clip_phase(pae, clip).state()[int(clip.meta["anchor_frame"])]
        assert float((matched.goal.phase[b] - own.float()).abs().max()) > 1e-3


def test_a_library_clip_matches_itself_and_keeps_its_window(tiny):
    config, model, train, library, pae, windows, _ = tiny
    clip = train[1]
    matched = table4.matched_goals([table4.reach_scene(clip)], library, model, windows, config)
    assert int(matched.rows[0]) == 1 and matched.distances[0] == pytest.approx(0.0, abs=1e-5)
    positions, rotations = key_joint_transforms(clip)
    frames = (int(clip.meta["anchor_frame"]) + WINDOW_OFFSETS).clamp(0, len(clip) - 1)
    expected = positions[frames].float()
    expected[:, 0, 2] = 0.0
    torch.testing.assert_close(matched.goal.positions[0], expected, atol=1e-4, rtol=0)
    torch.testing.assert_close(matched.goal.rotations[0], rotations[frames].float(), atol=1e-5, rtol=0)


def test_the_window_is_carried_rigidly_onto_the_grasp_point(tiny):
    config, model, _, library, _, windows, test = tiny
    scenes = [table4.reach_scene(c) for c in test]
    matched = table4.matched_goals(scenes, library, model, windows, config)
    for b, (scene, row) in enumerate(zip(scenes, matched.rows)):
        hand = matched.goal.hand[b]
        assert int(hand) == ("left", "right").index(scene.hand)
        np.testing.assert_allclose(matched.goal.positions[b, CENTRE, 2 + hand].numpy(), scene.grasp_point, atol=1e-5)
        assert float(matched.goal.positions[b, :, 0, 2].abs().max()) == 0.0  # the root on the ground
        # the hip and wrists keep their distances (a rigid move); the rotations stay rotations
        source = torch.as_tensor(windows[int(row)].positions[:, 1:])
        carried = matched.goal.positions[b, :, 1:].double()
        torch.testing.assert_close(torch.cdist(carried, carried), torch.cdist(source, source), atol=1e-5, rtol=0)
        R = matched.goal.rotations[b].double()
        torch.testing.assert_close(R @ R.transpose(-1, -2), torch.eye(3, dtype=torch.float64).expand_as(R),
                                   atol=1e-5, rtol=0)


def test_errors_name_what_was_expected(tiny):
    config, model, _, library, _, windows, test = tiny
    with pytest.raises(ValueError, match="reach-and-grasp clip"):
        table4.reach_scene(mocap.generate_clip("walk", seed=0))
    with pytest.raises(ValueError, match="sequence of ReachScene"):
        table4.matched_goals(test, library, model, windows, config)
    with pytest.raises(ValueError, match="windows: expected one window per library row"):
        table4.matched_goals([table4.reach_scene(test[0])], library, model, windows[:1], config)
    with pytest.raises(ValueError, match="clips: expected a positive int"):
        table4.table4_runs(None, clips=0)


def test_the_planned_approach_runs_from_the_window_start_to_the_grasp_point(tiny):
    config, model, _, library, _, windows, test = tiny
    data = interactions.planner_data_config("toy", n_clips=2, n_test_clips=1)
    planner_config = intp.planner_config("toy", width=48, latent=8, steps=200, batch_size=4, fit_steps=20)
    planner = hand_paths.trained_approach_planner(data, planner_config)
    scenes = [table4.reach_scene(c) for c in test]
    matched = table4.matched_goals(scenes, library, model, windows, config)
    planned, plans = table4.planned_approach_goal(matched.goal, scenes, planner, seed=0)
    for b, (scene, plan) in enumerate(zip(scenes, plans)):
        k = 2 + int(matched.goal.hand[b])
        if plan is None:  # no path found: the matched approach is kept as it was
            assert torch.equal(planned.positions[b], matched.goal.positions[b])
            continue
        # from the window's first sample (the wrist, where the walk to x_s begins) to the grasp point (the contact)
        torch.testing.assert_close(planned.positions[b, 0, k], matched.goal.positions[b, 0, k])
        np.testing.assert_allclose(planned.positions[b, CENTRE, k].numpy(), scene.grasp_point, atol=1e-4)
        assert np.allclose(plan.positions[-1], scene.grasp_point, atol=1e-6)
        # only the working wrist's approach changes
        others = [j for j in range(4) if j != k]
        assert torch.equal(planned.positions[b][:, others], matched.goal.positions[b][:, others])
        assert torch.equal(planned.positions[b, CENTRE + 1:], matched.goal.positions[b, CENTRE + 1:])
        assert torch.equal(planned.rotations, matched.goal.rotations)
    assert any(p is not None for p in plans)
    with pytest.raises(ValueError, match="scenes: expected one per goal"):
        table4.planned_approach_goal(matched.goal, scenes[:1], planner)


def test_straight_approach_keeps_the_ends_and_is_straight():
    Goal = KeyJointGoal
    rng = np.random.default_rng(0)
    positions = torch.as_tensor(rng.normal(size=(2, 13, 4, 3)), dtype=torch.float32)
    rotations = torch.eye(3).expand(2, 13, 4, 3, 3).clone()
    goal = Goal(positions, rotations, torch.zeros(2, 4, 3), torch.tensor([0, 1]))
    straight = table4.straight_approach_goal(goal, goal.hand)
    for b, k in ((0, 2), (1, 3)):
        path = straight.positions[b, :7, k].double()
        assert torch.allclose(path[[0, -1]], positions[b, [0, 6], k].double(), atol=1e-5)
        line = path[-1] - path[0]
        off = torch.linalg.cross(path - path[0], line.expand_as(path)).norm(dim=-1) / line.norm()
        assert float(off.max()) < 1e-4  # on the line between the ends
    # everything else is untouched: the other wrist, the samples after the keyframe, the rotations
    assert torch.equal(straight.positions[0, :, 3], positions[0, :, 3])
    assert torch.equal(straight.positions[:, 7:], positions[:, 7:])
    assert torch.equal(straight.rotations, rotations)


def test_the_goal_of_a_table4_scene_comes_back_from_the_cache_as_run(tmp_cache):
    from hoi_tutorial.infra import load_or_build

    rng = np.random.default_rng(0)
    goal = KeyJointGoal(torch.as_tensor(rng.normal(size=(3, 13, 4, 3)), dtype=torch.float32),
                        torch.eye(3).expand(3, 13, 4, 3, 3).clone(), torch.as_tensor(rng.normal(size=(3, 4, 3))),
                        torch.tensor([0, 1, 1]), torch.tensor([40, 52, 47]))
    table = load_or_build("test_table4_goal", {}, lambda: {"anchors": np.arange(3), "goal": goal._asdict()})
    one = table4.scene_goal(table, 1)
    for name, value in one._asdict().items():
        assert torch.equal(value, getattr(goal, name)[1:2]), name
    assert table4.scene_goal({"anchors": np.arange(3), "goal": goal._replace(due=None)._asdict()}, 1).due is None
    for bad in (3, -1, True, 1.0):
        with pytest.raises(ValueError, match="scene"):
            table4.scene_goal(table, bad)
