"""CHOICE's bimanual task scheduler (§6.3, Eq. 24, Fig. 6): the cost at hand-computed cases, the auxiliary
objects found in the target's way, the schedule chosen by the free hands, the state machine's keyframes,
errors."""
import dataclasses

import numpy as np
import pytest

from hoi_tutorial.choice.controller import kalman
from hoi_tutorial.choice.pick_and_place import environment, goal_library, scheduler
from hoi_tutorial.choice.pick_and_place.environment import KeyPose
from hoi_tutorial.world.objects import CATEGORY_SIZES, make_object
from hoi_tutorial.world.scenes import Kitchen, make_kitchen


@pytest.fixture(scope="module")
def matcher(module_cache, one_cpu_thread):
    """``M(H, o)`` from an autoencoder trained briefly on two kitchens and a library of four clips per kind."""
    config = environment.environment_config("toy", n_kitchens=2, channels=(4, 8, 16), steps=150)
    trained = environment.trained_environment_autoencoder(config)
    rows = goal_library.goal_keyframes(config, goal_library.library_config("toy", n_clips=4))
    library = goal_library.build_goal_library(trained.model, rows)
    return scheduler.library_matcher(library, trained.model, scheduler.scheduler_config(k=2), config)


def _on_board(holder, item, row, u, v):
    """``item`` standing on the holder's support surface ``row`` at fractions ``(u, v)`` of the x and y range
    its centre can take (the item within the surface)."""
    z, x0, x1, y0, y1, free = holder.support_surfaces[row]
    assert item.canonical_bounds[1, 2] + 0.02 <= free  # it fits under the board above
    r = float(np.max(np.abs(item.canonical_bounds[:, :2]))) + 0.005
    local = np.eye(4)
    local[:3, 3] = (x0 + r + u * (x1 - x0 - 2 * r), y0 + r + v * (y1 - y0 - 2 * r), z)
    return item.with_pose(holder.pose @ local)


def _kitchen_with(holder_category, items_at, **state):
    """Kitchen 0's furniture (the door or drawer set by ``state``) with items put on one holder."""
    base = make_kitchen(0, door_angle=state.get("door_angle", 0.0), drawer_open=state.get("drawer_open", 0.0))
    holder = base.furniture_of(holder_category)
    items = [_on_board(holder, make_object(category, seed), row, u, v) for category, seed, row, u, v in items_at]
    return Kitchen(base.size, base.furniture, items, [base.furniture.index(holder)] * len(items), base.obstacles)


@pytest.fixture(scope="module")
def cabinet_bottle():
    """A bottle in the middle of a closed cabinet's floor."""
    return _kitchen_with("cabinet", [("bottle", 5, 0, 0.5, 0.5)])


def _in_front(kitchen, index) -> KeyPose:
    """Standing 45 cm in front of the target's holder, facing it (heading 0 faces +Y)."""
    front = kitchen.holder_of(index).rotation[:, 1]
    return KeyPose.standing((kitchen.items[index].translation + 0.45 * front)[:2], np.arctan2(front[0], -front[1]))


# ----------------------------------------------------------------------------- Eq. 24


def test_eq_24_at_hand_computed_cases():
    eye = np.broadcast_to(np.eye(3), (3, 3, 3))
    current = KeyPose(eye, np.zeros((3, 3)))
    beta, alpha = 1.0 / kalman.mean_body_width(), 1.0 / np.pi
    # every key joint 10 cm along x from p^key, the target keyframe equal to the auxiliary one
    auxiliary = current.translated([0.1, 0.0, 0.0])
    assert scheduler.schedule_cost(current, auxiliary, auxiliary) == pytest.approx(3 * 0.1 * beta)
    # the target keyframe turns the left wrist by 90° about z and moves the pelvis 20 cm up
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    rotations = auxiliary.rotations.copy()
    rotations[0] = quarter
    positions = auxiliary.positions.copy()
    positions[2, 2] += 0.2
    target = KeyPose(rotations, positions)
    transition = alpha * np.sqrt(2.0) * np.pi / 2 + beta * 0.2
    assert scheduler.deviation(auxiliary, target) == pytest.approx(transition)
    assert scheduler.schedule_cost(current, auxiliary, target) == pytest.approx(3 * 0.1 * beta + 2 * transition)
    assert scheduler.schedule_cost(current, auxiliary, target, weight=0.0) == pytest.approx(3 * 0.1 * beta)
    assert scheduler.scheduler_config("paper").weight == 2.0  # CHOICE's w


