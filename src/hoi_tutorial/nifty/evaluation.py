"""NIFTY's evaluation run end to end (§4.2-4.5): trained models sampled on the test scenes and scored, cached.

The protocol itself -- the test scenes, the metrics, a table's row -- is :mod:`hoi_tutorial.nifty.scoring`;
here it is applied, once per configuration, to

- the object-conditioned motion model without guidance (:func:`evaluate_motion_model`: NIFTY's Cond. MDM
  baseline, plus its training conditions and the data),
- the model guided by the interaction field, best of N (:func:`evaluate_guided`: NIFTY; with other fields
  or the nearest-anchor objective, the ablations of Tables 2-7),
- the Cond. VAE baseline (:func:`evaluate_cond_vae`),
- the two controls that split NIFTY's gain between guidance and selection (:func:`evaluate_controls`),

with builders for ``infra.warm_cache``. Every result goes through the artifact cache, keyed by the
configurations and the code.

Scaled down: 500 test scenes per action -> 32; sequences of 150 frames -> the model's ``max_frames``.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
import torch

from .._validate import check_choice
from ..infra import load_or_build
from ..infra.presets import scaled_config
from ..world.features import NIFTY_STATE_LAYOUT
from ..world.motion import Motion
from . import baselines, data, guidance, interaction_field, motion_model, scoring
from .scoring import ScoredMotions, MotionScores, approach_length, evaluate_motions, scene_distance_range, test_scenes

__all__ = [
    "EvaluationConfig",
    "EVALUATION_SCALES",
    "evaluation_config",
    "MotionModelEvaluation",
    "evaluate_motion_model",
    "build_evaluation",
    "GUIDED_SCENE_BLOCK",
    "GUIDANCE_OBJECTIVES",
    "GuidedEvaluation",
    "evaluate_guided",
    "build_guided_evaluation",
    "evaluate_cond_vae",
    "CONTROLS",
    "evaluate_controls",
    "ALPHA_GRID",
    "AlphaSweep",
    "guidance_alpha_sweep",
    "pooled_skeleton_medians",
    "build_alpha_sweep",
    "chosen_alpha",
    "chosen_alpha_over_seeds",
    "worst_seed_skeleton_medians",
    "build_table1",
]

APPROACH_QUANTILE = {"sit": 0.5, "lift": 0.15}

# Guided samples are drawn and cached in blocks of this many test scenes (see evaluate_guided).
GUIDED_SCENE_BLOCK = 8
# What evaluate_guided can guide with: NIFTY's learned field, or Appendix D.1's nearest anchor pose.
GUIDANCE_OBJECTIVES = ("field", "nearest_anchor")


@dataclass
class MotionModelEvaluation:
    """What :func:`evaluate_motion_model` returns.

    Attributes:
        n_approach: ``N_A``, approach frames scored for penetration (Appendix C.2).
        training_index: indices into ``dataset.sequences`` of the training sequences sampled.
        test_scenes: the :class:`TestScene` list.
        distance_range: ``(low, high)`` metres, the test scenes' start distances.
        scenes: one unguided sample per test scene (NIFTY's Cond. MDM baseline).
        training: one sample per training condition in ``training_index``.
        data: those training sequences themselves (the synthetic data's own scores).
    """

    n_approach: int
    training_index: list
    test_scenes: list
    distance_range: tuple
    scenes: ScoredMotions
    training: ScoredMotions
    data: ScoredMotions

# --------------------------------------------------------------------------- a trained model, end to end


@dataclass(frozen=True)
class EvaluationConfig:
    """What :func:`evaluate_motion_model` samples and measures (part of its cache key).

    The defaults are the ``toy`` preset; :func:`evaluation_config` gives every scale.

    Attributes:
        n_scenes: random test scenes (NIFTY: 500 per action).
        n_training: training sequences whose own conditions are sampled too (the model's best case).
        n_approach_sequences: data sequences ``N_A`` is estimated from.
        n_object_points: object surface points for D2O and penetration (NIFTY: 2K).
        guidance_scale: classifier-free guidance ``s`` (None: the model's, MDM's 2.5).
        seed: seeds scenes, subsets, point sampling and the sampler's noise.
    """

    n_scenes: int = 32
    n_training: int = 16
    n_approach_sequences: int = 24
    n_object_points: int = 2000
    guidance_scale: Optional[float] = None
    seed: int = 0


# What the larger scales change from the defaults (the toy preset); NIFTY tests 500 scenes per action.
EVALUATION_SCALES = {
    "small": {"n_scenes": 100},
    "paper": {"n_scenes": 500},
}


def evaluation_config(scale: str = "toy", **overrides) -> EvaluationConfig:
    """The evaluation of a scale preset (``"toy"``: 32 test scenes per action), fields overridable."""
    return scaled_config(EvaluationConfig, scale, EVALUATION_SCALES, overrides, factory="evaluation_config")

def _subset(n_total: int, n: int, seed: int, salt: int) -> list[int]:
    rng = np.random.default_rng([int(seed), salt])
    return sorted(int(i) for i in rng.choice(n_total, size=min(int(n), n_total), replace=False))


def _scene_conditions(scenes, n_points: int, seed: int) -> tuple[dict, torch.Tensor]:
    """The raw condition of the test scenes, batched (``CONDITION_KEYS``), and their ``(S, 4, 4)``
    ``world_from_canonical`` placements (``motion_model.interaction_condition`` per scene)."""
    conditions = [motion_model.interaction_condition(s.start, s.obj, n_points, seed=seed) for s in scenes]
    cond = {name: torch.stack([c[name] for c in conditions]) for name in motion_model.CONDITION_KEYS}
    return cond, torch.stack([c["world_from_canonical"] for c in conditions])


def _motions_payload(motions: Sequence[Motion]) -> dict:
    return {"local_rotations": torch.stack([m.local_rotations.float() for m in motions]),
            "root_position": torch.stack([m.root_position.float() for m in motions])}


def _payload_motions(payload: dict, betas: Sequence[torch.Tensor]) -> list[Motion]:
    return [Motion(rots.double(), root.double(), b)
            for rots, root, b in zip(payload["local_rotations"], payload["root_position"], betas)]


def evaluate_motion_model(dataset, model_config, config: Optional[EvaluationConfig] = None, device="cpu",
                          progress: bool = False) -> MotionModelEvaluation:
    """Sample a trained motion model and score it with NIFTY's metrics, once (then from the cache).

    Three sets of motions are scored with :func:`evaluate_motions`:

    - ``"scenes"``: one unguided sample per random test scene (:func:`test_scenes`, start distances
      spanning the training data's, see :func:`scene_distance_range`) — NIFTY's Cond. MDM baseline;
    - ``"training"``: one sample for each of ``n_training`` training sequences' own condition, to
      set beside those sequences;
    - ``"data"``: the same training sequences themselves (the synthetic data's own scores).

    The sampled sets' metrics also hold ``final_distance_positions``: the pelvis-to-centre distance
    of the last frame when the root is read from the predicted positions ``t^p`` instead of the
    integrated velocities (Appendix B), to show how much integration drift contributes.

    Args:
        dataset: a ``nifty.data.SyntheticDataset``.
        model_config: the ``nifty.motion_model.MotionModelConfig`` of the model (trained or loaded
            with ``trained_motion_model``).
        config: an :class:`EvaluationConfig`.
        device: where to train (if needed) and sample.
        progress: True always shows training's progress bar; False, where ``infra.progress`` shows one (a notebook).
    Returns:
        a :class:`MotionModelEvaluation`.
    """
    config = config or EvaluationConfig()
    if not dataset.sequences:
        raise ValueError("dataset: expected at least one training sequence")
    distance_range = scene_distance_range(dataset)
    scenes = test_scenes(dataset.training_anchors, config.n_scenes, distance_range, seed=config.seed)
    training_index = _subset(len(dataset.sequences), config.n_training, config.seed, 1)
    approach_index = _subset(len(dataset.sequences), config.n_approach_sequences, config.seed, 2)
    training = [dataset.sequences[i] for i in training_index]

    def build():
        model = motion_model.trained_motion_model(dataset, model_config, device=device, progress=progress).model
        n_approach = approach_length([dataset.sequences[i].motion for i in approach_index],
                                     [dataset.sequences[i].obj for i in approach_index], dataset.config.action,
                                     max_frames=model_config.max_frames, n_object_points=config.n_object_points,
                                     seed=config.seed)
        # One sampling call for the scenes and the training conditions together.
        scene_cond, scene_placement = _scene_conditions(scenes, model_config.n_points, config.seed)
        tensors = motion_model.InteractionTensors.from_sequences(training, model_config.max_frames,
                                                                 model_config.n_points, model_config.seed)
        cond = {name: torch.cat([scene_cond[name], tensors.condition()[name]]) for name in motion_model.CONDITION_KEYS}
        placement = torch.cat([scene_placement, tensors.world_from_canonical])
        generator = torch.Generator().manual_seed(config.seed)
        states = motion_model.sample_motions(model, cond, generator=generator,
                                             guidance_scale=config.guidance_scale, device=device)
        motions = motion_model.states_to_motions(states, cond["betas"], placement)
        objects = [s.obj for s in scenes] + [s.obj for s in training]
        out = {"n_approach": int(n_approach), "sets": {}}
        parts = {"scenes": (motions[:len(scenes)], objects[:len(scenes)]),
                 "training": (motions[len(scenes):], objects[len(scenes):]),
                 "data": ([s.motion for s in training], objects[len(scenes):])}
        # Appendix B reads the root from integrated velocities; for comparison, where the predicted
        # positions t^p put the last frame.
        last = states[:, -1, NIFTY_STATE_LAYOUT["root_position"]].double()
        last = (placement[:, :3, :3].double() @ last[:, :, None])[..., 0] + placement[:, :3, 3].double()
        centres = torch.as_tensor(np.stack([scoring.object_centre(obj) for obj in objects]))
        positions_end = (last[:, :2] - centres).norm(dim=-1).numpy()
        for name, (ms, objs) in parts.items():
            scores = evaluate_motions(ms, objs, dataset.training_anchors, n_approach, config.n_object_points,
                                      config.seed).as_dict()
            if name == "scenes":
                scores["final_distance_positions"] = positions_end[:len(scenes)]
            elif name == "training":
                scores["final_distance_positions"] = positions_end[len(scenes):]
            out["sets"][name] = {"metrics": scores, **({} if name == "data" else _motions_payload(ms))}
        return out

    key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(model_config),
           "evaluation": dataclasses.asdict(config)}
    artifact = load_or_build(f"nifty_{dataset.config.action}_motion_model_evaluation", key, build)
    betas = {"scenes": [s.start.betas for s in scenes], "training": [s.motion.betas for s in training]}
    sets = {}
    for name, part in artifact["sets"].items():
        motions = [s.motion for s in training] if name == "data" else _payload_motions(part, betas[name])
        sets[name] = ScoredMotions(motions, MotionScores(**part["metrics"]))
    return MotionModelEvaluation(n_approach=int(artifact["n_approach"]), training_index=training_index,
                                 test_scenes=scenes, distance_range=distance_range, **sets)


def build_evaluation(data_config, model_config, config: Optional[EvaluationConfig] = None, device="cpu") -> None:
    """Every artifact :func:`evaluate_motion_model` needs for one action: the synthetic data, the
    trained motion model and its evaluation, built or loaded (for ``infra.warm_cache``, which
    builds the two actions at once).

    Args:
        data_config: a ``nifty.data.SyntheticDataConfig``.
        model_config: a ``nifty.motion_model.MotionModelConfig`` for the same action.
        config: an :class:`EvaluationConfig`.
        device: where to train and sample.
    """
    dataset = data.synthesize(data_config, device=device, progress=False)
    evaluate_motion_model(dataset, model_config, config, device=device)


# --------------------------------------------------------------------------- NIFTY: guided sampling


@dataclass
class GuidedEvaluation:
    """What :func:`evaluate_guided` returns.

    Attributes:
        test_scenes: the scenes sampled (the first ``n_scenes`` of :func:`evaluate_motion_model`'s).
        samples: the kept sample of each scene and its metrics.
        objective: ``(S,)`` the kept samples' final guidance objective (m²).
        all_objectives: ``(S, N)`` every candidate's final objective.
        n_samples, alpha: N and the guidance step size α used.
    """

    test_scenes: list
    samples: ScoredMotions
    objective: np.ndarray
    all_objectives: np.ndarray
    n_samples: int
    alpha: float


def _check_objective(objective: str, field_config) -> None:
    check_choice(objective, GUIDANCE_OBJECTIVES, "objective")
    if objective == "field" and field_config is None:
        raise ValueError("field_config: expected an InteractionFieldConfig for objective='field', got None")


def _objective_for(dataset, model_config, field_config, objective: str, objects, device):
    """``objective_for(cond, n_samples) -> G`` for scenes with these ``objects``: the trained field's
    objective, or D.1's nearest anchor pose of the object (the anchors of each object's category)."""
    if objective == "field":
        field = interaction_field.trained_interaction_field(dataset, model_config, field_config, device=device).model
        return functools.partial(guidance.field_objective, field)
    allowed = torch.tensor([[a.obj.category == obj.category for a in dataset.training_anchors] for obj in objects])
    return functools.partial(guidance.nearest_anchor_objective,
                             guidance.anchor_simplified_poses(dataset.training_anchors), allowed=allowed)


def evaluate_guided(dataset, model_config, field_config, config: Optional[EvaluationConfig] = None, *,
                    n_samples: int = 10, alpha: Optional[float] = None, n_scenes: Optional[int] = None,
                    objective: str = "field", device="cpu") -> GuidedEvaluation:
    """NIFTY on the test scenes: guided by the interaction field, best of ``n_samples`` (§4.1), scored
    with :func:`evaluate_motions`, once (then from the cache).

    With ``objective="nearest_anchor"`` the guidance is Appendix D.1's non-parametric field instead
    (the offset to the nearest training anchor pose of the scene's object category,
    ``guidance.nearest_anchor_objective``; Table 3) and ``field_config`` is not used (pass ``None``).

    The scenes, ``N_A`` and the point sampling are those of :func:`evaluate_motion_model` for the same
    ``config``, so the rows compare scene by scene with its Cond. MDM samples.

    Args:
        dataset: a ``nifty.data.SyntheticDataset``.
        model_config: the motion model's configuration.
        field_config: the ``nifty.interaction_field.InteractionFieldConfig`` of the field.
        config: an :class:`EvaluationConfig` (default: the toy preset).
        n_samples: candidates per scene, N (NIFTY: 10).
        alpha: guidance step size (default: the variant's, ``guidance.step_size``); ``0`` samples without
            guidance and only selects by the objective (the *selection only* control).
        n_scenes: the first this many test scenes (default all).
        objective: ``"field"`` (NIFTY) or ``"nearest_anchor"`` (Table 3's non-parametric field).
        device: where to train (if needed) and sample.
    Returns:
        a :class:`GuidedEvaluation`.
    """
    _check_objective(objective, field_config)
    config = config or EvaluationConfig()
    alpha = guidance.step_size(field_config, objective) if alpha is None else float(alpha)
    unguided = evaluate_motion_model(dataset, model_config, config, device=device)
    scenes = unguided.test_scenes[:n_scenes] if n_scenes is not None else unguided.test_scenes
    if not scenes:
        raise ValueError(f"n_scenes: expected at least one test scene, got {n_scenes!r}")

    def build(start, stop):
        block = scenes[start:stop]
        model = motion_model.trained_motion_model(dataset, model_config, device=device).model
        objective_for = _objective_for(dataset, model_config, field_config, objective, [s.obj for s in block], device)
        cond, placement = _scene_conditions(block, model_config.n_points, config.seed)
        generator = torch.Generator().manual_seed(int(np.random.SeedSequence([config.seed, start]).generate_state(1)[0]))
        out = guidance.guided_samples(model, cond, objective_for, n_samples=n_samples, alpha=alpha, generator=generator,
                                      guidance_scale=config.guidance_scale, device=device)
        motions = motion_model.states_to_motions(out.states, cond["betas"], placement)
        scores = evaluate_motions(motions, [s.obj for s in block], dataset.training_anchors, unguided.n_approach,
                                  config.n_object_points, config.seed)
        return {"metrics": scores.as_dict(), **_motions_payload(motions), "objective": out.objective.numpy(),
                "all_objectives": out.all_objectives.numpy()}

    parts = []
    # Blocks of GUIDED_SCENE_BLOCK scenes, each cached on its own with its own noise: the first scenes give the
    # same samples whether 8 or 32 are asked for, so a later, larger evaluation reuses an earlier one.
    for start in range(0, len(scenes), GUIDED_SCENE_BLOCK):
        stop = min(start + GUIDED_SCENE_BLOCK, len(scenes))
        key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(model_config),
               "field": dataclasses.asdict(field_config) if objective == "field" else None,
               "objective": objective, "evaluation": dataclasses.asdict(config),
               "n_samples": int(n_samples), "alpha": alpha, "scenes": [start, stop]}
        parts.append(load_or_build(f"nifty_{dataset.config.action}_guided_evaluation", key,
                                   functools.partial(build, start, stop)))
    artifact = {"metrics": {name: np.concatenate([np.asarray(p["metrics"][name]) for p in parts])
                            for name in parts[0]["metrics"]},
                "local_rotations": torch.cat([p["local_rotations"] for p in parts]),
                "root_position": torch.cat([p["root_position"] for p in parts]),
                "objective": np.concatenate([np.asarray(p["objective"]) for p in parts]),
                "all_objectives": np.concatenate([np.asarray(p["all_objectives"]) for p in parts])}
    motions = _payload_motions(artifact, [s.start.betas for s in scenes])
    return GuidedEvaluation(test_scenes=scenes, samples=ScoredMotions(motions, MotionScores(**artifact["metrics"])),
                            objective=np.asarray(artifact["objective"]),
                            all_objectives=np.asarray(artifact["all_objectives"]), n_samples=int(n_samples),
                            alpha=alpha)


def build_guided_evaluation(data_config, model_config, field_config, config: Optional[EvaluationConfig] = None, *,
                            n_samples: int = 10, alpha: Optional[float] = None, n_scenes: Optional[int] = None,
                            objective: str = "field", device="cpu") -> None:
    """Every artifact :func:`evaluate_guided` needs for one action (data, motion model and its
    evaluation, interaction field, guided samples), built or loaded: for ``infra.warm_cache``."""
    dataset = data.synthesize(data_config, device=device, progress=False)
    evaluate_guided(dataset, model_config, field_config, config, n_samples=n_samples, alpha=alpha, n_scenes=n_scenes,
                    objective=objective, device=device)


# --------------------------------------------------------------------------- the Cond. VAE baseline


def evaluate_cond_vae(dataset, model_config, vae_config, config: Optional[EvaluationConfig] = None, *,
                      device="cpu") -> ScoredMotions:
    """NIFTY's Cond. VAE baseline (§4.3) on the test scenes: one sample per scene, scored with
    :func:`evaluate_motions`, once (then from the cache).

    The scenes, ``N_A`` and the point sampling are those of :func:`evaluate_motion_model` for the same
    ``config``, so the rows of Table 1 compare scene by scene.

    Args:
        dataset: a ``nifty.data.SyntheticDataset``.
        model_config: the motion model's configuration (its evaluation gives the scenes and ``N_A``).
        vae_config: the ``nifty.baselines.CondVAEConfig`` of the baseline.
        config: an :class:`EvaluationConfig` (default: the toy preset).
        device: where to train (if needed) and sample.
    Returns:
        :class:`ScoredMotions`, one per test scene.
    """
    config = config or EvaluationConfig()
    if vae_config.max_frames != model_config.max_frames:
        raise ValueError(f"vae_config.max_frames: expected the motion model's {model_config.max_frames}, "
                         f"got {vae_config.max_frames}")
    unguided = evaluate_motion_model(dataset, model_config, config, device=device)
    scenes = unguided.test_scenes

    def build():
        model = baselines.trained_cond_vae(dataset, vae_config, device=device).model
        cond, placement = _scene_conditions(scenes, vae_config.n_points, config.seed)
        states = baselines.sample_cond_vae(model, cond, generator=torch.Generator().manual_seed(config.seed))
        motions = motion_model.states_to_motions(states, cond["betas"], placement)
        scores = evaluate_motions(motions, [s.obj for s in scenes], dataset.training_anchors, unguided.n_approach,
                                  config.n_object_points, config.seed)
        return {"metrics": scores.as_dict(), **_motions_payload(motions)}

    key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(model_config),
           "vae": dataclasses.asdict(vae_config), "evaluation": dataclasses.asdict(config)}
    artifact = load_or_build(f"nifty_{dataset.config.action}_cond_vae_evaluation", key, build)
    motions = _payload_motions(artifact, [s.start.betas for s in scenes])
    return ScoredMotions(motions, MotionScores(**artifact["metrics"]))


# --------------------------------------------------------------------------- controls: guidance or selection?

# NIFTY keeps the best of N guided samples by the field's objective G (§4.1), so its gain over one unguided sample
# (Cond. MDM) has two sources. Each control keeps one: "selection only" draws N samples without guidance (α = 0)
# and keeps the best by the same G; "guidance only" draws one guided sample (nothing to select from).
CONTROLS = ("selection only", "guidance only")


def evaluate_controls(dataset, model_config, field_config, config: Optional[EvaluationConfig] = None, *,
                      n_samples: int = 10, alpha: Optional[float] = None, device="cpu") -> dict:
    """Chapter 6's two controls of Table 1 on every test scene, scored, once (then from the cache).

    - ``"selection only"``: ``n_samples`` samples per scene *without* guidance, the one with the lowest
      final field objective G kept (:func:`evaluate_guided` with ``alpha=0``): what choosing the best
      of N by G does alone;
    - ``"guidance only"``: one guided sample per scene (``n_samples=1``, NIFTY's α): what guidance does
      alone.

    The same scenes, model, field (the same G) and N as NIFTY's row, so each compares with NIFTY and
    with Cond. MDM scene by scene.

    Returns:
        ``{"selection only": GuidedEvaluation, "guidance only": GuidedEvaluation}``.
    """
    return {"selection only": evaluate_guided(dataset, model_config, field_config, config, n_samples=n_samples,
                                              alpha=0.0, device=device),
            "guidance only": evaluate_guided(dataset, model_config, field_config, config, n_samples=1, alpha=alpha,
                                             device=device)}


def build_table1(data_config, model_config, field_config, vae_config, config: Optional[EvaluationConfig] = None, *,
                 n_samples: int = 10, device="cpu") -> None:
    """Every artifact of one action's Table 1 (Cond. VAE, Cond. MDM, NIFTY and the two controls on all test
    scenes), built or loaded: for ``infra.warm_cache``, which builds the two actions at once."""
    dataset = data.synthesize(data_config, device=device, progress=False)
    evaluate_guided(dataset, model_config, field_config, config, n_samples=n_samples, device=device)
    evaluate_controls(dataset, model_config, field_config, config, n_samples=n_samples, device=device)
    evaluate_cond_vae(dataset, model_config, vae_config, config, device=device)


# --------------------------------------------------------------------------- choosing α (ours: NIFTY does not state it)

# The step sizes the protocol may try, a factor of about 3 apart (``scripts/choose_guidance_alpha.py`` tries a
# variant's current α and its neighbours, and goes on outwards while the best lies at an end).
ALPHA_GRID = (0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0)


@dataclass
class AlphaSweep:
    """What :func:`guidance_alpha_sweep` returns for one action and one variant.

    Attributes:
        alphas: the step sizes tried.
        scores: ``{α: MotionScores}`` of the kept sample per training condition.
        objective: ``{α: (C,)}`` each kept sample's final guidance objective (m²).
        guide_last_step: whether the last denoising step was guided too.
        n_samples: candidates per condition, N (the best by the objective kept).
    """

    alphas: tuple
    scores: dict
    objective: dict
    guide_last_step: bool
    n_samples: int = 1

    def summary(self) -> dict:
        """``{α: {"G (m², median)", "skeleton distance (m, median)", "D2O ≤ 2 cm"}}``."""
        return {alpha: {"G (m², median)": float(np.median(self.objective[alpha])),
                        "skeleton distance (m, median)": float(np.median(self.scores[alpha].skeleton_distance)),
                        "D2O ≤ 2 cm": float(np.mean(self.scores[alpha].d2o <= 0.02))}
                for alpha in self.alphas}


def guidance_alpha_sweep(dataset, model_config, field_config, config: Optional[EvaluationConfig] = None, *,
                         alphas: Sequence[float] = ALPHA_GRID, objective: str = "field", guide_last_step: bool = False,
                         n_samples: int = 1, device="cpu") -> AlphaSweep:
    """The protocol that chooses a variant's guidance step size α (Eq. 4; NIFTY does not state α), once
    (then from the cache).

    For each α, ``n_samples`` guided candidates for each of the ``config.n_training`` training conditions
    :func:`evaluate_motion_model` samples (the training sequences' own starts and objects, never a test
    scene), the one with the lowest final objective kept (as the tables sample; N = 1: nothing selects),
    scored by :func:`evaluate_motions` against the training anchors.
    :func:`chosen_alpha` reads the result; ``scripts/choose_guidance_alpha.py`` runs it for every variant.

    Args:
        dataset, model_config, field_config, config: as :func:`evaluate_guided` (``field_config`` ``None``
            for ``objective="nearest_anchor"``).
        alphas: the step sizes to try (each > 0).
        objective: ``"field"`` or ``"nearest_anchor"``.
        guide_last_step: guide the last denoising step too (``guidance.guided_samples``).
        n_samples: candidates per condition, N (the tables: 10).
        device: where to sample.
    Returns:
        an :class:`AlphaSweep`.
    """
    _check_objective(objective, field_config)
    if isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 1:
        raise ValueError(f"n_samples: expected a positive int, got {n_samples!r}")
    alphas = tuple(float(a) for a in alphas)
    if not alphas or not all(a > 0 for a in alphas):
        raise ValueError(f"alphas: expected step sizes > 0, got {alphas!r}")
    config = config or EvaluationConfig()
    unguided = evaluate_motion_model(dataset, model_config, config, device=device)
    sequences = [dataset.sequences[i] for i in unguided.training_index]
    objects = [s.obj for s in sequences]

    def build(alpha):
        model = motion_model.trained_motion_model(dataset, model_config, device=device).model
        tensors = motion_model.InteractionTensors.from_sequences(sequences, model_config.max_frames,
                                                                 model_config.n_points, model_config.seed)
        cond = {name: tensors.condition()[name] for name in motion_model.CONDITION_KEYS}
        objective_for = _objective_for(dataset, model_config, field_config, objective, objects, device)
        samples = guidance.guided_samples(model, cond, objective_for, n_samples=n_samples, alpha=alpha,
                                          generator=torch.Generator().manual_seed(config.seed),
                                          guidance_scale=config.guidance_scale, guide_last_step=guide_last_step,
                                          device=device)
        motions = motion_model.states_to_motions(samples.states, cond["betas"], tensors.world_from_canonical)
        scores = evaluate_motions(motions, objects, dataset.training_anchors, unguided.n_approach,
                                  config.n_object_points, config.seed)
        return {"metrics": scores.as_dict(), "objective": samples.objective.numpy()}

    # One artifact per α, each with the same noise: a grid extended later reuses the step sizes already tried.
    field = dataclasses.asdict(field_config) if objective == "field" else None
    artifacts = {}
    for alpha in alphas:
        key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(model_config), "field": field,
               "objective": objective, "evaluation": dataclasses.asdict(config), "alpha": alpha,
               "guide_last_step": guide_last_step, "n_samples": n_samples}
        artifacts[alpha] = load_or_build(f"nifty_{dataset.config.action}_alpha_sweep", key,
                                         functools.partial(build, alpha))
    return AlphaSweep(alphas=alphas, scores={a: MotionScores(**artifacts[a]["metrics"]) for a in alphas},
                      objective={a: np.asarray(artifacts[a]["objective"]) for a in alphas},
                      guide_last_step=guide_last_step, n_samples=n_samples)


def build_alpha_sweep(data_config, model_config, field_config, config: Optional[EvaluationConfig] = None,
                      **kwargs) -> None:
    """:func:`guidance_alpha_sweep` for one action, built or loaded: for ``infra.warm_cache``."""
    dataset = data.synthesize(data_config, progress=False)
    guidance_alpha_sweep(dataset, model_config, field_config, config, **kwargs)


def pooled_skeleton_medians(sweeps: Sequence[AlphaSweep]) -> dict:
    """``{α: median skeleton distance (m)}`` over the training conditions of every sweep given, pooled."""
    sweeps = list(sweeps)
    if not sweeps or any(s.alphas != sweeps[0].alphas for s in sweeps):
        raise ValueError("sweeps: expected at least one AlphaSweep, all over the same alphas")
    return {alpha: float(np.median(np.concatenate([s.scores[alpha].skeleton_distance for s in sweeps])))
            for alpha in sweeps[0].alphas}


def chosen_alpha(sweeps: Sequence[AlphaSweep]) -> float:
    """The α whose samples end closest to the training anchors: the lowest median skeleton distance over
    the training conditions of every sweep given (e.g. sit and lift), pooled. Ties go to the smaller α."""
    pooled = pooled_skeleton_medians(sweeps)
    return min(pooled, key=lambda alpha: (pooled[alpha], alpha))


def worst_seed_skeleton_medians(sweeps_by_seed: dict) -> dict:
    """``{α: the largest over the seeds of each seed's median skeleton distance (m)}``, each seed's sweeps (e.g. sit
    and lift) pooled by :func:`pooled_skeleton_medians`; ``sweeps_by_seed``: ``{seed: [AlphaSweep, ...]}``."""
    if not sweeps_by_seed:
        raise ValueError("sweeps_by_seed: expected at least one seed's sweeps")
    per_seed = [pooled_skeleton_medians(sweeps) for sweeps in sweeps_by_seed.values()]
    if any(set(medians) != set(per_seed[0]) for medians in per_seed):
        raise ValueError("sweeps_by_seed: expected every seed's sweeps over the same alphas")
    return {alpha: max(medians[alpha] for medians in per_seed) for alpha in per_seed[0]}


def chosen_alpha_over_seeds(sweeps_by_seed: dict) -> float:
    """The α chosen over several seeds by the worst of them: for each α, each seed's median skeleton distance
    (its sweeps, e.g. sit and lift, pooled), the largest over the seeds; the α whose largest is lowest. Ties go
    to the smaller α. With one seed it is :func:`chosen_alpha`.

    Ours (NIFTY states no α). One α serves every seed a reader may type, and a seed whose samples fall apart at
    an α a pooled median would still prefer (the others' samples carrying the median) is what a reader meets:
    the worst seed guards against it.

    Args:
        sweeps_by_seed: ``{seed: [AlphaSweep, ...]}``, every sweep over the same alphas.
    """
    worst = worst_seed_skeleton_medians(sweeps_by_seed)
    return min(worst, key=lambda alpha: (worst[alpha], alpha))
