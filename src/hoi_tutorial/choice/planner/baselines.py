"""The planners CHOICE compares with in Table 3 (§8.2.1).

- :func:`minimum_jerk_plan` stands in for cuRobo ({cite}`sundaralingam2023curobo`), "the parallelized
  collision-free minimum-jerk model": the wrist's waypoints between a fixed start and goal minimise the
  squared jerk plus a penalty on coming closer than ``margin`` to an obstacle, read from the scene's
  signed distance (the same geometry the fields are built from). cuRobo optimises a robot's joints
  with a fixed base; here the wrist point itself, at a fixed duration (ours: the straight distance at
  the demonstrations' mean wrist speed). Solved with L-BFGS in torch from the straight line.

- the **diffusion policy** of Chi et al. ({cite}`chi2023diffusionpolicy`), "a generative data-driven planner
  trained with the same set of motion data": a DDPM (``nn.diffusion``, the x0 loss and ancestral sampling)
  over the next ``T_p = 16`` wrist positions, conditioned on an observation — the wrist relative to the goal,
  the goal in the grid, ``c`` and a coarse code of the scene's signed distances — and run closed-loop with
  receding horizon (the first ``T_a = 8`` executed, then a new observation), trained on every frame of the
  planner's training interactions. Chi et al.'s observation horizon of 2 is 1 here, their 1-D temporal
  U-Net an MLP over the chunk, the scene code ours (:class:`DiffusionPolicyConfig`).
"""
from __future__ import annotations

from typing import Callable, Optional

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch

from ..._validate import check_numbers, check_positive_ints, check_shape
from ...infra import TrainedModel, load_or_build, scaled_config, single_threaded, state_dict_to_cpu, trainer_config
from ...nn.denoisers import MLPDenoiser
from ...nn.diffusion import cosine_schedule, sample, train_denoiser
from . import fields, interactions

__all__ = [
    "minimum_jerk_profile",
    "minimum_jerk_plan",
    "DiffusionPolicyConfig",
    "DIFFUSION_POLICY_SCALES",
    "diffusion_policy_config",
    "scene_code",
    "policy_observation",
    "DiffusionPolicy",
    "policy_training_data",
    "train_diffusion_policy",
    "trained_diffusion_policy",
    "diffusion_policy_rollout",
]


def minimum_jerk_profile(n_frames: int) -> np.ndarray:
    """(n,) the minimum-jerk blend ``10s³ − 15s⁴ + 6s⁵`` from 0 to 1 (Flash and Hogan 1985): the jerk-optimal
    free move between two rests."""
    s = np.linspace(0.0, 1.0, int(n_frames))
    return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5


def minimum_jerk_plan(start, goal, n_frames: int, obstacle_sdf: Optional[Callable] = None, *,
                      margin: float = 0.05, obstacle_weight: float = 1e5, iterations: int = 200) -> np.ndarray:
    """A collision-penalised minimum-jerk wrist path from ``start`` to ``goal`` (the cuRobo stand-in).

    The ends are held at rest (two copies of each end pad the jerk's third differences), the interior
    frames minimise ``Σ ‖Δ³x‖² / J₀ + w · mean(max(0, margin − sdf(x)) / margin)²`` (``J₀`` the free move's
    jerk, so that ``w`` weighs the two in the same units; ours).

    Args:
        start, goal: (3,) metres.
        n_frames: frames including both ends (≥ 3).
        obstacle_sdf: ``points (..., 3) torch → (...)`` signed distance to the obstacles (differentiable);
            None: a free move (the result is then the discrete minimum-jerk path).
        margin: metres the penalty keeps from obstacles.
        obstacle_weight: ``w``.
        iterations: L-BFGS iterations.
    Returns:
        (n_frames, 3) metres.
    """
    start = np.asarray(start, dtype=np.float64)
    goal = np.asarray(goal, dtype=np.float64)
    check_shape(start, (3,), "start")
    check_shape(goal, (3,), "goal")
    n = int(n_frames)
    if n < 3:
        raise ValueError(f"n_frames: expected at least 3 frames, got {n_frames!r}")
    s = torch.as_tensor(minimum_jerk_profile(n)[1:-1, None], dtype=torch.float64)
    a, b = torch.as_tensor(start), torch.as_tensor(goal)
    interior = (a + s * (b - a)).clone().requires_grad_(True)
    optimizer = torch.optim.LBFGS([interior], lr=1.0, max_iter=int(iterations), line_search_fn="strong_wolfe")

    def path():
        return torch.cat([a[None], a[None], a[None], interior, b[None], b[None], b[None]])

    with torch.no_grad():  # the free move's jerk: the scale of the jerk term
        jerk_scale = torch.diff(path(), n=3, dim=0).pow(2).sum().clamp_min(1e-12)

    def objective():
        optimizer.zero_grad()
        loss = torch.diff(path(), n=3, dim=0).pow(2).sum() / jerk_scale
        if obstacle_sdf is not None:
            d = obstacle_sdf(interior)
            loss = loss + obstacle_weight * (torch.clamp(margin - d, min=0.0) / margin).pow(2).mean()
        loss.backward()
        return loss

    optimizer.step(objective)
    return path()[2:-2].detach().numpy()


