"""GoalNet (SAMP §3.2, §4.3, Appendix A.2 and B.2): where on an object to sit, and facing which way.

The algorithm box, as this module runs it:

1. **Goal data** (§4.3): objects of five categories (sofas, L-shaped sofas, chairs, armchairs,
   tables; Table S.2), each with its labelled sitting goals ``g = [g^p, g^d]`` (pelvis position,
   forward direction); "augmented by randomly scaling the objects across the xyz axes". Each goal
   is expressed in the object's *centre frame* (its axes, origin at its box centre), and the object
   by its interaction voxels in that frame, ``I`` (2048 numbers; "the voxel position relative to the
   object center instead of the character root").
2. **Training** (Eq. 4): ``‖ĝ^p − g^p‖² + ‖ĝ^d − g^d‖² + β₂ KL(Q(Z_goal | g, I) ‖ N(0, I))`` with
   ``β₂ = 0.5``, Adam at 1e-3 (Appendix B.2).
3. **Sampling** (§3.2): ``Z_goal ~ N(0, I)``, decoded with ``I`` of the target object; the goal is
   moved from the centre frame to the world.
4. **Evaluation** (§5.2): the reconstruction error of unseen goals on test objects (cm, degrees) and
   the diversity of generated goals, APD-Pos and APD-Rot (Eqs. 7–8, ``metrics.goal_apd``), against
   the labelled goals' own APD.

Scaling (paper → toy): 87 ShapeNet objects with 1–5 hand-labelled goals → 87 procedural toy
objects of the same categories and counts, with the toy world's annotated goals; ~13K augmented
samples → 20 random xyz scalings per object (scale factors uniform in [0.8, 1.25] per axis: ours,
the paper states no range); 100 epochs → 2000 steps of 64, the KL weight rising from 0 to β₂ over
them (ours: without it the toy GoalNet's posterior collapses). The networks keep the paper's sizes
(they are small); goals and voxels are standardised inside the network. The unseen test objects are new instances of the same categories at their
sampled sizes. Lying goals are not GoalNet's (§4.3 labels sitting goals): sofas give theirs directly.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Optional

import numpy as np
import torch

from .._validate import check_choice, check_numbers, check_positive_ints
from ..infra import (TrainedModel, TrainResult, load_or_build, scaled_config, single_threaded, state_dict_to_cpu,
                     train, trainer_config)
from ..metrics import goal_apd, goal_reconstruction_error
from ..nn.cvae import gaussian_kl
from ..world.objects import SITTABLE, ToyObject, make_object
from .core import GOAL_SIZE, VOXEL_SIZE, GoalNetCVAE

__all__ = [
    "GOAL_CATEGORIES",
    "PAPER_INSTANCES",
    "GoalDataConfig",
    "goal_data_config",
    "GoalData",
    "goal_data",
    "object_goals",
    "GoalNetConfig",
    "GOALNET_SCALES",
    "goalnet_config",
    "build_goalnet",
    "train_goalnet",
    "trained_goalnet",
    "sample_goals",
    "reconstruct_goals",
    "GoalNetEvaluation",
    "evaluate_goalnet",
]

GOAL_CATEGORIES = ("chair", "armchair", "sofa", "l_sofa", "table")  # SAMP §4.3
PAPER_INSTANCES = {"armchair": 15, "chair": 16, "sofa": 20, "l_sofa": 18, "table": 18}  # SAMP Table S.2 (87)
_SPLITS = ("train", "test")


# ----------------------------------------------------------------------------- data


@dataclass(frozen=True)
class GoalDataConfig:
    """GoalNet's goal data (defaults: the ``toy`` preset).

    Attributes:
        instances: ``((category, count), ...)`` training objects per category (SAMP Table S.2).
        scalings: randomly scaled copies of each training object (SAMP: ~13K samples in all).
        scale_range: ``(low, high)`` of each axis's scale factor (ours; not stated in SAMP).
        test_instances: unseen objects per category for the evaluation (unscaled).
        seed: seeds the instances and the scalings.
    """

    instances: tuple = tuple((c, PAPER_INSTANCES[c]) for c in GOAL_CATEGORIES)
    scalings: int = 20
    scale_range: tuple = (0.8, 1.25)
    test_instances: int = 10
    seed: int = 0

    def __post_init__(self):
        for entry in self.instances:
            if not (isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[1], int) and entry[1] >= 1):
                raise ValueError(f"instances: expected (category, positive count) pairs, got {entry!r}")
            check_choice(entry[0], SITTABLE, "instances category")
        check_positive_ints(self, ("scalings", "test_instances"))
        low, high = self.scale_range
        if not 0 < low <= high:
            raise ValueError(f"scale_range: expected 0 < low <= high, got {self.scale_range!r}")


# SAMP's own sizes under "paper": ~13K samples from its 87 objects (about 150 scalings each).
GOAL_DATA_SCALES = {"small": {"scalings": 60}, "paper": {"scalings": 150, "test_instances": 30}}


def goal_data_config(scale: str = "toy", **overrides) -> GoalDataConfig:
    """The preset for ``scale``, fields overridable."""
    return scaled_config(GoalDataConfig, scale, GOAL_DATA_SCALES, overrides, factory="goal_data_config")


def object_goals(obj: ToyObject) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An object's GoalNet sample(s): its voxels and its sitting goals, all in its centre frame.

    Returns:
        ``(voxels (2048,), positions (K, 3) metres, directions (K, 3) unit)``, float32; the
        voxels and goals do not change when the object is moved (they are in its own frame).
    """
    frame = obj.centre_frame
    voxels = obj.interaction_voxels(frame).reshape(-1).astype(np.float32)
    positions, directions = obj.sit_goals
    local = (positions - frame[:3, 3]) @ frame[:3, :3]
    return voxels, local.astype(np.float32), (directions @ frame[:3, :3]).astype(np.float32)