def test_candidate_schedules_follow_the_free_hands():
    names = [s.name for s in scheduler.candidate_schedules()]
    assert names == ["sequential (left hand)", "sequential (right hand)",
                     "co-temporal (left: auxiliary, right: target)", "co-temporal (right: auxiliary, left: target)"]
    assert scheduler.candidate_schedules(busy=("left",)) == [scheduler.Schedule("right", "right")]
    assert scheduler.candidate_schedules(busy=("right",), auxiliary=False) == [scheduler.Schedule(None, "left")]
    with pytest.raises(ValueError, match="both hands"):
        scheduler.candidate_schedules(busy=("left", "right"))
    with pytest.raises(ValueError, match="busy"):
        scheduler.candidate_schedules(busy=("third",))


# ----------------------------------------------------------------------------- o_g and o_d


def test_a_closed_door_is_opened_just_enough_and_an_open_one_is_no_auxiliary(cabinet_bottle):
    task = scheduler.detect_task(cabinet_bottle, 0)
    cabinet = cabinet_bottle.holder_of(0)
    assert task.auxiliary.kind == "door" and task.auxiliary.name == "cabinet door"
    np.testing.assert_allclose(task.auxiliary.contact, cabinet.handle_point)
    full = CATEGORY_SIZES["cabinet"]["door_angle"].high
    assert 0 < task.opening <= full
    np.testing.assert_allclose(task.hold, cabinet.with_params(door_angle=task.opening).handle_point)
    assert np.allclose(task.way, cabinet.rotation[:, 1]) and np.dot(task.carry - task.target.contact, task.way) > 0
    assert task.target.environment[0] is not cabinet  # the target's surroundings have the door open
    opened = _kitchen_with("cabinet", [("bottle", 5, 0, 0.5, 0.5)], door_angle=full)
    assert scheduler.detect_task(opened, 0).auxiliary is None


def test_a_closed_drawer_is_pulled_out_and_its_item_moves_with_it():
    kitchen = _kitchen_with("drawer", [("mug", 2, 0, 0.5, 0.9)])
    drawer = kitchen.holder_of(0)
    task = scheduler.detect_task(kitchen, 0)
    assert task.auxiliary.kind == "drawer" and np.allclose(task.way, [0.0, 0.0, 1.0])
    assert 0 < task.opening <= CATEGORY_SIZES["drawer"]["drawer_open"].high
    before = environment.item_goal(kitchen, 0).contact
    np.testing.assert_allclose(task.target.contact, before + task.opening * drawer.rotation[:, 1], atol=1e-9)


def test_an_item_in_front_is_an_obstacle_to_move(matcher):
    kitchen = _kitchen_with("shelf", [("bottle", 3, 1, 0.5, 0.25), ("mug", 4, 1, 0.5, 0.8)])
    task = scheduler.detect_task(kitchen, 0)
    assert task.auxiliary.kind == "item" and task.auxiliary.obj is kitchen.items[1]
    assert all(thing is not kitchen.items[1] for thing in task.target.environment)  # the mug is gone
    assert task.aside is not None
    current = _in_front(kitchen, 0)
    for schedule in (scheduler.Schedule("left", "left"), scheduler.Schedule("left", "right")):
        plan = scheduler.plan_task(kitchen, 0, current, matcher, schedule=schedule)
        steps = [(k.action, k.hand, k.object) for k in plan.keyframes]
        mug_place = steps.index(("place", "left", "mug 1"))
        bottle_reach = steps.index(("reach", schedule.target_hand, "bottle 0"))
        assert steps.index(("carry", "left", "mug 1")) < bottle_reach
        if schedule.cotemporal:  # held aside while the bottle comes out, then put back where it stood
            assert bottle_reach < mug_place
            np.testing.assert_allclose(plan.keyframes[mug_place].position, task.auxiliary.contact)
        else:  # put down on its board first
            assert mug_place < bottle_reach
            np.testing.assert_allclose(plan.keyframes[mug_place].position, task.aside)


