"""CHOICE Table 3's protocol and baselines: the minimum-jerk planner, scene changes, run measures."""
import dataclasses

import numpy as np
import pytest
import torch

from hoi_tutorial.choice.planner import baselines, interactions, table3
from hoi_tutorial.world.objects import make_object


def test_a_free_minimum_jerk_move_is_the_quintic():
    start, goal = np.array([0.1, -0.2, 0.9]), np.array([0.5, 0.1, 1.2])
    path = baselines.minimum_jerk_plan(start, goal, 40)
    quintic = start + baselines.minimum_jerk_profile(40)[:, None] * (goal - start)
    assert np.allclose(path[[0, -1]], [start, goal])
    # the discrete optimum with the ends at rest is the quintic to within 1.5 % of the move
    assert np.abs(path - quintic).max() < 0.015 * np.linalg.norm(goal - start)
    # and its jerk is no larger than the quintic's (the optimum of the same discrete cost)
    jerk = lambda p: np.sum(np.diff(np.concatenate([[start] * 2, p, [goal] * 2]), n=3, axis=0) ** 2)
    assert jerk(path) <= jerk(quintic) + 1e-12


def test_minimum_jerk_keeps_clear_of_an_obstacle_on_the_straight_line():
    start, goal = np.zeros(3), np.array([0.4, 0.1, 0.2])
    centre = 0.5 * (start + goal)
    sphere = lambda x: (x - torch.as_tensor(centre, dtype=x.dtype)).norm(dim=-1) - 0.05
    path = baselines.minimum_jerk_plan(start, goal, 30, sphere, margin=0.03)
    clearance = sphere(torch.as_tensor(path)).numpy()
    assert clearance.min() > 0.0  # the straight line goes through the sphere's centre
    with pytest.raises(ValueError, match="n_frames: expected at least 3"):
        baselines.minimum_jerk_plan(start, goal, 2)


def test_scaling_an_object_scales_its_box():
    shelf = make_object("shelf", 3).placed(1.0, 2.0, 0.5)
    bigger = table3.scale_object(shelf, (1.2, 0.8, 1.5))
    (lo, hi), (lo2, hi2) = shelf.canonical_bounds, bigger.canonical_bounds
    np.testing.assert_allclose((hi2 - lo2) / (hi - lo), [1.2, 0.8, 1.5], rtol=1e-6)
    np.testing.assert_allclose(bigger.pose, shelf.pose)


@pytest.fixture(scope="module")
def test_set(module_cache):
    config = interactions.planner_data_config("toy", n_clips=1, n_test_clips=3)
    return config, interactions.interaction_set(config, "test")


def test_cases_keep_the_goal_clear_and_move_it_with_a_reshaped_container(test_set):
    config, test = test_set
    for reshape in (False, True):
        cases = table3.planning_cases(test, config.field, reshape=reshape)
        assert 0 < len(cases) <= len([i for i in test.interactions if i.condition[2] == 0])
        for case in cases:
            source = test.interactions[case.source]
            assert case.obstacle_sdf(case.goal) > 0.01 and case.obstacle_sdf(case.start) > 0
            assert abs(float(case.target.sdf(case.goal))) < 0.02  # still on the (moved) item
            assert case.condition[0] == pytest.approx(case.goal[2])  # c's goal height is the (moved) goal's
            np.testing.assert_array_equal(case.condition[1:], source.condition[1:])
            # the item is carried on a pick's leave: its points stand on the target at the contact
            assert (case.item_points is not None) == (source.condition[3] == 1)
            if case.item_points is not None:
                assert np.abs(case.target.sdf(case.item_points)).max() < 1e-6
            if not reshape:  # the item and the container stay; the clutter moves by at most 5 cm
                np.testing.assert_allclose(case.goal, source.wrist[-1], atol=1e-9)
                for before, after in zip(source.obstacle_objects()[1:], case.obstacles[1:]):
                    assert np.linalg.norm(after.translation[:2] - before.translation[:2]) <= 0.05 + 1e-9
        if reshape:  # reshaping moves goals up and down: c follows them
            assert max(abs(c.condition[0] - test.interactions[c.source].condition[0]) for c in cases) > 0.01


def test_run_measures_count_collisions_and_the_reach(test_set):
    config, test = test_set
    case = table3.planning_cases(test, config.field, reshape=False)[0]
    straight = case.start + np.linspace(0, 1, 20)[:, None] * (case.goal - case.start)
    demo = test.interactions[case.source].wrist
    inside = demo[test.interactions[case.source].grid.contains(demo)]
    measured = table3.measure_run(inside, case)
    assert measured.end_error < 1e-9 and measured.min_clearance > 0 and measured.success  # the demonstration itself
    inside_obstacle = case.scene.grid.points()[tuple(np.argwhere(case.scene.obstacle_sdf < -0.005)[0])]
    through = table3.measure_run(np.concatenate([straight[:10], [inside_obstacle], straight[10:]]), case)
    assert through.min_clearance < 0 and not through.success
    short = table3.measure_run(straight[:15], case)
    assert short.end_error > 0.02 and not short.success
    row = table3.summarise([measured, through, short])
    assert row["successes"] == 1 and row["runs"] == 3 and row["success (%)"] == pytest.approx(100 / 3)
    with pytest.raises(ValueError, match="path: expected a"):
        table3.measure_run(straight[:2], case)
    with pytest.raises(ValueError, match="path: expected a path starting at the case's start"):
        table3.measure_run(straight[1:], case)  # every planner is judged from the same start


def test_a_carried_item_driven_into_its_board_is_a_collision(test_set):
    config, test = test_set
    leaves = [c for c in table3.planning_cases(test, config.field, reshape=False) if c.item_points is not None]
    assert leaves
    for case in leaves:
        # the wrist comes to the contact from 4 cm straight below it: clear itself, the item it carries is
        # pushed 4 cm down into the board it stands on
        below = case.goal - [0.0, 0.0, 0.04]
        path = np.concatenate([case.start + np.linspace(0, 1, 20)[:, None] * (below - case.start),
                               below + np.linspace(0, 1, 6)[1:, None] * (case.goal - below)])
        run = table3.measure_run(path, case)
        if run.min_clearance <= 0:
            continue  # this wrist path itself hits something: not the case to test with
        assert run.item_clearance < -table3.ITEM_REST_TOLERANCE and run.collided and not run.success and run.end_error < 1e-9
        # the same path without the item (an approach) is judged on the wrist alone
        bare = table3.measure_run(path, dataclasses.replace(case, item_points=None))
        assert np.isnan(bare.item_clearance) and not bare.collided and bare.success
        # the safety distance is the hand's and the object's: the item is nearer the board than the wrist
        assert run.safety < bare.safety
        break
    else:
        pytest.fail("no leave case with a clear wrist path from below")
