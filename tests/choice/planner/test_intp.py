"""CHOICE's implicit trajectory planner (§4.2, Eqs. 7–12): the interactions, the auto-decoder's
training and run-time fit, the start point, the integration, the orientation transfer, errors."""
import numpy as np
import pytest
import torch
from torch import nn

from hoi_tutorial.choice.planner import fields, interactions, intp
from hoi_tutorial.choice.planner.decoder import FieldDecoder, channel_values


@pytest.fixture(scope="module")
def tiny(module_cache):
    """Two clips' interactions and an auto-decoder trained on them for a few hundred steps."""
    dcfg = interactions.planner_data_config("toy", n_clips=2, n_test_clips=1)
    train = interactions.interaction_set(dcfg, "train")
    cfg = intp.planner_config("toy", width=48, latent=8, steps=400, batch_size=4, fit_steps=40)
    model, result = intp.train_planner(train, cfg)
    return dcfg, train, cfg, model, result


def test_interactions_have_fields_conditions_and_the_contact_last(tiny):
    dcfg, train, *_ = tiny
    assert len(train) == 2 * 4  # approach and leave, each also as a place
    assert train.fields.shape == (len(train), 16, 16, 16, 3)
    c = train.conditions.numpy()
    assert set(np.unique(c[:, 2])) == {0.0, 1.0} and set(np.unique(c[:, 3])) == {0.0, 1.0}
    for inter in train.interactions:
        target = inter.target_object()
        assert abs(float(target.sdf(inter.wrist[-1]))) < 0.02  # the wrist touches the item at the contact
        assert float(inter.condition[0]) == pytest.approx(inter.wrist[-1, 2], abs=1e-5)
        # the clutter stays clear of the demonstrated path
        for obstacle in inter.obstacle_objects()[1:]:
            assert np.min(obstacle.sdf(inter.wrist)) > dcfg.clearance - 1e-9
    # a place is the pick played backwards: same fields, the action label set
    grasp = [i for i in train.interactions if i.condition[2] == 0]
    place = [i for i in train.interactions if i.condition[2] == 1]
    assert np.array_equal(grasp[0].fields, place[0].fields) and grasp[0].condition[3] != place[0].condition[3]


def test_training_lowers_the_loss_and_reconstructs_with_the_own_code(tiny):
    _, train, cfg, model, result = tiny
    rec = sum(np.asarray(result.extra[c]) for c in cfg.channels)  # Eq. 7's terms, without the codes' prior
    assert np.mean(rec[-20:]) < 0.5 * np.mean(rec[:20])
    assert np.mean(result.losses[-20:]) < np.mean(result.losses[:20])
    points = train.points.numpy()
    own, other = [], []
    for i in range(len(train)):
        true = train.fields[i].numpy() * model.scales.numpy()
        for j, bucket in ((i, own), ((i + 4) % len(train), other)):  # +4: another clip's interaction
            pred = intp.predict_fields(model, model.codes.weight[j].detach(), train.conditions[i], points) * model.scales.numpy()
            bucket.append(np.abs(pred[..., 0] - true[..., 0]).mean())
    assert np.mean(own) < 0.05  # D_t within 5 % of its range on average
    assert np.mean(own) < np.mean(other)  # each code holds its own scene


def test_the_latent_fit_lowers_eq_9_and_plans_end_on_the_goal(tiny):
    dcfg, train, cfg, model, _ = tiny
    inter = train.interactions[0]
    scene = fields.scene_fields(inter.grid, inter.target_object(), inter.obstacle_objects(), None, 30.0, dcfg.field)
    points, values, n_t = intp.prior_samples(scene, inter, inter.wrist[-1])
    assert n_t > 0 and len(points) > n_t
    fit = intp.fit_latent(model, cfg, scene, inter.condition, points, values)
    assert fit.codes.shape == (cfg.inits, cfg.latent) and fit.losses.shape == (cfg.fit_steps, cfg.inits)
    assert np.all(fit.final < fit.initial)
    start = inter.wrist[np.flatnonzero(inter.grid.contains(inter.wrist))[0]]
    plan = intp.plan_trajectory(model, cfg, train, scene, inter.condition, start, inter.wrist[-1])
    assert np.linalg.norm(plan.positions[-1] - inter.wrist[-1]) < 1e-6
    assert plan.rotations.shape == (len(plan.positions), 3, 3)
    # v̄ of Eq. 11 is the matched prior's mean wrist speed; the integration steps v̄/30 a frame
    prior = train.interactions[plan.prior_index].wrist
    assert plan.mean_speed == pytest.approx(np.linalg.norm(np.diff(prior, axis=0), axis=1).mean() * 30)
    # fitting is deterministic for a seed
    again = intp.fit_latent(model, cfg, scene, inter.condition, points, values)
    assert torch.equal(fit.codes, again.codes)