# ----------------------------------------------------------------------------- the diffusion policy


@dataclass(frozen=True)
class DiffusionPolicyConfig:
    """The diffusion-policy baseline (Chi et al. 2023) over wrist positions (defaults: the ``toy`` preset).

    Attributes:
        horizon: ``T_p``, wrist positions predicted per call (Chi et al.: 16).
        action_steps: ``T_a``, of those executed before predicting again (Chi et al.: 8).
        diffusion_steps: DDPM steps ``K`` (Chi et al.: 100; the cosine schedule of ``nn.diffusion``).
        width, depth: the residual-MLP denoiser (``nn.denoisers.MLPDenoiser``; Chi et al. use a 1-D
            temporal U-Net of 256-1024 channels, ours is an MLP over the whole chunk).
        pool: the scene code's cells per axis: the grid's obstacle and target signed distances
            min-pooled to ``pool³`` cells each (ours; Chi et al. observe images or low-dimensional states).
        code_clip: the signed distances are clipped to ``[-code_clip, code_clip]`` metres and divided by it.
        steps, batch_size, lr, lr_schedule: training (CHOICE: 6000 epochs, 2 days on two V100s).
        max_frames: a rollout gives up after this many frames (6 s at 30 fps).
        reach: metres; a rollout ends at the first frame this close to the goal (the grasp happens; ours,
            Table 3's reach tolerance).
        seed: seeds the weights and the batches.
    """

    horizon: int = 16
    action_steps: int = 8
    diffusion_steps: int = 50
    width: int = 256
    depth: int = 3
    pool: int = 4
    code_clip: float = 0.3
    steps: int = 2500
    batch_size: int = 256
    lr: float = 1e-3
    lr_schedule: str = "cosine"
    max_frames: int = 180
    reach: float = 0.02
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("horizon", "action_steps", "diffusion_steps", "width", "depth", "pool", "steps",
                                   "batch_size", "max_frames"))
        if self.action_steps > self.horizon:
            raise ValueError(f"action_steps: expected at most horizon={self.horizon}, got {self.action_steps}")
        check_numbers(self, ("code_clip", "lr", "reach"), above=0)


# Chi et al.: K = 100 DDPM steps; CHOICE trained it for 6000 epochs.
DIFFUSION_POLICY_SCALES = {
    "small": {"diffusion_steps": 100, "width": 512, "steps": 10000},
    "paper": {"diffusion_steps": 100, "width": 1024, "depth": 4, "steps": 100000, "pool": 8},
}


def diffusion_policy_config(scale: str = "toy", **overrides) -> DiffusionPolicyConfig:
    """The preset for ``scale``, fields overridable."""
    return scaled_config(DiffusionPolicyConfig, scale, DIFFUSION_POLICY_SCALES, overrides,
                         factory="diffusion_policy_config")


