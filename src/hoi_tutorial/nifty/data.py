"""NIFTY's synthetic interaction data, end to end and cached (§3.3).

1. toy mocap (the stand-in for AMASS) -> 2. the time-reversed prior trained on it ->
3. anchors for the interaction across toy subjects and objects -> 4. one tree per anchor
(Algorithm 1) -> 5. every root-to-node path played forwards, minus those starting within 1 m.

Each stage goes through the artifact cache, keyed by its configuration and by this package's code.
Objects and anchors are cheap and deterministic, so they are regenerated rather than stored;
the cache keeps the trained prior and the rollout paths.

Scaling (paper -> toy): 174 sitting / 72 lifting anchors from 7 subjects -> 4 subjects x 2 anchors,
with further rounds of 8 anchors while fewer than 48 sequences are kept (at most 8 rounds);
tree depth 7 -> 4 and, with it, the start-distance filter 1 m -> 0.75 m; 200K / 110K sequences -> a few hundred; HuMoR trained on AMASS for days ->
the prior trained on a few dozen toy clips for under a minute.
"""
from __future__ import annotations

import dataclasses
import functools
import warnings
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import torch

from .._validate import check_choice, check_positive_ints
from ..infra import TrainedModel, load_or_build, state_dict_to_cpu
from ..infra.presets import check_scale, scaled_config
from ..world import mocap
from ..world.motion import FPS, Motion, action_id
from . import motion_prior, rollout
from .anchors import Anchor, collect_anchors
from .motion_prior import PriorConfig, ReversePrior, prior_config, train_reverse_prior
from .rollout import (InteractionSequence, PruneConfig, TreeConfig, grow_trees, joint_limits_from,
                      skating_limit_from, start_distance, tree_config)

__all__ = [
    "PRIOR_MOCAP_KINDS",
    "SyntheticDataConfig",
    "SYNTHETIC_DATA_SCALES",
    "PAPER_ANCHORS_PER_SUBJECT",
    "synthetic_data_config",
    "prior_training_clips",
    "prune_settings",
    "trained_prior",
    "SyntheticDataset",
    "synthesize",
    "survival_by_depth",
    "failure_counts",
    "recheck_sequences",
    "recheck_failures",
]

# What the scene-unaware prior learns from (NIFTY: AMASS without jumping/dancing): locomotion,
# standing, and the sitting and lifting transitions, with no object in the state.
PRIOR_MOCAP_KINDS = ("walk", "turn", "side_step", "idle", "sit", "lift")


@dataclass(frozen=True)
class SyntheticDataConfig:
    """Everything that determines a synthetic dataset (the cache key).

    The defaults are the ``toy`` preset for sitting; :func:`synthetic_data_config` gives every
    scale and action.

    Attributes:
        action: ``"sit"`` or ``"lift"``.
        clips_per_kind: toy-mocap clips per kind of ``PRIOR_MOCAP_KINDS`` for the prior.
        mocap_subjects: toy subjects in the prior's training mocap.
        n_subjects: subjects the anchors come from (NIFTY: 7).
        anchors_per_subject: anchors per subject (NIFTY: ~25 sitting, ~10 lifting).
        prior: the prior's sizes and training settings (``motion_prior.prior_config``).
        tree: Algorithm 1's settings (``rollout.tree_config``).
        prune: PruneCheck thresholds (the joint limits are derived from the mocap, see
            :func:`prune_settings`).
        check_skating: PruneCheck also rejects nodes whose feet skate more than the mocap's worst
            second (our addition to NIFTY's checks, see ``rollout.PruneConfig.skating``). Off in
            every preset: at toy scale it leaves few sitting paths (chapter 3 measures the share
            of the kept sequences that would pass it).
        min_sequences: the dataset's stated minimum: while fewer sequences are kept, a further
            round of anchors (``anchors_per_subject`` more per subject) grows its trees (our
            addition: NIFTY's 174 / 72 anchors always give enough paths, a handful of toy anchors
            may give none for an unlucky seed).
        max_anchor_rounds: at most this many rounds of anchors; :func:`synthesize` warns when the
            minimum is still not reached.
        seed: base seed (:func:`synthetic_data_config` also gives it to the prior).
    """

    action: str = "sit"
    clips_per_kind: int = 8
    mocap_subjects: int = 4
    n_subjects: int = 4
    anchors_per_subject: int = 2
    prior: PriorConfig = field(default_factory=PriorConfig)
    tree: TreeConfig = field(default_factory=TreeConfig)
    prune: PruneConfig = field(default_factory=PruneConfig)
    check_skating: bool = False
    min_sequences: int = 48
    max_anchor_rounds: int = 8
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("clips_per_kind", "mocap_subjects", "n_subjects", "anchors_per_subject",
                                   "min_sequences", "max_anchor_rounds"))