@dataclass
class GoalData:
    """Goal samples: one row per (object, goal).

    Attributes:
        voxels: ``(N, 2048)`` the object's interaction voxels in its centre frame.
        goals: ``(N, 6)`` ``[g^p (m), g^d (unit)]`` in the same frame.
        object_index: ``(N,)`` int64, which object of ``categories`` the row belongs to.
        categories: the category of each object (length ``n_objects``).
        object_voxels: ``(n_objects, 2048)`` one voxel code per object (for sampling).
    """

    voxels: torch.Tensor
    goals: torch.Tensor
    object_index: torch.Tensor
    categories: list
    object_voxels: torch.Tensor

    def __len__(self) -> int:
        return int(self.goals.shape[0])

    @property
    def n_objects(self) -> int:
        return len(self.categories)


def _objects(config: GoalDataConfig, split: str) -> list[ToyObject]:
    objects = []
    salt = _SPLITS.index(split)
    for k, (category, count) in enumerate(config.instances):
        count = count if split == "train" else config.test_instances
        for i in range(count):
            instance_seed = int(np.random.default_rng([config.seed, salt, k, i]).integers(2**31))
            if split == "test":
                objects.append(make_object(category, seed=instance_seed))
                continue
            rng = np.random.default_rng([config.seed, salt, k, i, 1])
            for _ in range(config.scalings):
                scale = rng.uniform(*config.scale_range, size=3)
                objects.append(make_object(category, seed=instance_seed, size_scale=scale))
    return objects


def goal_data(config: GoalDataConfig, split: str = "train") -> GoalData:
    """The goal samples of ``split`` (``"train"``: the scaled training objects; ``"test"``: unseen
    objects, new instances of the same categories), built once and then loaded from the cache."""
    check_choice(split, _SPLITS, "split")

    def build():
        voxels, goals, index, categories, object_voxels = [], [], [], [], []
        for n, obj in enumerate(_objects(config, split)):
            code, positions, directions = object_goals(obj)
            object_voxels.append(code)
            categories.append(obj.category)
            for p, d in zip(positions, directions):
                voxels.append(code)
                goals.append(np.concatenate([p, d]))
                index.append(n)
        return {"voxels": torch.as_tensor(np.stack(voxels)), "goals": torch.as_tensor(np.stack(goals)),
                "object_index": torch.as_tensor(index, dtype=torch.int64), "categories": categories,
                "object_voxels": torch.as_tensor(np.stack(object_voxels))}

    artifact = load_or_build(f"samp_goal_data_{split}", dataclasses.asdict(config), build, verbose=False)
    return GoalData(**artifact)