class _DistanceDecoder(nn.Module):
    """An analytic stand-in for the decoder: D_toa·ε of the time |x − g| / v to a goal g."""

    def __init__(self, goal, speed, eps):
        super().__init__()
        self.latent, self.condition = 2, 4
        self.goal, self.speed, self.eps = torch.as_tensor(goal, dtype=torch.float32), speed, eps

    def forward(self, x, z, c):
        t = (x - self.goal).norm(dim=-1, keepdim=True) / self.speed
        return self.eps / torch.clamp(t, min=self.eps)


def _analytic_model(goal_local, speed=0.5, eps=0.1):
    model = nn.Module()
    model.decoder = _DistanceDecoder(goal_local, speed, eps)
    model.register_buffer("scales", torch.tensor([eps]))
    return model


def test_integration_and_start_point_in_an_empty_scene():
    grid = fields.FieldGrid(np.array([0.0, 0.0, 1.0]), 0.3, 16, 0.05)
    goal = grid.to_world(np.array([0.1, -0.05, 0.08]))
    model = _analytic_model(grid.to_local(goal))
    phi = intp.time_field(model, torch.zeros(2), np.zeros(4), grid)
    wrist = grid.to_world(np.array([-0.3, 0.3, -0.2]))
    x_s = intp.start_point(grid, phi, wrist, mean_speed=0.5)
    cost = -phi + np.linalg.norm(grid.points() - wrist, axis=-1) / 0.5
    assert np.allclose(x_s, grid.points()[np.unravel_index(np.argmin(cost), cost.shape)])
    path = intp.integrate(model, torch.zeros(2), np.zeros(4), grid, x_s, step=0.5 / 30, stop_time=0.1)
    assert np.linalg.norm(path[-1] - goal) < 0.5 * 0.1 + 0.5 / 30  # stops within ε·v plus a step
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    assert np.allclose(steps, 0.5 / 30, atol=1e-5)  # Eq. 10 at the mean speed
    with pytest.raises(ValueError, match="no cell with a finite time"):
        intp.start_point(grid, np.full(grid.shape, 5.0), wrist, 0.5)
    with pytest.raises(ValueError, match="mean_speed"):
        intp.start_point(grid, phi, wrist, 0.0)


def test_a_plan_from_the_wrist_walks_straight_to_x_s_at_the_mean_speed():
    positions = np.array([[0.3, 0.0, 1.0], [0.32, 0.0, 1.0], [0.34, 0.0, 1.0], [0.35, 0.0, 1.0]])
    plan = intp.WristPlan(positions, np.broadcast_to(np.eye(3), (4, 3, 3)), positions[0], 0, None, None, 0.0,
                          mean_speed=0.6)
    wrist = np.array([0.0, 0.4, 1.0])  # 50 cm from x_s
    path = plan.from_wrist(wrist)
    np.testing.assert_allclose(path[0], wrist)
    np.testing.assert_allclose(path[-len(positions):], positions)
    walk = path[: len(path) - len(positions) + 1]  # the walk and x_s
    steps = np.linalg.norm(np.diff(walk, axis=0), axis=1)
    assert len(steps) == 25 and np.allclose(steps, 0.5 / 25)  # ⌈0.5 m / (0.6 m/s / 30)⌉ equal steps, none faster
    assert np.allclose(np.cross(walk - wrist, positions[0] - wrist), 0.0)  # on the straight line
    np.testing.assert_allclose(plan.from_wrist(positions[0]), positions)  # already at x_s: nothing added
    with pytest.raises(ValueError, match="mean_speed"):
        intp.WristPlan(positions, plan.rotations, positions[0], 0, None, None, 0.0).from_wrist(wrist)