# What the larger scales change from the defaults (the toy preset); the prior and the trees take
# theirs from ``motion_prior.PRIOR_SCALES`` and ``rollout.TREE_SCALES``.
SYNTHETIC_DATA_SCALES = {
    "small": {"clips_per_kind": 30, "mocap_subjects": 7, "n_subjects": 7, "anchors_per_subject": 8},
    "paper": {"clips_per_kind": 200, "mocap_subjects": 20, "n_subjects": 7},
}
# NIFTY: 174 sitting / 72 lifting anchors from 7 subjects.
PAPER_ANCHORS_PER_SUBJECT = {"sit": 25, "lift": 10}


def synthetic_data_config(action: str, scale: str = "toy", **overrides) -> SyntheticDataConfig:
    """The preset for ``action`` and ``scale`` (``toy``: CPU minutes; ``small``; ``paper``: NIFTY's
    sizes), fields overridable by keyword.

    ``seed`` seeds the whole pipeline, the prior's training included: ``seed=3`` also sets
    ``prior.seed`` to 3. ``prior`` and ``tree`` are that component's preset for the same scale
    (``motion_prior.prior_config``, ``rollout.tree_config``); pass a whole configuration to replace
    one (``prior=prior_config("toy", steps=100)``), it is then used as it is.
    """
    check_choice(action, ("sit", "lift"), "action")
    check_scale(scale, "synthetic_data_config: scale")
    fixed = {"action": action,
             "prior": prior_config(scale, seed=overrides.get("seed", SyntheticDataConfig.seed)),
             "tree": tree_config(scale)}
    if scale == "paper":
        fixed["anchors_per_subject"] = PAPER_ANCHORS_PER_SUBJECT[action]
    return scaled_config(SyntheticDataConfig, scale, SYNTHETIC_DATA_SCALES, overrides,
                         factory="synthetic_data_config", fixed=fixed)


def prior_training_clips(config: SyntheticDataConfig) -> list[Motion]:
    """The toy mocap the prior is trained on (deterministic for the seed).

    Generated once per process and configuration (the joint limits, the re-check and the
    chapters ask for it repeatedly); the list is new at each call, the clips are shared, so
    callers must not modify them.
    """
    key = (config.clips_per_kind, config.seed, config.mocap_subjects, PRIOR_MOCAP_KINDS)
    if key not in _PRIOR_CLIPS:
        _PRIOR_CLIPS.clear()  # keep one configuration: a few MB
        _PRIOR_CLIPS[key] = mocap.generate_dataset(config.clips_per_kind, seed=config.seed,
                                                          kinds=PRIOR_MOCAP_KINDS, subjects=config.mocap_subjects)
    return list(_PRIOR_CLIPS[key])


_PRIOR_CLIPS: dict = {}


def prune_settings(config: SyntheticDataConfig, check_skating: Optional[bool] = None) -> PruneConfig:
    """PruneCheck's thresholds with the limits read off the prior's mocap: the joint rotation limits
    (``rollout.joint_limits_from``) and, when skating is checked, the worst foot skating of a
    node-long window (``rollout.skating_limit_from``).

    Args:
        config: the dataset's configuration.
        check_skating: override ``config.check_skating`` (e.g. to re-check a dataset more strictly).
    """
    clips = prior_training_clips(config)
    check_skating = config.check_skating if check_skating is None else bool(check_skating)
    skating = skating_limit_from(clips, config.tree.frames_per_node) if check_skating else None
    return dataclasses.replace(config.prune, joint_limits=joint_limits_from(clips), skating=skating)