# ----------------------------------------------------------------------------- model


@dataclass(frozen=True)
class GoalNetConfig:
    """GoalNet and its training (defaults: the ``toy`` preset).

    Attributes:
        interaction_hidden, interaction_out: the interaction encoder ({512, 512, 64}, Appendix B.2).
        hidden: the encoder's hidden widths, reversed in the decoder (REFERENCE_NOTES).
        latent: size of ``Z_goal`` (SAMP: 3).
        kl_weight: β₂ of Eq. 4 (SAMP: 0.5).
        kl_warmup: steps over which the KL weight rises linearly from 0 to ``kl_weight`` (KL annealing,
            Bowman et al. 2016; ours, SAMP states none: with the full weight from the first step the toy
            GoalNet's posterior collapses onto the prior and every sample is the same goal). At toy
            scale it rises over the whole training; over its first half, seeds 1 and 2 collapsed on
            sofas (generated seats 3 and 1 cm apart) where the whole-run ramp kept seed 2's apart.
        steps, batch_size, lr, lr_schedule, warmup_steps, grad_clip, optimizer: training (SAMP: Adam,
            1e-3, 100 epochs; the batch size is not stated).
        seed: seeds the weights, the batches and the latent draws.
    """

    interaction_hidden: tuple = (512, 512)
    interaction_out: int = 64
    hidden: tuple = (32, 16, 8)
    latent: int = 3
    kl_weight: float = 0.5
    kl_warmup: int = 2000
    steps: int = 2000
    batch_size: int = 64
    lr: float = 1e-3
    lr_schedule: str = "constant"
    warmup_steps: int = 0
    grad_clip: Optional[float] = None
    optimizer: str = "adam"
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("interaction_out", "latent", "steps", "batch_size"))
        if not isinstance(self.kl_warmup, int) or self.kl_warmup < 0:
            raise ValueError(f"kl_warmup: expected an int >= 0 (steps), got {self.kl_warmup!r}")
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("kl_weight",), at_least=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)


# 100 epochs of ~13K samples (SAMP Appendix B.2) at a batch of 64 is ~20K steps.
GOALNET_SCALES = {"small": {"steps": 6000, "kl_warmup": 6000}, "paper": {"steps": 20000, "kl_warmup": 0}}


def goalnet_config(scale: str = "toy", **overrides) -> GoalNetConfig:
    """The preset for ``scale``, fields overridable."""
    return scaled_config(GoalNetConfig, scale, GOALNET_SCALES, overrides, factory="goalnet_config")


def build_goalnet(config: GoalNetConfig, data: Optional[GoalData] = None) -> GoalNetCVAE:
    """A freshly initialised GoalNet, its weights seeded by ``config.seed`` (global RNG untouched),
    standardising with ``data``'s statistics (none: identity, e.g. before loading a state dict)."""
    stats = {}
    if data is not None:
        # A coordinate that never varies (an always-empty cell) keeps a unit scale.
        stats = {"goal_mean": data.goals.mean(0), "goal_std": data.goals.std(0).clamp_min(1e-3),
                 "voxel_mean": data.voxels.mean(0), "voxel_std": data.voxels.std(0).clamp_min(1e-3)}
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return GoalNetCVAE(config.interaction_hidden, config.interaction_out, config.hidden, config.latent, **stats)


@single_threaded
def train_goalnet(data: GoalData, config: GoalNetConfig, device="cpu",
                  progress: bool = False) -> tuple[GoalNetCVAE, TrainResult]:
    """Minimise Eq. 4 over random batches of ``data`` (its KL weight annealed over ``config.kl_warmup``).

    Returns:
        ``(model in eval mode, TrainResult)``; the result's ``extra`` holds ``"reconstruction"``
        (the two squared errors, summed over the standardised coordinates) and ``"kl"`` per step.
    """
    if not isinstance(data, GoalData) or len(data) == 0:
        raise ValueError("data: expected GoalData with at least one goal")
    model = build_goalnet(config, data)

    def sample_batch(step: int, generator: torch.Generator):
        index = torch.randint(0, len(data), (config.batch_size,), generator=generator)
        return {"goals": data.goals[index], "voxels": data.voxels[index],
                "seed": torch.randint(0, 2**62, (1,), generator=generator),
                "kl_weight": config.kl_weight * min(1.0, (step + 1) / config.kl_warmup) if config.kl_warmup
                else config.kl_weight}

    def loss_fn(net, batch):
        generator = torch.Generator(device=batch["goals"].device).manual_seed(int(batch["seed"]))
        reconstruction, target, mu, logvar = net(batch["goals"], batch["voxels"], generator)
        squared = (reconstruction - target).pow(2).sum(dim=-1).mean()
        kl = gaussian_kl(mu, logvar).mean()
        return squared + batch["kl_weight"] * kl, {"reconstruction": squared.detach(), "kl": kl.detach()}

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.eval(), result


