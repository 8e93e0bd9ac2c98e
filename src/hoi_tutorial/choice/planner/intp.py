"""The neural implicit trajectory planner (CHOICE §4.2, Eqs. 7–12, Fig. 3).

The algorithm box, as this module runs it:

1. **Training** (Eqs. 7–8): an auto-decoder — one latent code ``z_i`` per training interaction and a
   shared decoder ``f_θ(x, z; c)`` (``decoder.FieldDecoder``) — fitted jointly to the interactions'
   fields: L1 on ``D_t`` and ``D_o``, L2 on ``D_toa``, and ``‖z_i‖² / σ²`` with ``σ = 0.01``.
2. **Run time, latent optimisation** (Eq. 9): in a new scene the planner knows ``D_t`` and ``D_o`` on
   the grid ``E_t`` (the scene is known) and ``D_toa`` only at ``x_prior = {x_O, x_T}`` — 0 inside the
   obstacles, and the time of a matched demonstration ``τ_prior`` where its wrist is within 5 cm of the
   target; ``z`` alone is optimised (several initialisations at once), ``γ = N(E_t) / N(x_prior)``.
3. **Start point** (Eq. 11): ``x_s = argmin −φ̂(x) + d(x, w) / v̄`` over the cells where ``φ̂`` is
   finite, ``w`` the wrist at the planning frame, ``v̄`` the mean wrist speed.
4. **Integration** (Eq. 10): from ``x_s`` down ``φ̂ = 1 / D̂_toa`` to its sink, the goal; a leave is
   planned as the approach to its release point and reversed.
5. **Orientation transfer** (Eq. 12): the prior's wrist rotations, synchronised from the contact
   backwards, each turned so that its relation to the path's tangent is the prior's; the final
   approaching frames blended to the prior (its contact point is kept).

Every loss is Eq. 8/9 divided by ``N(E_t)`` (the same minimiser): a mean over cells plus
``‖z‖² / (σ² N(E_t))``. Choices the paper does not state, ours: fields multiplied by ``ε`` to lie in
[0, 1]; cells sampled per step (``points``; DeepSDF samples too); ``φ̂`` above ``max_time`` counts as
infinite in Eq. 11; the integration walks ``v̄ / fps`` per step along ``−∇φ̂ / ‖∇φ̂‖`` (Eq. 10's
direction at the demonstrations' mean speed); the prior matched among the training interactions with
the same hand, action and segment by the closest ``D_t`` ("given c and D_t", §4.2); Eq. 12 applied as
one rotation taking the prior's tangent to the plan's (Eq. 12 per column with an unnormalised axis is not
a rotation in general; one rotation keeps every column's angle to the tangent, as Eq. 12 intends).

Scaling (paper → toy): ``z`` 128 → 16, 6 × 256 → 6 × 96, 300 epochs on two A100s (8 h) → ``steps`` batches
of ``batch_size`` interactions × ``points`` cells; 100 latent steps and three initialisations as the paper.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import torch
from torch import nn

from ..._validate import check_numbers, check_positive_ints, check_shape
from ...infra import TrainedModel, load_or_build, scaled_config, single_threaded, state_dict_to_cpu, train, trainer_config
from . import fields, interactions
from .decoder import CHANNEL_SETS, FieldDecoder, channel_values
from .interactions import InteractionSet, PlannerDataConfig

__all__ = [
    "PlannerConfig",
    "PLANNER_SCALES",
    "planner_config",
    "AutoDecoder",
    "build_auto_decoder",
    "reconstruction_loss",
    "train_planner",
    "trained_planner",
    "predict_fields",
    "match_prior",
    "carried_prior",
    "prior_samples",
    "LatentFit",
    "fit_latent",
    "latent_objective",
    "time_field",
    "start_point",
    "integrate",
    "transfer_orientation",
    "WristPlan",
    "plan_trajectory",
    "plan_each_init",
]


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class PlannerConfig:
    """The auto-decoder, its training and its run-time optimisation (defaults: the ``toy`` preset).

    Attributes:
        latent: size of ``z`` (CHOICE: 128).
        width, layers, skip: the decoder (CHOICE §8.1: 256, 6, the 4th layer).
        channels: the fields the decoder is trained on and optimised against (§8.2.3's ablations).
        code_sigma: ``σ`` of Eqs. 8–9 (CHOICE: 0.01, DeepSDF's, with Eq. 8's sum over 32³ cells). The
            toy grid has 8× fewer cells, so the same σ weighs the codes' prior 8× more against the
            fields; measured at toy, with 0.01 the run-time codes stay near 0 (norm 0.05 against the
            training codes' 0.5; Eq. 9 falls from 0.185 to 0.176), with 0.05 Eq. 9 falls to 0.125.
        steps, batch_size, points, lr, lr_schedule, warmup_steps, grad_clip, optimizer: training —
            ``batch_size`` interactions × ``points`` cells per step (CHOICE: 300 epochs, two A100s, 8 h).
        near_share: share of a step's cells drawn from where the time of arrival is below
            ``max_time`` (the tube around the demonstration), the rest uniformly (ours, as DeepSDF draws
            most of its samples near the surface).
        fit_steps: run-time latent steps (CHOICE §8.1: 100).
        fit_lr: their Adam learning rate (ours; DeepSDF's reconstruction uses 5e-3 over 800 steps).
        fit_points: cells of ``E_t`` per run-time step and initialisation (ours).
        inits: latent initialisations optimised at once (CHOICE: three per scene).
        init_std: their standard deviation (DeepSDF's reconstruction: 0.01).
        prior_radius: ``x_T``: the matched wrist's frames within this of the target (CHOICE: 5 cm).
        max_time: ``φ̂`` above this (s) counts as infinite in Eq. 11 (ours).
        seed: seeds the weights, the codes' initialisation, the batches and the run-time draws.
    """

    latent: int = 16
    width: int = 96
    layers: int = 6
    skip: int = 4
    channels: tuple = CHANNEL_SETS[0]
    code_sigma: float = 0.05
    steps: int = 1500
    batch_size: int = 8
    points: int = 256
    near_share: float = 0.5
    lr: float = 1e-3
    lr_schedule: str = "cosine"
    warmup_steps: int = 0
    grad_clip: Optional[float] = None
    optimizer: str = "adam"
    fit_steps: int = 100
    fit_lr: float = 0.01
    fit_points: int = 256
    inits: int = 3
    init_std: float = 0.01
    prior_radius: float = 0.05
    max_time: float = 5.0
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("latent", "width", "layers", "skip", "steps", "batch_size", "points",
                                   "fit_steps", "fit_points", "inits"))
        if tuple(self.channels) not in CHANNEL_SETS:
            raise ValueError(f"channels: expected one of {[list(c) for c in CHANNEL_SETS]} (CHOICE's three fields "
                             f"and the 2-channel ablations of §8.2.3), got {self.channels!r}")
        if not 0 <= self.near_share < 1:
            raise ValueError(f"near_share: expected a fraction in [0, 1), got {self.near_share!r}")
        check_numbers(self, ("code_sigma", "fit_lr", "init_std", "prior_radius", "max_time", "lr"), above=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)


# CHOICE §8.1: z of 128, 6 x 256; 300 epochs of 5546 interactions x 32^3 cells.
PLANNER_SCALES = {
    "small": {"latent": 64, "width": 256, "steps": 6000, "batch_size": 16, "points": 1024, "fit_points": 1024},
    "paper": {"latent": 128, "width": 256, "code_sigma": 0.01, "steps": 100000, "batch_size": 32, "points": 4096, "fit_points": 32768},
}


def planner_config(scale: str = "toy", **overrides) -> PlannerConfig:
    """The preset for ``scale``, fields overridable (``planner_config("toy", channels=("t", "toa"))``
    is INTP-2Ch-D_t)."""
    return scaled_config(PlannerConfig, scale, PLANNER_SCALES, overrides, factory="planner_config")


# ----------------------------------------------------------------------------- training (Eqs. 7-8)


class AutoDecoder(nn.Module):
    """The decoder and one latent code per training interaction (DeepSDF's auto-decoder)."""

    def __init__(self, decoder: FieldDecoder, n_codes: int, init_std: float):
        super().__init__()
        self.decoder = decoder
        self.codes = nn.Embedding(int(n_codes), decoder.latent)
        nn.init.normal_(self.codes.weight, 0.0, init_std)


def _channel_scales(epsilons, channels) -> np.ndarray:
    """Each channel's ``ε`` (the distance ε for D_t, D_o and D_o', the time ε for D_toa)."""
    eps = np.asarray(epsilons, dtype=np.float32)
    return np.array([eps[2] if c == "toa" else eps[0] for c in channels], dtype=np.float32)


def build_auto_decoder(config: PlannerConfig, n_codes: int, epsilons, half_extent: float) -> AutoDecoder:
    """A fresh auto-decoder, weights and codes seeded by ``config.seed`` (global RNG untouched); the
    codes start at ``N(0, 1/latent)`` (DeepSDF: ``1/√latent`` standard deviation). ``epsilons``: the
    (3,) ``ε`` of the three fields; the decoder outputs each field times its ``ε``."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        decoder = FieldDecoder(config.latent, 4, config.width, config.layers, config.skip, tuple(config.channels),
                               half_extent)
        model = AutoDecoder(decoder, n_codes, 1.0 / np.sqrt(config.latent))
    model.register_buffer("scales", torch.as_tensor(_channel_scales(epsilons, config.channels)))
    return model


def reconstruction_loss(prediction: torch.Tensor, target: torch.Tensor, channels) -> tuple[torch.Tensor, dict]:
    """Eq. 7 as a mean over cells: L1 on ``D_t`` and ``D_o``, squared error on ``D_toa``.

    Args:
        prediction, target: (..., len(channels)) fields times ``ε``.
    Returns:
        ``(loss, {channel: its mean term})``.
    """
    terms = {}
    for k, name in enumerate(channels):
        diff = prediction[..., k] - target[..., k]
        terms[name] = diff.pow(2).mean() if name == "toa" else diff.abs().mean()
    return sum(terms.values()), terms


@single_threaded
def train_planner(dataset: InteractionSet, config: PlannerConfig, device="cpu", progress: bool = False):
    """Minimise Eq. 8 over the decoder and the codes (one code per interaction of ``dataset``).

    Returns:
        ``(AutoDecoder in eval mode, TrainResult)``; ``extra`` holds the per-channel terms and ``"code"``
        (the mean ``‖z‖²``).
    """
    if not isinstance(dataset, InteractionSet) or len(dataset) == 0:
        raise ValueError("dataset: expected an InteractionSet with at least one interaction")
    grid = dataset.interactions[0].grid
    model = build_auto_decoder(config, len(dataset), dataset.epsilons, grid.half_extent)
    fields_flat = (channel_values(dataset.fields.reshape(len(dataset), -1, 3), config.channels) * model.scales).float()
    points = dataset.points.reshape(-1, 3)
    conditions = dataset.conditions
    n_cells = points.shape[0]
    reg = 1.0 / (config.code_sigma ** 2 * n_cells)

    # cell weights: near_share on the tube where the time of arrival is below max_time, the rest uniform
    tube = (dataset.fields.reshape(len(dataset), -1, 3)[..., 2] > 1.0 / config.max_time).float()
    weights = (1.0 - config.near_share) / n_cells + config.near_share * tube / tube.sum(1, keepdim=True).clamp_min(1.0)

    def sample_batch(step, generator):
        scenes = torch.randint(0, len(dataset), (config.batch_size,), generator=generator)
        cells = torch.multinomial(weights[scenes], config.points, replacement=True, generator=generator)
        return {"scenes": scenes, "x": points[cells], "c": conditions[scenes],
                "target": fields_flat[scenes[:, None], cells]}

    def loss_fn(net, batch):
        z = net.codes(batch["scenes"])  # (B, L)
        prediction = net.decoder(batch["x"], z[:, None], batch["c"][:, None])
        rec, terms = reconstruction_loss(prediction, batch["target"], config.channels)
        code = z.pow(2).sum(-1).mean()
        return rec + reg * code, {**{k: v.detach() for k, v in terms.items()}, "code": code.detach()}

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.eval(), result


def trained_planner(data_config: PlannerDataConfig, config: PlannerConfig, device="cpu",
                    progress: bool = False) -> TrainedModel:
    """The auto-decoder trained on ``interactions.interaction_set(data_config, "train")`` once, then loaded
    from the cache. ``details``: ``n_interactions``, the final per-channel terms (means over the last
    100 steps) and ``code_norm`` (the mean ``‖z_i‖``)."""
    def build():
        dataset = interactions.interaction_set(data_config, "train")
        model, result = train_planner(dataset, config, device=device, progress=progress)
        details = {name: float(np.mean(result.extra[name][-100:])) for name in config.channels}
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_interactions": len(dataset),
                "code_norm": float(model.codes.weight.detach().norm(dim=-1).mean()), **details}

    key = {"data": dataclasses.asdict(data_config), "model": dataclasses.asdict(config)}
    artifact = load_or_build("choice_planner", key, build)
    f = data_config.field
    model = build_auto_decoder(config, artifact["n_interactions"], (f.epsilon, f.epsilon, f.time_epsilon), 0.5 * f.extent)
    model.load_state_dict(artifact["state"])
    details = {k: artifact[k] for k in ("n_interactions", "code_norm", *config.channels)}
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"], details)


@torch.no_grad()
def predict_fields(model: AutoDecoder, z: torch.Tensor, c, points) -> np.ndarray:
    """The decoder's fields at ``points``: (..., len(channels)) in the fields' own units (``1/ε`` scale undone).

    Args:
        z: (latent,) code. c: (4,) condition. points: (..., 3) metres, grid frame.
    """
    x = torch.as_tensor(np.asarray(points), dtype=torch.float32)
    out = model.decoder(x, torch.as_tensor(z, dtype=torch.float32), torch.as_tensor(np.asarray(c), dtype=torch.float32))
    return out.numpy() / model.scales.numpy()


# ----------------------------------------------------------------------------- run time (Eqs. 9-12)


def match_prior(dataset: InteractionSet, d_target: np.ndarray, condition) -> int:
    """The training interaction whose demonstration serves as ``τ_prior`` (§4.2: "given c and D_t, a
    grasping/placing motion clip is matched in the database"): among those with the same hand, action
    and segment, the one whose ``D_t`` is closest (mean absolute difference over the grid)."""
    condition = np.asarray(condition, dtype=np.float32)
    check_shape(condition, (4,), "condition")
    d_target = np.asarray(d_target, dtype=np.float32)
    same = np.flatnonzero(np.all(dataset.conditions.numpy()[:, 1:] == condition[1:], axis=1))
    if len(same) == 0:
        raise ValueError(f"condition: no training interaction with hand/action/segment {condition[1:].tolist()}")
    cost = [np.abs(dataset.fields[k, ..., 0].numpy() - d_target).mean() for k in same]
    return int(same[int(np.argmin(cost))])


def carried_prior(grid: fields.FieldGrid, prior: interactions.Interaction, goal) -> np.ndarray:
    """The prior's wrist positions (T, 3) carried into this scene (world frame): expressed in its own
    grid's frame, put in this grid's frame, and shifted so that its contact (last frame) is ``goal``."""
    goal = np.asarray(goal, dtype=np.float64)
    check_shape(goal, (3,), "goal")
    local = prior.local_wrist
    return grid.to_world(local - local[-1] + grid.to_local(goal))


def prior_samples(scene: fields.SceneFields, prior: interactions.Interaction, goal,
                  radius: float = 0.05) -> tuple[np.ndarray, np.ndarray, int]:
    """``x_prior = {x_O, x_T}`` of Eq. 9 and the ``D_toa`` known there.

    ``x_O``: the cells inside obstacles (``D_toa = 0``). ``x_T``: the prior's wrist frames carried into
    this scene (:func:`carried_prior`) that lie within ``radius`` of its target, with ``D_toa`` from the
    prior's own time to go there (its field at the frame's cell in its own grid).

    Returns:
        ``(points (K, 3) metres in the grid frame, D_toa (K,), number of x_T samples)``.
    """
    grid = scene.grid
    points = grid.to_local(grid.points())
    x_o = (scene.obstacle_sdf < 0) & (scene.target_sdf > 0)
    carried = carried_prior(grid, prior, goal)
    near = np.asarray(scene_target_distance(scene, carried)) < radius
    x_t = grid.to_local(carried[near])
    values_t = prior.fields[..., 2][tuple(prior.grid.cell_of(prior.wrist[near]).T)]
    return (np.concatenate([points[x_o], x_t]).astype(np.float32),
            np.concatenate([np.zeros(int(x_o.sum())), values_t]).astype(np.float32), int(near.sum()))


def scene_target_distance(scene: fields.SceneFields, world_points) -> np.ndarray:
    """The target's signed distance at world points, interpolated from the scene's grid (metres)."""
    return scene.grid.sample(scene.target_sdf, world_points)


@dataclass
class LatentFit:
    """What Eq. 9's optimisation returns.

    Attributes:
        codes: (inits, latent) the optimised codes.
        losses: (fit_steps, inits) Eq. 9 (divided by ``N(E_t)``) per step and initialisation, on the
            step's sampled cells.
        final: (inits,) Eq. 9 over the whole grid after the fit (the best is ``codes[final.argmin()]``).
        seconds: wall-clock time of the optimisation.
        initial: (inits,) Eq. 9 over the whole grid at the initial codes.
        history: ``{step: (inits, latent) codes}`` for the steps asked for in ``record``.
    """

    codes: torch.Tensor
    losses: np.ndarray
    final: np.ndarray
    seconds: float
    initial: np.ndarray
    history: dict = field(default_factory=dict)

    @property
    def best(self) -> torch.Tensor:
        return self.codes[int(np.argmin(self.final))]


def fit_latent(model: AutoDecoder, config: PlannerConfig, scene: fields.SceneFields, condition,
               prior_points, prior_values, *, generator: Optional[torch.Generator] = None,
               record=()) -> LatentFit:
    """Eq. 9: optimise ``config.inits`` codes at once against the known fields of a new scene.

    Args:
        model: the trained auto-decoder (its decoder is frozen here).
        scene: the new scene's fields (``D_t``, ``D_o`` used; its ``D_toa`` is NOT read).
        condition: (4,) ``c``.
        prior_points, prior_values: ``x_prior`` and ``D_toa`` there (:func:`prior_samples`).
        generator: draws the initial codes and the cells of each step (default: seeded by ``config.seed``).
        record: steps (0 = before the first) whose codes are kept in ``LatentFit.history``.
    """
    generator = generator if generator is not None else torch.Generator().manual_seed(config.seed)
    known = [c for c in config.channels if c != "toa"]
    grid = scene.grid
    points = torch.as_tensor(grid.to_local(grid.points()).reshape(-1, 3), dtype=torch.float32)
    eps = scene.epsilons
    targets = torch.as_tensor(_known_targets(scene, known), dtype=torch.float32)
    prior_points = torch.as_tensor(np.asarray(prior_points), dtype=torch.float32).reshape(-1, 3)
    prior_values = torch.as_tensor(np.asarray(prior_values), dtype=torch.float32).reshape(-1) * float(eps[2])
    if len(prior_points) == 0:
        raise ValueError("prior_points: expected at least one x_prior sample")
    c = torch.as_tensor(np.asarray(condition), dtype=torch.float32)
    n_cells = points.shape[0]
    reg = 1.0 / (config.code_sigma ** 2 * n_cells)
    codes = (torch.randn(config.inits, model.decoder.latent, generator=generator) * config.init_std).requires_grad_(True)
    initial = latent_objective(model, config, scene, condition, prior_points, prior_values / float(eps[2]), codes.detach())
    optimizer = torch.optim.Adam([codes], lr=config.fit_lr)
    decoder = model.decoder
    for p in decoder.parameters():
        p.requires_grad_(False)
    toa = len(config.channels) - 1
    losses = []
    record = set(int(r) for r in record)
    history = {0: codes.detach().clone()} if 0 in record else {}
    start = time.perf_counter()
    try:
        for step in range(config.fit_steps):
            if step == config.fit_steps // 2:  # DeepSDF decays the rate part-way
                for group in optimizer.param_groups:
                    group["lr"] = config.fit_lr * 0.1
            cells = torch.randint(0, n_cells, (config.inits, config.fit_points), generator=generator)
            pred = decoder(points[cells], codes[:, None], c)  # (inits, P, channels)
            scene_term = (pred[..., :toa] - targets[cells]).abs().mean(dim=(1, 2)) * len(known)
            prior_pred = decoder(prior_points[None], codes[:, None], c)[..., toa]
            prior_term = (prior_pred - prior_values).pow(2).mean(dim=1)  # gamma * sum / N(E_t)
            loss = scene_term + prior_term + reg * codes.pow(2).sum(-1)
            optimizer.zero_grad()
            loss.sum().backward()
            optimizer.step()
            losses.append(loss.detach().numpy().copy())
            if step + 1 in record:
                history[step + 1] = codes.detach().clone()
    finally:
        for p in decoder.parameters():
            p.requires_grad_(True)
    losses = np.stack(losses)
    seconds = time.perf_counter() - start
    final = latent_objective(model, config, scene, condition, prior_points, prior_values / float(eps[2]), codes.detach())
    return LatentFit(codes.detach(), losses, final, seconds, initial, history)


def _known_targets(scene: fields.SceneFields, known) -> np.ndarray:
    """(n³, k) the scene's known channels (all but D_toa) times their ε."""
    stacked = np.stack([scene.D_t, scene.D_o, np.zeros_like(scene.D_t)], axis=-1).reshape(-1, 3)
    return channel_values(stacked, known) * _channel_scales(scene.epsilons, known)


@torch.no_grad()
def latent_objective(model: AutoDecoder, config: PlannerConfig, scene: fields.SceneFields, condition,
                     prior_points, prior_values, codes) -> np.ndarray:
    """Eq. 9 (divided by ``N(E_t)``) over the whole grid for each of ``codes`` (inits, latent): (inits,)."""
    known = [c for c in config.channels if c != "toa"]
    grid = scene.grid
    eps = scene.epsilons
    points = torch.as_tensor(grid.to_local(grid.points()).reshape(-1, 3), dtype=torch.float32)
    targets = torch.as_tensor(_known_targets(scene, known), dtype=torch.float32)
    prior_points = torch.as_tensor(np.asarray(prior_points), dtype=torch.float32).reshape(-1, 3)
    prior_values = torch.as_tensor(np.asarray(prior_values), dtype=torch.float32).reshape(-1) * float(eps[2])
    c = torch.as_tensor(np.asarray(condition), dtype=torch.float32)
    codes = torch.as_tensor(codes, dtype=torch.float32).reshape(-1, model.decoder.latent)
    toa = len(config.channels) - 1
    pred = model.decoder(points[None], codes[:, None], c)
    scene_term = (pred[..., :toa] - targets).abs().mean(dim=(1, 2)) * len(known)
    prior_term = (model.decoder(prior_points[None], codes[:, None], c)[..., toa] - prior_values).pow(2).mean(dim=1)
    reg = 1.0 / (config.code_sigma ** 2 * points.shape[0])
    return (scene_term + prior_term + reg * codes.pow(2).sum(-1)).numpy()


def _time_from_output(out: torch.Tensor, eps: float, max_time: float) -> torch.Tensor:
    # φ̂ = 1 / D̂_toa, with D̂_toa = out / ε; values under 1 / max_time read as max_time
    return 1.0 / torch.clamp(out / eps, min=1.0 / max_time)


@torch.no_grad()
def time_field(model: AutoDecoder, z, condition, grid: fields.FieldGrid, max_time: float = 5.0) -> np.ndarray:
    """``φ̂ = 1 / D̂_toa`` on the grid, seconds, capped at ``max_time`` (n, n, n)."""
    points = torch.as_tensor(grid.to_local(grid.points()), dtype=torch.float32)
    out = model.decoder(points, torch.as_tensor(z, dtype=torch.float32), torch.as_tensor(np.asarray(condition), dtype=torch.float32))
    return _time_from_output(out[..., -1], float(model.scales[-1]), max_time).numpy().astype(np.float64)


def start_point(grid: fields.FieldGrid, phi: np.ndarray, wrist, mean_speed: float, blocked=None,
                max_time: float = 5.0) -> np.ndarray:
    """Eq. 11: ``x_s = argmin −φ(x) + d(x, w) / v̄`` over the cells with ``φ`` below ``max_time``
    (and outside ``blocked``). Returns (3,) world metres."""
    phi = np.asarray(phi, dtype=np.float64)
    check_shape(phi, grid.shape, "phi")
    wrist = np.asarray(wrist, dtype=np.float64)
    check_shape(wrist, (3,), "wrist")
    if not mean_speed > 0:
        raise ValueError(f"mean_speed: expected a positive speed (m/s), got {mean_speed!r}")
    ok = phi < max_time * (1 - 1e-6)
    if blocked is not None:
        ok &= ~np.asarray(blocked)
    if not ok.any():
        raise ValueError("phi: no cell with a finite time of arrival; the latent fit found no path")
    pts = grid.points()
    cost = -phi + np.linalg.norm(pts - wrist, axis=-1) / mean_speed
    cost[~ok] = np.inf
    return pts[np.unravel_index(int(np.argmin(cost)), cost.shape)]


def integrate(model: AutoDecoder, z, condition, grid: fields.FieldGrid, start, *, step: float,
              max_steps: int = 200, stop_time: float = 0.02, max_time: float = 5.0) -> np.ndarray:
    """Eq. 10: walk from ``start`` along ``−∇φ̂ / ‖∇φ̂‖`` (autograd through the decoder), ``step`` metres
    a frame, until ``φ̂`` falls below ``stop_time`` or stops falling, or the walk leaves the grid.

    Returns:
        (K, 3) world positions, ``start`` first.
    """
    decoder = model.decoder
    zt = torch.as_tensor(z, dtype=torch.float32)
    ct = torch.as_tensor(np.asarray(condition), dtype=torch.float32)
    x = torch.as_tensor(grid.to_local(np.asarray(start, dtype=np.float64)), dtype=torch.float32)
    path = [x.clone()]
    previous = np.inf
    for _ in range(int(max_steps)):
        xg = x.clone().requires_grad_(True)
        phi = _time_from_output(decoder(xg, zt, ct)[..., -1], float(model.scales[-1]), max_time)
        value = float(phi.detach())
        if value < stop_time or value >= previous:
            break
        (grad,) = torch.autograd.grad(phi, xg)
        norm = float(grad.norm())
        if not norm > 0:
            break
        x = (x - step * grad / norm).detach()
        if float(x.abs().max()) > grid.half_extent:
            break
        path.append(x.clone())
        previous = value
    return grid.to_world(torch.stack(path).numpy().astype(np.float64))


def _rotation_taking(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking unit vector ``a`` to unit vector ``b`` (Rodrigues)."""
    v = np.cross(a, b)
    s, c = np.linalg.norm(v), float(np.dot(a, b))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)  # half turn about an axis normal to a
    k = v / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * K + (1 - c) * K @ K


def _tangents(path: np.ndarray) -> np.ndarray:
    t = np.gradient(path, axis=0) if len(path) > 1 else np.zeros_like(path)
    norm = np.linalg.norm(t, axis=-1, keepdims=True)
    return np.where(norm > 1e-9, t / np.maximum(norm, 1e-12), np.array([0.0, 0.0, 1.0]))


def transfer_orientation(prior_positions, prior_rotations, planned) -> np.ndarray:
    """Eq. 12: the planned path's wrist rotations from the prior's.

    Frames are synchronised from the contact backwards (the LAST frame of both is the contact): plan
    frame ``n − i`` takes prior frame ``m − i`` (the prior's first frame where the plan is longer), turned
    by the smallest rotation that takes the prior's tangent there to the plan's. Each column keeps its
    angle to the tangent, and the result is a rotation; where the tangents agree it is the prior's.

    Args:
        prior_positions: (m, 3) metres. prior_rotations: (m, 3, 3). planned: (n, 3) metres.
    Returns:
        (n, 3, 3) rotation matrices.
    """
    prior_positions = np.asarray(prior_positions, dtype=np.float64)
    prior_rotations = np.asarray(prior_rotations, dtype=np.float64)
    planned = np.asarray(planned, dtype=np.float64)
    check_shape(prior_positions, (None, 3), "prior_positions")
    check_shape(prior_rotations, (len(prior_positions), 3, 3), "prior_rotations")
    check_shape(planned, (None, 3), "planned")
    if len(prior_positions) < 2 or len(planned) < 1:
        raise ValueError("transfer_orientation: expected a prior of at least 2 frames and a non-empty plan")
    t_prior, t_plan = _tangents(prior_positions), _tangents(planned)
    m, n = len(prior_positions), len(planned)
    out = np.empty((n, 3, 3))
    for i in range(n):
        j = max(m - 1 - i, 0)
        out[n - 1 - i] = _rotation_taking(t_prior[j], t_plan[n - 1 - i]) @ prior_rotations[j]
    return out


@dataclass
class WristPlan:
    """A planned wrist trajectory (world frame) and what produced it.

    Attributes:
        positions: (K, 3) metres, the contact LAST (an approach; a leave is planned towards its release
            point and reversed only by :meth:`in_time_order`).
        rotations: (K, 3, 3) wrist rotations (Eq. 12).
        start: (3,) ``x_s`` of Eq. 11.
        prior_index: the matched training interaction.
        fit: the latent optimisation.
        code: (latent,) the code used (the best initialisation's unless one was asked for).
        seconds: total planning time.
        segment: ``"approach"`` or ``"leave"``.
        mean_speed: ``v̄`` of Eq. 11 (m/s), the matched prior's mean wrist speed; the integration steps
            ``v̄ / fps`` metres a frame.
    """

    positions: np.ndarray
    rotations: np.ndarray
    start: np.ndarray
    prior_index: int
    fit: LatentFit
    code: torch.Tensor
    seconds: float
    segment: str = "approach"
    mean_speed: float = float("nan")

    def from_wrist(self, wrist, fps: float = 30.0) -> np.ndarray:
        """(K', 3) metres, the contact last: ``positions`` preceded by a straight walk from ``wrist`` (the wrist
        at the planning frame, ``w`` of Eq. 11) to ``start`` (``x_s``) at ``mean_speed`` (``v̄``).

        CHOICE integrates from ``x_s`` and leaves the way from ``w`` to ``x_s`` to the controller; a path that is
        compared with planners starting at ``w`` (Table 3) starts there too (ours: the straight line at the
        speed Eq. 11 assumes).
        """
        wrist = np.asarray(wrist, dtype=np.float64)
        check_shape(wrist, (3,), "wrist")
        if not self.mean_speed > 0:
            raise ValueError(f"mean_speed: expected the plan's positive v̄ (m/s), got {self.mean_speed!r}")
        distance = float(np.linalg.norm(self.start - wrist))
        n = int(np.ceil(distance / (self.mean_speed / float(fps))))
        walk = wrist + np.arange(n)[:, None] / max(n, 1) * (self.start - wrist)
        return np.concatenate([walk, self.positions])

    def in_time_order(self) -> tuple[np.ndarray, np.ndarray]:
        """(positions, rotations) in the order the wrist moves (a leave starts at the release)."""
        if self.segment == "leave":
            return self.positions[::-1], self.rotations[::-1]
        return self.positions, self.rotations


def plan_trajectory(model: AutoDecoder, config: PlannerConfig, dataset: InteractionSet, scene: fields.SceneFields,
                    condition, wrist, goal, *, init: Optional[int] = None, blend_frames: int = 5,
                    generator: Optional[torch.Generator] = None) -> WristPlan:
    """Plan one approach (or leave) in a new scene: match a prior and carry it onto ``goal``, fit ``z``
    (Eq. 9), start at ``x_s`` (Eq. 11), integrate (Eq. 10), blend the last ``blend_frames`` to the
    carried prior (its contact lands on ``goal``) and transfer its orientations (Eq. 12).

    Args:
        scene: the new scene's fields on its grid (``D_toa`` unused).
        condition: (4,) ``c``.
        wrist: (3,) metres, the wrist at the planning frame.
        goal: (3,) metres, the contact (grasp or release) point; it must not lie inside an obstacle.
        init: use this initialisation's code instead of the best one (:func:`plan_each_init` plans
            with every one from a single fit).
    """
    plans = plan_each_init(model, config, dataset, scene, condition, wrist, goal, blend_frames=blend_frames,
                           generator=generator, inits=None if init is None else [int(init)])
    return plans[0]


def plan_each_init(model: AutoDecoder, config: PlannerConfig, dataset: InteractionSet, scene: fields.SceneFields,
                   condition, wrist, goal, *, inits=None, blend_frames: int = 5,
                   generator: Optional[torch.Generator] = None) -> list:
    """:func:`plan_trajectory` for several codes of one latent fit: ``inits`` (indices; default: the
    best one only — pass ``range(config.inits)`` for all, as CHOICE's Table 3 reports)."""
    start_clock = time.perf_counter()
    grid = scene.grid
    goal = np.asarray(goal, dtype=np.float64)
    check_shape(goal, (3,), "goal")
    if not grid.contains(goal):
        raise ValueError(f"goal: expected a point inside the scene's grid, got {goal.round(3).tolist()}")
    if float(grid.sample(scene.obstacle_sdf, goal)) < 0:
        raise ValueError(f"goal: {goal.round(3).tolist()} lies inside an obstacle")
    condition = np.asarray(condition, dtype=np.float32)
    check_shape(condition, (4,), "condition")
    prior_index = match_prior(dataset, scene.D_t, condition)
    prior = dataset.interactions[prior_index]
    points, values, _ = prior_samples(scene, prior, goal, config.prior_radius)
    fit = fit_latent(model, config, scene, condition, points, values, generator=generator)
    fit_seconds = time.perf_counter() - start_clock
    fps = 30.0
    mean_speed = float(np.mean(np.linalg.norm(np.diff(prior.wrist, axis=0), axis=-1)) * fps)
    carried = carried_prior(grid, prior, goal)
    segment = "leave" if float(condition[3]) > 0.5 else "approach"
    chosen = [int(np.argmin(fit.final))] if inits is None else [int(k) for k in inits]
    plans = []
    for k in chosen:
        clock = time.perf_counter()
        code = fit.codes[k]
        phi = time_field(model, code, condition, grid, config.max_time)
        x_s = start_point(grid, phi, wrist, mean_speed, scene.blocked, config.max_time)
        path = integrate(model, code, condition, grid, x_s, step=mean_speed / fps, max_time=config.max_time,
                         stop_time=float(scene.epsilons[2]))
        if len(path) < blend_frames + 1:  # the walk stopped at once: hold x_s, then the blend carries it in
            path = np.concatenate([np.repeat(path[:1], blend_frames + 1 - len(path), axis=0), path])
        # the last frames blend to the carried prior, whose contact is the goal
        n = min(blend_frames, len(path))
        w = np.linspace(0.0, 1.0, n + 1)[1:, None]
        path = np.concatenate([path[:-n], (1 - w) * path[-n:] + w * carried[-n:]])
        rotations = transfer_orientation(carried, prior.wrist_rotations, path)
        plans.append(WristPlan(path, rotations, x_s, prior_index, fit, code,
                               fit_seconds + time.perf_counter() - clock, segment, mean_speed))
    return plans