def trained_prior(config: SyntheticDataConfig, device: str = "cpu", progress: bool = False):
    """The reverse prior for ``config``, trained once and then loaded from the artifact cache.

    Returns a :class:`~hoi_tutorial.infra.TrainedModel` (the prior in eval mode, its losses and
    seconds) whose ``details`` hold ``n_clips`` and ``n_frames``, the reversed toy-mocap clips and
    frames it was trained on.
    """
    def build():
        clips = prior_training_clips(config)
        model, result = train_reverse_prior(clips, config.prior, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_clips": len(clips),
                "n_frames": int(sum(len(c) for c in clips))}

    key = {"clips_per_kind": config.clips_per_kind, "mocap_subjects": config.mocap_subjects,
           "prior": dataclasses.asdict(config.prior), "seed": config.seed, "kinds": PRIOR_MOCAP_KINDS}
    artifact = load_or_build("nifty_reverse_prior", key, build)
    model = ReversePrior(config.prior)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"n_clips": artifact["n_clips"], "n_frames": artifact["n_frames"]})


@dataclass
class SyntheticDataset:
    """The result of :func:`synthesize`.

    Attributes:
        config: the configuration.
        anchors: the anchors, one tree each.
        sequences: kept training sequences (forward motions ending in their anchor, with objects).
        leaves: per anchor, the indices into ``all_paths`` of its root-to-leaf paths (Fig. 4).
        all_paths: every root-to-node path before the 1 m filter, as ``InteractionSequence``.
        tree_stats: per anchor, survival rates and failure counts of Algorithm 1.
        stats: totals (``paths``, ``kept``, ``filtered_near_start``), ``anchor_rounds`` (rounds of
            anchors grown to reach ``config.min_sequences``) and ``prior``, the prior's training
            seconds, clips and frames.
    """

    config: SyntheticDataConfig
    anchors: list
    sequences: list
    leaves: list
    all_paths: list
    tree_stats: list
    stats: dict

    @property
    def training_anchor_index(self) -> list[int]:
        """Indices into ``anchors`` of the anchors with at least one kept sequence, ascending."""
        used = {id(s.anchor) for s in self.sequences}
        return [i for i, anchor in enumerate(self.anchors) if id(anchor) in used]

    @property
    def training_anchors(self) -> list:
        """The anchors of the training data: those with at least one kept sequence (NIFTY §4.2's
        nearest-neighbour search for skeleton distance and contact IoU runs over these)."""
        return [self.anchors[i] for i in self.training_anchor_index]


def _paths_payload(trees) -> dict:
    rots, roots, anchor_idx, depth, leaf = [], [], [], [], []
    stats = []
    for a, tree in enumerate(trees):
        for motion in rollout.tree_paths(tree):
            node = tree.nodes[motion.meta["node"]]
            rots.append(motion.local_rotations)
            roots.append(motion.root_position)
            anchor_idx.append(a)
            depth.append(motion.meta["depth"])
            leaf.append(not node.children)
        stats.append({
            "attempts": {str(k): v for k, v in tree.attempts_per_depth.items()},
            "created": {str(k): v for k, v in tree.created_per_depth.items()},
            "tries": {str(k): v for k, v in tree.tries_per_depth.items()},
            "passed": {str(k): v for k, v in tree.passed_per_depth.items()},
            "failures": dict(tree.failures),
        })
    return {"local_rotations": rots, "root_position": roots, "anchor": np.array(anchor_idx, dtype=np.int64),
            "depth": np.array(depth, dtype=np.int64), "leaf": np.array(leaf, dtype=bool), "trees": stats}


@functools.lru_cache(maxsize=16)
def _collected_anchors(action: str, n_subjects: int, anchors_per_subject: int, seed: int, rounds: int) -> tuple:
    # Anchors come from the toy mocap (seconds for several rounds) and are not stored in the cache; a chapter
    # loads the same dataset many times (warm_cache first checks every build), so each process makes them once.
    return tuple(collect_anchors(action, n_subjects, anchors_per_subject, seed, rounds))