def scene_code(obstacle_sdf, target_sdf, pool: int, clip: float) -> np.ndarray:
    """(2·pool³,) float32: what the policy sees of the scene.

    Args:
        obstacle_sdf, target_sdf: (n, n, n) signed distances (m) at the grid's cell centres
            (``fields.SceneFields.obstacle_sdf``, ``.target_sdf``).
        pool, clip: each is min-pooled to ``pool³`` cells, clipped to ``±clip`` metres and divided by ``clip``.
    """
    obstacle_sdf = np.asarray(obstacle_sdf, dtype=np.float64)
    n = obstacle_sdf.shape[0]
    check_shape(obstacle_sdf, (n, n, n), "obstacle_sdf")
    check_shape(np.asarray(target_sdf), (n, n, n), "target_sdf")
    if n % pool:
        raise ValueError(f"pool: expected a divisor of the grid's {n} cells per axis, got {pool}")
    b = n // pool
    parts = []
    for sdf in (obstacle_sdf, target_sdf):
        blocks = np.asarray(sdf, dtype=np.float64).reshape(pool, b, pool, b, pool, b).min(axis=(1, 3, 5))
        parts.append(np.clip(blocks, -clip, clip).ravel() / clip)
    return np.concatenate(parts).astype(np.float32)


def policy_observation(grid, wrist, goal, condition, code) -> np.ndarray:
    """(B, 10 + len(code)) float32 observations: the wrist relative to the goal (3, grid frame, m), the goal
    relative to the grid's centre (3, m), ``c`` (4) and the scene code.

    Args:
        wrist: (B, 3) world metres. goal: (3,) world metres. condition: (4,). code: (M,).
    """
    wrist = np.atleast_2d(np.asarray(wrist, dtype=np.float64))
    check_shape(wrist, (None, 3), "wrist")
    goal_local = grid.to_local(np.asarray(goal, dtype=np.float64)[None])[0]
    rest = np.concatenate([goal_local, np.asarray(condition, dtype=np.float64), np.asarray(code, dtype=np.float64)])
    return np.concatenate([grid.to_local(wrist) - goal_local, np.broadcast_to(rest, (len(wrist), len(rest)))],
                          axis=1).astype(np.float32)


def _action_windows(local: np.ndarray, horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """Every frame ``t`` of a (T, 3) path with the next ``horizon`` positions relative to it, padded with
    the last position (Chi et al. pad after the episode's end)."""
    padded = np.concatenate([local, np.repeat(local[-1:], horizon, axis=0)])
    starts = np.arange(len(local))
    chunks = padded[starts[:, None] + 1 + np.arange(horizon)[None]] - local[:, None]
    return starts, chunks


class DiffusionPolicy(torch.nn.Module):
    """The denoiser and the action normalisation (chunks divided by a per-coordinate ``scale``)."""

    def __init__(self, config: DiffusionPolicyConfig, obs_dim: int):
        super().__init__()
        self.config = config
        self.schedule = cosine_schedule(config.diffusion_steps)
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(config.seed)
            self.denoiser = MLPDenoiser(config.horizon * 3, cond_dim=int(obs_dim), width=config.width,
                                        depth=config.depth, schedule=self.schedule)
        self.register_buffer("scale", torch.ones(3))

    def forward(self, x_k, k, cond, drop_cond=None):
        return self.denoiser(x_k, k, cond, drop_cond)


def policy_training_data(dataset, config: DiffusionPolicyConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """``(observations (N, obs), chunks (N, horizon, 3) metres)`` from every frame of every interaction's
    demonstrated wrist path (contact last), in its grid's frame."""
    obs, acts = [], []
    for inter in dataset.interactions:
        points = inter.grid.points()
        code = scene_code(fields.sdf_union(inter.obstacle_objects())(points), inter.target_object().sdf(points),
                          config.pool, config.code_clip)
        local = inter.grid.to_local(inter.wrist)
        starts, chunks = _action_windows(local, config.horizon)
        obs.append(policy_observation(inter.grid, inter.wrist[starts], inter.wrist[-1], inter.condition, code))
        acts.append(chunks)
    return torch.as_tensor(np.concatenate(obs)), torch.as_tensor(np.concatenate(acts), dtype=torch.float32)


@single_threaded
def train_diffusion_policy(dataset, config: DiffusionPolicyConfig, device="cpu", progress: bool = False):
    """Fit the policy's denoiser with the x0 loss of ``nn.diffusion`` on every (observation, next chunk)
    pair of ``dataset`` (no condition dropout: the policy is always conditioned).

    Returns:
        ``(DiffusionPolicy in eval mode, TrainResult)``.
    """
    if not hasattr(dataset, "interactions") or len(dataset.interactions) == 0:
        raise ValueError("dataset: expected an InteractionSet with at least one interaction")
    obs, chunks = policy_training_data(dataset, config)
    model = DiffusionPolicy(config, obs.shape[1])
    model.scale = chunks.reshape(-1, 3).std(0).clamp_min(1e-3)
    result = train_denoiser(model, chunks / model.scale, obs, model.schedule,
                            trainer_config(config, device=device, progress=progress), p_uncond=0.0)
    return model.eval(), result


def trained_diffusion_policy(data_config, config: DiffusionPolicyConfig, device="cpu",
                             progress: bool = False) -> TrainedModel:
    """The policy trained on ``interactions.interaction_set(data_config, "train")`` once, then loaded from the cache.
    ``details``: ``n_pairs`` (observation-chunk pairs) and ``obs_dim``."""
    def build():
        dataset = interactions.interaction_set(data_config, "train")
        model, result = train_diffusion_policy(dataset, config, device=device, progress=progress)
        n_pairs = sum(len(i.wrist) for i in dataset.interactions)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_pairs": n_pairs,
                "obs_dim": int(model.denoiser.cond_dim)}

    key = {"data": dataclasses.asdict(data_config), "model": dataclasses.asdict(config)}
    artifact = load_or_build("choice_diffusion_policy", key, build)
    model = DiffusionPolicy(config, artifact["obs_dim"])
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"n_pairs": artifact["n_pairs"], "obs_dim": artifact["obs_dim"]})