def trained_goalnet(data_config: GoalDataConfig, config: GoalNetConfig, device="cpu",
                    progress: bool = False) -> TrainedModel:
    """GoalNet trained on ``goal_data(data_config, "train")`` once, then loaded from the cache.

    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel` whose ``details`` hold ``n_goals`` and
        ``n_objects`` (training samples and scaled objects) and the final ``reconstruction`` and
        ``kl`` terms (means over the last 100 steps).
    """
    def build():
        data = goal_data(data_config, "train")
        model, result = train_goalnet(data, config, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_goals": len(data), "n_objects": data.n_objects,
                "reconstruction": float(np.mean(result.extra["reconstruction"][-100:])),
                "kl": float(np.mean(result.extra["kl"][-100:]))}

    key = {"data": dataclasses.asdict(data_config), "model": dataclasses.asdict(config)}
    artifact = load_or_build("samp_goalnet", key, build)
    model = build_goalnet(config)
    model.load_state_dict(artifact["state"])
    details = {name: artifact[name] for name in ("n_goals", "n_objects", "reconstruction", "kl")}
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"], details)


# ----------------------------------------------------------------------------- sampling


def _split_goals(goals: torch.Tensor) -> tuple[np.ndarray, np.ndarray]:
    goals = goals.detach().cpu().double().numpy()
    directions = goals[..., 3:]
    norm = np.linalg.norm(directions, axis=-1, keepdims=True)
    return goals[..., :3], directions / np.maximum(norm, 1e-9)


@torch.no_grad()
def sample_goals(model: GoalNetCVAE, obj: ToyObject, n: int, *, generator: torch.Generator,
                 frame: str = "world") -> tuple[np.ndarray, np.ndarray]:
    """``n`` goals for ``obj`` from GoalNet's decoder, ``Z_goal ~ N(0, I)`` (SAMP §3.2).

    Args:
        model: a trained :class:`~hoi_tutorial.samp.core.GoalNetCVAE`.
        obj: the target object, placed anywhere (its voxels are read in its own centre frame).
        n: how many goals.
        generator: ``torch.Generator`` for the latent draws.
        frame: ``"world"`` (positions moved with the object) or ``"centre"`` (the object's centre frame).
    Returns:
        ``(positions (n, 3) metres, directions (n, 3) unit)``.
    """
    if not isinstance(model, GoalNetCVAE):
        raise TypeError(f"model: expected a GoalNetCVAE, got {type(model).__name__}")
    if not isinstance(obj, ToyObject):
        raise TypeError(f"obj: expected a ToyObject, got {type(obj).__name__}")
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise ValueError(f"n: expected a positive int, got {n!r}")
    check_choice(frame, ("world", "centre"), "frame")
    voxels = obj.interaction_voxels(obj.centre_frame).reshape(-1).astype(np.float32)
    device = next(model.parameters()).device
    code = torch.as_tensor(voxels, device=device).expand(n, VOXEL_SIZE)
    z = torch.randn(n, model.latent, generator=generator).to(device)
    positions, directions = _split_goals(model.decode(z, code))
    if frame == "centre":
        return positions, directions
    centre = obj.centre_frame
    return positions @ centre[:3, :3].T + centre[:3, 3], directions @ centre[:3, :3].T


@torch.no_grad()
def reconstruct_goals(model: GoalNetCVAE, data: GoalData) -> torch.Tensor:
    """``(N, 6)`` each goal of ``data`` encoded and decoded through its posterior mean (§5.2's
    reconstruction of unseen goals); directions unnormalised."""
    mu, _ = model.posterior(data.goals, data.voxels)
    return model.decode(mu, data.voxels)