def synthesize(config: SyntheticDataConfig, device: str = "cpu", progress: bool = False) -> SyntheticDataset:
    """Run (or load) the whole synthetic-data pipeline for one interaction."""
    trained = trained_prior(config, device=device, progress=progress)
    prior = trained.model
    per_round = config.n_subjects * config.anchors_per_subject

    def round_anchors(rounds):
        return list(_collected_anchors(config.action, config.n_subjects, config.anchors_per_subject, config.seed,
                                       int(rounds)))

    def build():
        prune = prune_settings(config)
        generator = torch.Generator().manual_seed(config.seed)  # one stream across rounds
        trees, kept = [], 0
        every_round = None  # generated once, when a second round is needed (round r does not depend on how many follow)
        for r in range(config.max_anchor_rounds):
            if r == 0:
                new_anchors = round_anchors(1)
            else:
                every_round = every_round or round_anchors(config.max_anchor_rounds)
                new_anchors = every_round[r * per_round:(r + 1) * per_round]
            new_trees = grow_trees(prior, new_anchors, generator, config.tree, prune)
            trees += new_trees
            kept += sum(start_distance(path, tree.anchor.obj) >= config.tree.min_start_distance
                        for tree in new_trees for path in rollout.tree_paths(tree))
            if kept >= config.min_sequences:
                break
        return {**_paths_payload(trees), "rounds": r + 1}

    key = {"config": dataclasses.asdict(config)}
    payload = load_or_build(f"nifty_{config.action}_rollouts", key, build)
    dataset_anchors = round_anchors(int(payload["rounds"]))
    action = action_id(config.action)
    all_paths = []
    for rots, roots, a, d in zip(payload["local_rotations"], payload["root_position"], payload["anchor"], payload["depth"]):
        anchor: Anchor = dataset_anchors[int(a)]
        T = rots.shape[0]
        motion = Motion(rots, roots, anchor.betas, FPS, actions=np.full(T, action, dtype=np.int64),
                        meta={"depth": int(d), "anchor_frame": T - 1, "action": config.action,
                              "subject": anchor.subject, "anchor": int(a)})
        all_paths.append(InteractionSequence(motion, anchor.obj, anchor))
    sequences = [p for p in all_paths if start_distance(p.motion, p.obj) >= config.tree.min_start_distance]
    leaves = [[i for i in range(len(all_paths)) if payload["anchor"][i] == a and payload["leaf"][i]]
              for a in range(len(dataset_anchors))]
    stats = {"paths": len(all_paths), "kept": len(sequences), "filtered_near_start": len(all_paths) - len(sequences),
             "anchor_rounds": int(payload["rounds"]), "prior": {"seconds": trained.seconds, **trained.details}}
    if len(sequences) < config.min_sequences:
        warnings.warn(f"synthesize({config.action!r}, seed={config.seed}): {len(sequences)} sequences kept after "
                      f"{payload['rounds']} rounds of anchors, fewer than min_sequences={config.min_sequences}",
                      RuntimeWarning, stacklevel=2)
    return SyntheticDataset(config, dataset_anchors, sequences, leaves, all_paths, payload["trees"], stats)


def survival_by_depth(dataset: SyntheticDataset) -> dict:
    """Over all trees, per depth: RollOut calls, children created, tries drawn, tries passed.

    Returns ``{depth: {"attempts", "created", "tries", "passed", "survival", "pass_rate"}}`` where
    ``survival`` = created / attempts (a child slot got a motion within NTries) and ``pass_rate`` =
    passed / tries (a single rollout passed PruneCheck).
    """
    table: dict = {}
    for stats in dataset.tree_stats:
        for name in ("attempts", "created", "tries", "passed"):
            for depth, count in stats[name].items():
                row = table.setdefault(int(depth), {"attempts": 0, "created": 0, "tries": 0, "passed": 0})
                row[name] += int(count)
    for row in table.values():
        row["survival"] = row["created"] / row["attempts"] if row["attempts"] else float("nan")
        row["pass_rate"] = row["passed"] / row["tries"] if row["tries"] else float("nan")
    return dict(sorted(table.items()))