@torch.no_grad()
def diffusion_policy_rollout(model: DiffusionPolicy, scenes, starts, goals, conditions, *, seed: int = 0) -> list:
    """Run the policy closed-loop (receding horizon) in several scenes at once.

    Each round observes every unfinished wrist, samples a chunk of ``horizon`` positions for all of them in
    one batched DDPM call (``nn.diffusion.sample``) and executes the first ``action_steps``; a rollout ends
    at the first frame within ``reach`` of its goal, or after ``max_frames``.

    Args:
        scenes: per case, its ``fields.SceneFields`` (the geometry the policy sees).
        starts, goals: (B, 3) world metres. conditions: (B, 4).
        seed: seeds the sampling noise.
    Returns:
        per case, its wrist path (T, 3) world metres, the start first.
    """
    cfg = model.config
    starts = np.asarray(starts, dtype=np.float64)
    goals = np.asarray(goals, dtype=np.float64)
    check_shape(starts, (len(scenes), 3), "starts")
    check_shape(goals, (len(scenes), 3), "goals")
    conditions = np.asarray(conditions, dtype=np.float64)
    check_shape(conditions, (len(scenes), 4), "conditions")
    codes = [scene_code(s.obstacle_sdf, s.target_sdf, cfg.pool, cfg.code_clip) for s in scenes]
    paths = [[s.copy()] for s in starts]
    active = list(range(len(scenes)))
    generator = torch.Generator().manual_seed(int(seed))
    while active:
        obs = np.concatenate([policy_observation(scenes[i].grid, paths[i][-1], goals[i], conditions[i], codes[i])
                              for i in active])
        cond = torch.as_tensor(obs)
        chunks = sample(lambda x, k: model(x, k, cond), (len(active), cfg.horizon, 3), model.schedule,
                        generator=generator) * model.scale
        still = []
        for row, i in enumerate(active):
            grid = scenes[i].grid
            steps = grid.to_world(grid.to_local(paths[i][-1][None])[0] + chunks[row, :cfg.action_steps].double().numpy())
            close = np.flatnonzero(np.linalg.norm(steps - goals[i], axis=1) < cfg.reach)
            paths[i].extend(steps[:close[0] + 1] if len(close) else steps)
            if not len(close) and len(paths[i]) < cfg.max_frames:
                still.append(i)
        active = still
    return [np.asarray(p[:cfg.max_frames]) for p in paths]