@dataclass
class GoalNetEvaluation:
    """SAMP §5.2's GoalNet numbers on unseen objects.

    Attributes:
        position_error: metres, mean reconstruction error of the test goals' positions.
        angle_error: degrees, the same for their directions.
        n_test_goals, n_test_objects: what they are measured on.
        apd_pos, apd_rot: metres, degrees: APD (Eqs. 7–8) of ``n_generated`` goals per test object.
        gt_apd_pos, gt_apd_rot: the same for the labelled goals, over the objects with at least two
            (``n_gt_objects`` of them; each object weighs the same).
        apd_by_category: ``{category: {"apd_pos", "apd_rot"}}`` of the generated goals.
        n_generated: N of Eqs. 7–8.
        position_errors: ``(n_test_goals,)`` metres, each test goal's reconstruction error (their mean is
            ``position_error``): the cases for a paired comparison with another reading of the decoder.
        apd_pos_by_object: ``(n_test_objects,)`` metres, each test object's APD-Pos (a category's mean is its
            ``apd_by_category`` entry), in the order of ``data.categories``.
    """

    position_error: float
    angle_error: float
    n_test_goals: int
    n_test_objects: int
    apd_pos: float
    apd_rot: float
    gt_apd_pos: float
    gt_apd_rot: float
    n_gt_objects: int
    apd_by_category: dict
    n_generated: int
    position_errors: np.ndarray
    apd_pos_by_object: np.ndarray


def _labelled_apd(data: GoalData) -> tuple[float, float, int]:
    pos, rot = [], []
    for n in range(data.n_objects):
        rows = data.goals[data.object_index == n]
        if len(rows) >= 2:
            positions, directions = _split_goals(rows)
            apd = goal_apd(positions[None], directions[None])
            pos.append(apd["apd_pos"])
            rot.append(apd["apd_rot"])
    if not pos:
        return float("nan"), float("nan"), 0
    return float(np.mean(pos)), float(np.mean(rot)), len(pos)


@torch.no_grad()
def evaluate_goalnet(model: GoalNetCVAE, data: GoalData, n_generated: int = 10, seed: int = 0) -> GoalNetEvaluation:
    """Reconstruction error and goal diversity on ``data`` (the unseen test objects, SAMP §5.2)."""
    if not isinstance(n_generated, int) or n_generated < 2:
        raise ValueError(f"n_generated: expected an int >= 2 (APD compares pairs), got {n_generated!r}")
    positions, directions = _split_goals(reconstruct_goals(model, data))
    true_positions, true_directions = _split_goals(data.goals)
    errors = goal_reconstruction_error(positions, directions, true_positions, true_directions)
    generator = torch.Generator().manual_seed(int(seed))
    z = torch.randn(data.n_objects * n_generated, model.latent, generator=generator)
    codes = data.object_voxels.repeat_interleave(n_generated, dim=0)
    gen_positions, gen_directions = _split_goals(model.decode(z, codes).reshape(data.n_objects, n_generated,
                                                                                 GOAL_SIZE))
    overall = goal_apd(gen_positions, gen_directions)
    categories = np.asarray(data.categories)
    by_category = {c: goal_apd(gen_positions[categories == c], gen_directions[categories == c])
                   for c in dict.fromkeys(data.categories)}
    gt_pos, gt_rot, n_gt = _labelled_apd(data)
    per_goal = np.linalg.norm(np.asarray(positions, dtype=np.float64) - np.asarray(true_positions, dtype=np.float64),
                              axis=-1)
    per_object = np.array([goal_apd(gen_positions[i:i + 1], gen_directions[i:i + 1])["apd_pos"]
                           for i in range(data.n_objects)])
    return GoalNetEvaluation(
        position_error=errors["position_error"], angle_error=errors["angle_error"], n_test_goals=len(data),
        n_test_objects=data.n_objects, apd_pos=overall["apd_pos"], apd_rot=overall["apd_rot"],
        gt_apd_pos=gt_pos, gt_apd_rot=gt_rot, n_gt_objects=n_gt, apd_by_category=by_category,
        n_generated=n_generated, position_errors=per_goal, apd_pos_by_object=per_object)