def test_orientation_transfer_gives_rotations_and_keeps_the_prior_on_its_own_path():
    rng = np.random.default_rng(0)
    prior = np.cumsum(rng.normal(size=(20, 3)) * 0.02 + [0.0, 0.02, 0.0], axis=0)
    q, _ = np.linalg.qr(rng.normal(size=(20, 3, 3)))
    rotations = q * np.sign(np.linalg.det(q))[:, None, None]
    same = intp.transfer_orientation(prior, rotations, prior)
    np.testing.assert_allclose(same, rotations, atol=1e-9)
    planned = np.cumsum(rng.normal(size=(27, 3)) * 0.02 + [0.02, 0.0, 0.01], axis=0)
    out = intp.transfer_orientation(prior, rotations, planned)
    np.testing.assert_allclose(out @ np.swapaxes(out, 1, 2), np.broadcast_to(np.eye(3), out.shape), atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(out), 1.0, atol=1e-9)
    # every axis keeps its angle to the tangent (Eq. 12's intent), frames matched from the contact back
    tp, tq = intp._tangents(prior), intp._tangents(planned)
    for i in range(len(prior)):
        np.testing.assert_allclose(out[-1 - i].T @ tq[-1 - i], rotations[-1 - i].T @ tp[-1 - i], atol=1e-9)


def test_decoder_shapes_skip_and_errors():
    dec = FieldDecoder(latent=8, width=16, layers=6, skip=4)
    out = dec(torch.zeros(5, 7, 3), torch.zeros(5, 1, 8), torch.zeros(1, 1, 4))
    assert out.shape == (5, 7, 3)
    assert dec.hidden[3].in_features == 16 + 3 + 8 + 4  # the input again at the 4th layer (CHOICE §8.1)
    assert FieldDecoder(latent=8, channels=("t", "toa")).out.out_features == 2
    with pytest.raises(ValueError, match="channels"):
        FieldDecoder(latent=8, channels=("toa", "t"))
    # INTP-2Ch-D_o' (§8.2.3): one channel, the inverse distance to the nearest of target and obstacles
    D = np.array([[5.0, 2.0, 0.5], [0.0, 40.0, 0.0], [40.0, 1.0, 3.0]])
    np.testing.assert_allclose(channel_values(D, ("o'", "toa")), [[5.0, 0.5], [40.0, 0.0], [40.0, 3.0]])
    with pytest.raises(ValueError, match="x: expected shape"):
        dec(torch.zeros(5, 2), torch.zeros(8), torch.zeros(4))
    with pytest.raises(ValueError, match="channels: expected one of"):
        intp.planner_config(channels=("t", "o"))


def test_clear_errors_for_bad_plans(tiny):
    dcfg, train, cfg, model, _ = tiny
    inter = train.interactions[0]
    scene = fields.scene_fields(inter.grid, inter.target_object(), inter.obstacle_objects(), None, 30.0, dcfg.field)
    start = inter.wrist[np.flatnonzero(inter.grid.contains(inter.wrist))[0]]
    inside = np.argwhere(scene.obstacle_sdf < -0.005)[0]
    with pytest.raises(ValueError, match="goal: .* lies inside an obstacle"):
        intp.plan_trajectory(model, cfg, train, scene, inter.condition, start, inter.grid.points()[tuple(inside)])
    with pytest.raises(ValueError, match="condition: expected shape \\(4\\)"):
        intp.plan_trajectory(model, cfg, train, scene, inter.condition[:3], start, inter.wrist[-1])
    with pytest.raises(ValueError, match="goal: expected a point inside"):
        intp.plan_trajectory(model, cfg, train, scene, inter.condition, start, inter.wrist[-1] + 5.0)
    with pytest.raises(ValueError, match="no training interaction"):
        intp.match_prior(train, scene.D_t, np.array([1.0, 0.5, 0.0, 0.0]))
    with pytest.raises(ValueError, match="hand: expected one of"):
        interactions.condition_vector(1.0, "both", "grasp", "approach")