# ----------------------------------------------------------------------------- schedules and keyframes


def test_both_hands_free_choose_co_temporal_one_busy_hand_sequential(cabinet_bottle, matcher):
    current = _in_front(cabinet_bottle, 0)
    plan = scheduler.plan_task(cabinet_bottle, 0, current, matcher)
    assert len(plan.candidates) == 4 and all(c.feasible for c in plan.candidates)
    assert plan.chosen.schedule.cotemporal
    assert plan.chosen.cost == min(c.cost for c in plan.candidates)
    for c in plan.candidates:  # each candidate's cost is Eq. 24 at its own pair of keyframes
        target = c.target.contact
        if c.schedule.cotemporal:
            target = target.with_joint(environment.HANDS.index(c.schedule.auxiliary_hand), c.auxiliary.contact)
        assert c.cost == pytest.approx(scheduler.schedule_cost(current, c.auxiliary.contact, target))
    for busy, free in ((("left",), "right"), (("right",), "left")):
        plan = scheduler.plan_task(cabinet_bottle, 0, current, matcher, busy=busy)
        assert plan.chosen.schedule == scheduler.Schedule(free, free)
        assert {k.hand for k in plan.keyframes[1:]} == {free}


def test_the_state_machine_opens_the_door_before_the_bottle(cabinet_bottle, matcher):
    current = _in_front(cabinet_bottle, 0)
    plan = scheduler.plan_task(cabinet_bottle, 0, current, matcher, place_at=[2.5, 2.5, 0.8])
    task, schedule = plan.task, plan.chosen.schedule
    steps = [(k.action, k.object) for k in plan.keyframes]
    assert steps == [("walk", "cabinet door"), ("reach", "cabinet door"), ("grasp", "cabinet door"),
                     ("open", "cabinet door"), ("reach", "bottle 0"), ("grasp", "bottle 0"), ("carry", "bottle 0"),
                     ("release", "cabinet door"), ("place", "bottle 0"), ("release", "bottle 0")]
    door_hand = plan.keyframes[3].hand
    bottle_hand = plan.keyframes[4].hand
    assert door_hand == schedule.auxiliary_hand != bottle_hand == schedule.target_hand
    assert plan.keyframes[0].hand is None and np.allclose(plan.keyframes[0].position, plan.keyframes[1].pose.pelvis)
    expected = {1: task.auxiliary.contact, 3: task.hold, 4: task.target.contact, 6: task.carry, 7: task.hold,
                8: [2.5, 2.5, 0.8]}
    for i, position in expected.items():
        np.testing.assert_allclose(plan.keyframes[i].position, position)
    for k in plan.keyframes[1:]:
        if k.pose is not None:  # a matched keyframe, moved so that its wrist is on the goal
            np.testing.assert_allclose(k.pose.hand(k.hand), k.position, atol=1e-9)
    for k in plan.keyframes[4:7]:  # the door hand keeps the door open while the other takes the bottle
        np.testing.assert_allclose(k.pose.hand(door_hand), task.hold, atol=1e-9)
    # sequentially, the same hand lets go of the door before it reaches the bottle
    sequential = scheduler.plan_task(cabinet_bottle, 0, current, matcher, schedule=scheduler.Schedule("right", "right"))
    steps = [(k.action, k.hand, k.object) for k in sequential.keyframes]
    assert steps.index(("release", "right", "cabinet door")) < steps.index(("reach", "right", "bottle 0"))
    # deterministic
    again = scheduler.plan_task(cabinet_bottle, 0, current, matcher, place_at=[2.5, 2.5, 0.8])
    assert [(k.action, k.hand) for k in again.keyframes] == [(k.action, k.hand) for k in plan.keyframes]
    assert all(np.array_equal(a.position, b.position) for a, b in zip(again.keyframes, plan.keyframes))