def failure_counts(dataset: SyntheticDataset) -> dict:
    """PruneCheck failures by reason over all tries of all trees (a try can fail several checks)."""
    counts: dict = {}
    for stats in dataset.tree_stats:
        for reason, n in stats["failures"].items():
            counts[reason] = counts.get(reason, 0) + int(n)
    return counts


def recheck_sequences(dataset: SyntheticDataset, sequences=None, prune: Optional[PruneConfig] = None) -> torch.Tensor:
    """Run PruneCheck again on every node of every sequence: ``(N,)`` bool, every node passes.

    See :func:`recheck_failures`, which says which checks fail.
    """
    failures = recheck_failures(dataset, sequences, prune)
    return ~torch.stack(list(failures.values())).any(dim=0)


def recheck_failures(dataset: SyntheticDataset, sequences=None, prune: Optional[PruneConfig] = None) -> dict:
    """Run PruneCheck again on every node of every sequence, as the trees saw them.

    A sequence of ``1 + d * F`` frames is reversed and cut after the anchor frame into ``d``
    nodes of ``F`` frames; each node is checked against the anchor's own penetration depth with
    the same thresholds and joint limits. A node shared by several paths of a tree (same anchor,
    same frames) is checked once.

    Args:
        dataset: the synthetic dataset.
        sequences: the sequences to check (default: ``dataset.sequences``).
        prune: thresholds (default: the dataset's own, :func:`prune_settings`).
    Returns:
        ``{reason: (N,) bool}`` for every reason of ``rollout.PRUNE_REASONS``: some node of the
        sequence fails that check.
    """
    sequences = dataset.sequences if sequences is None else sequences
    config = dataset.config
    prune = prune_settings(config) if prune is None else prune
    F = config.tree.frames_per_node
    rots, roots, joints, betas, objects, depths = [], [], [], [], [], []
    penetration = {}
    node_of = {}  # paths of one tree share their first nodes: each distinct node is checked once
    owners = []  # per sequence, the indices of its nodes
    for seq in sequences:
        rev = seq.motion.reversed()
        depth = (len(rev) - 1) // F
        if depth * F + 1 != len(rev):
            raise ValueError(f"sequence of {len(rev)} frames is not 1 + depth x {F}")
        key = id(seq.anchor)
        if key not in penetration:
            penetration[key] = rollout.anchor_penetration(seq.anchor)
        rev_rots, rev_roots, rev_joints = rev.local_rotations, rev.root_position, None
        nodes = []
        for d in range(depth):
            sl = slice(1 + d * F, 1 + (d + 1) * F)
            # A node is identified by its anchor and its frames (root path and last pose).
            identity = (key, id(seq.obj), rev_roots[sl].numpy().tobytes(), rev_rots[sl.stop - 1].numpy().tobytes())
            if identity not in node_of:
                rev_joints = rev.joints if rev_joints is None else rev_joints
                node_of[identity] = len(rots)
                rots.append(rev_rots[sl])
                roots.append(rev_roots[sl])
                joints.append(rev_joints[sl])
                betas.append(seq.motion.betas)
                objects.append(seq.obj)
                depths.append(penetration[key])
            nodes.append(node_of[identity])
        owners.append(nodes)
    if not rots:  # no nodes: nothing fails
        return {reason: torch.zeros(len(sequences), dtype=torch.bool) for reason in rollout.PRUNE_REASONS}
    rots, roots, joints, betas = torch.stack(rots), torch.stack(roots), torch.stack(joints), torch.stack(betas)
    depths = torch.tensor(depths)
    fails = {reason: torch.empty(len(rots), dtype=torch.bool) for reason in rollout.PRUNE_REASONS}
    for start in range(0, len(rots), 256):  # every distinct node, in batches
        sl = slice(start, start + 256)
        segment = motion_prior.PoseTrack(rots[sl], roots[sl], joints[sl])
        checks = rollout.prune_check(segment, betas[sl], objects[sl], depths[sl], prune)
        for reason in rollout.PRUNE_REASONS:
            fails[reason][sl] = checks[reason]
    return {reason: torch.tensor([bool(flags[nodes].any()) for nodes in owners], dtype=torch.bool)
            for reason, flags in fails.items()}