def test_errors_name_what_was_expected(cabinet_bottle, matcher):
    current = _in_front(cabinet_bottle, 0)
    with pytest.raises(ValueError, match="place_at: expected a point inside the scene"):
        scheduler.plan_task(cabinet_bottle, 0, current, matcher, place_at=[9.0, 1.0, 0.8])
    with pytest.raises(ValueError, match="contact: expected a point inside the scene"):
        environment.item_goal(cabinet_bottle, 0, contact=[1.0, 1.0, -0.5])
    with pytest.raises(ValueError, match="action: expected one of"):
        scheduler.Keyframe("fly", "left", "bottle 0", np.zeros(3))
    with pytest.raises(ValueError, match="hand"):
        scheduler.Keyframe("walk", "left", "bottle 0", np.zeros(3))
    with pytest.raises(ValueError, match="both hands hold something"):
        scheduler.plan_task(cabinet_bottle, 0, current, matcher, busy=("left", "right"))
    with pytest.raises(ValueError, match="schedule: expected one of"):
        scheduler.plan_task(cabinet_bottle, 0, current, matcher, busy=("left",),
                            schedule=scheduler.Schedule("left", "right"))
    with pytest.raises(ValueError, match="index: expected an item index"):
        scheduler.detect_task(cabinet_bottle, 3)
    walled_in = _kitchen_with("drawer", [("mug", 2, 0, 0.5, 0.05)])  # at the back of the tray: never clear
    with pytest.raises(ValueError, match="cannot be taken out"):
        scheduler.detect_task(walled_in, 0)


def test_the_held_point_is_on_the_side_of_one_hand_only(cabinet_bottle):
    task = scheduler.detect_task(cabinet_bottle, 0)
    holder = cabinet_bottle.holder_of(0)
    right = -holder.rotation[:, 0]  # the viewer's right, facing the cabinet (its front is +Y)
    side = "right" if (task.hold - task.target.contact) @ right > 0 else "left"
    other = "left" if side == "right" else "right"
    assert scheduler.held_on_its_side(task, side) and not scheduler.held_on_its_side(task, other)
    # the held point moved to the other side of the target swaps the answer
    mirrored = dataclasses.replace(task, hold=task.hold - 2 * ((task.hold - task.target.contact) @ right) * right)
    assert scheduler.held_on_its_side(mirrored, other) and not scheduler.held_on_its_side(mirrored, side)
    with pytest.raises(ValueError, match="auxiliary_hand: expected one of"):
        scheduler.held_on_its_side(task, "middle")
    with pytest.raises(ValueError, match="task: expected a task with an auxiliary object held"):
        scheduler.held_on_its_side(dataclasses.replace(task, hold=None), side)


def test_the_cheapest_uncrossed_schedule_leaves_out_only_the_crossing_co_temporal_ones(cabinet_bottle, matcher):
    plan = scheduler.plan_task(cabinet_bottle, 0, _in_front(cabinet_bottle, 0), matcher)
    kept = scheduler.cheapest_uncrossed(plan.task, plan.candidates)
    crossing = [c for c in plan.candidates
                if c.schedule.cotemporal and not scheduler.held_on_its_side(plan.task, c.schedule.auxiliary_hand)]
    assert len(crossing) == 1  # one co-temporal schedule holds the door on its hand's side, the other across
    assert kept.feasible and kept is not crossing[0]
    assert kept.cost == min(c.cost for c in plan.candidates if c.feasible and c is not crossing[0])
    if plan.chosen is not crossing[0]:
        assert kept is plan.chosen
