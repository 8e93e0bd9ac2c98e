"""Tree-based rollouts with pruning: NIFTY Algorithm 1 (Appendix A.2) and the synthetic datasets.

Starting from an anchor pose, a time-reversed motion prior generates 1-second clips (nodes).
Each node gets ``B`` children (B = 6 for nodes at depths 1 and 2, B = 2 deeper), each child the
first of up to ``NTries = 20`` rollouts that passes :func:`prune_check`; growth is breadth-first
to the maximum depth. Every root-to-node path, played forwards, is an interaction motion that ends
exactly in its anchor; paths that start within 1 m of the object are filtered out afterwards.

The algorithm box, line by line (names as in Algorithm 1)::

    RollOut(startPose, N):   try up to N rollouts, return the first that passes PruneCheck, or null
    PruneCheck(motion):      object collision, floating, sinking, unnatural pose, stationary
                             (the paper's list ends in "etc."; an optional foot-skating check is ours)
    queue <- [root (anchor)]
    while queue: node <- pop; if node.depth == MaxDepth: continue
        for child in 1..B: motion <- RollOut(node.lastPose, NTries); if motion: push child

Implementation note: the while-loop runs level by level (that *is* breadth-first order) and, within
a level, every ``RollOut`` of every tree is drawn in one batch. The tries of one RollOut are drawn
in chunks and the first passing try in try order is kept, so the result is the same as trying one
after another, only faster.

Scaled down: depth 4 (NIFTY: 7) and fewer anchors at ``toy``; NTries, the branching factors and
the 1-second nodes are the paper's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np
import torch

from .. import metrics
from ..infra import single_threaded
from ..infra.presets import scaled_config
from ..world.body import body_vertices, toe_vertices
from ..world.kinematics import forward_kinematics
from ..world.motion import FPS, Motion, action_id
from ..world.rotations import matrix_to_axis_angle
from ..world.skeleton import JOINT_NAMES, bone_offsets, joint_index
from .anchors import Anchor, stack_anchor_poses
from .motion_prior import PoseTrack, ReversePrior, rollout

__all__ = [
    "TreeConfig",
    "TREE_SCALES",
    "tree_config",
    "PruneConfig",
    "prune_config",
    "JOINT_ANGLE_LIMITS",
    "TreeNode",
    "MotionTree",
    "branching_factor",
    "joint_limits_from",
    "skating_limit_from",
    "PRUNE_REASONS",
    "prune_check",
    "grow_trees",
    "tree_paths",
    "InteractionSequence",
    "anchor_penetration",
    "start_distance",
    "interaction_dataset",
]


@dataclass(frozen=True)
class TreeConfig:
    """Settings of Algorithm 1.

    The defaults are the ``toy`` preset; :func:`tree_config` gives every scale.

    Attributes:
        max_depth: depth of the tree in nodes (NIFTY: 7; toy preset: 4).
        frames_per_node: frames per node (NIFTY: 30, one second at 30 fps).
        n_tries: rollout attempts per child, ``NTries`` (NIFTY: 20).
        branching_shallow: children of nodes at depths 0 and 1, i.e. the sixfold branching that
            creates the nodes at depths 1 and 2 (NIFTY: B = 6).
        branching_deep: children of deeper nodes (NIFTY: B = 2).
        tries_per_chunk: tries drawn at once per child (speed only; results are unchanged).
        temperature: scale of the prior's latent standard deviation.
        min_start_distance: post-filter, metres: drop sequences whose first frame's pelvis is
            nearer than this to the object (NIFTY: 1 m; see :func:`start_distance`).
    """

    max_depth: int = 4
    frames_per_node: int = 30
    n_tries: int = 20
    branching_shallow: int = 6
    branching_deep: int = 2
    tries_per_chunk: int = 4
    temperature: float = 1.0
    min_start_distance: float = 0.75


# What the larger scales change from the defaults (the toy preset). Trees of 4 s instead of 7 s reach
# less far from the seat: at toy the start-distance filter scales with them.
TREE_SCALES = {
    "small": {"max_depth": 5, "min_start_distance": 1.0},
    "paper": {"max_depth": 7, "min_start_distance": 1.0},
}


def tree_config(scale: str = "toy", **overrides) -> TreeConfig:
    """Algorithm 1's settings for ``scale`` (``paper``: NIFTY's depth 7), fields overridable."""
    return scaled_config(TreeConfig, scale, TREE_SCALES, overrides, factory="tree_config")


def branching_factor(depth: int, config: TreeConfig) -> int:
    """``B`` for a node at ``depth`` (the root, the anchor, is depth 0).

    NIFTY: "B as 6 for the nodes at depths 1 and 2, while B = 2 for nodes at higher depths" — read
    here as the nodes *created* at depths 1 and 2 come six per parent.
    """
    return config.branching_shallow if depth < 2 else config.branching_deep


# Largest plausible rotation of each joint relative to its parent, degrees (the pelvis is free).
JOINT_ANGLE_LIMITS = {
    "pelvis": 360.0, "left_hip": 130.0, "right_hip": 130.0, "spine1": 60.0,
    "left_knee": 160.0, "right_knee": 160.0, "spine2": 45.0, "left_ankle": 60.0,
    "right_ankle": 60.0, "spine3": 45.0, "left_foot": 50.0, "right_foot": 50.0, "neck": 60.0,
    "left_collar": 45.0, "right_collar": 45.0, "head": 60.0, "left_shoulder": 150.0,
    "right_shoulder": 150.0, "left_elbow": 160.0, "right_elbow": 160.0, "left_wrist": 90.0,
    "right_wrist": 90.0,
}


@dataclass(frozen=True)
class PruneConfig:
    """Thresholds of PruneCheck (NIFTY gives the categories, not the numbers; these are ours).

    The same at every scale (:func:`prune_config`).

    Attributes:
        penetration: metres a body vertex may go into the object beyond the anchor's own depth.
        floating: metres the lowest body vertex may hover above the ground ...
        floating_frames: ... for at most this many consecutive frames.
        sinking: metres the lowest vertex may go below the ground.
        knee_hyperextension: degrees a knee may bend backwards.
        stationary: metres: the mean joint displacement over the node must exceed this.
        joint_limits: 22 radians, the largest rotation of each joint relative to its parent (a
            ``(22,)`` tensor is stored as a tuple of floats, so the configuration stays immutable);
            ``None`` uses ``JOINT_ANGLE_LIMITS``. :func:`joint_limits_from` derives them from mocap.
        skating: m/s, the largest foot-skating score (NIFTY §4.2's metric) either toe may have over
            the node; ``None`` skips the check. :func:`skating_limit_from` derives it from mocap.
            NIFTY's list of checks ends in "etc."; this one is ours, and off in the presets
            (``nifty.data.SyntheticDataConfig.check_skating``): a prior trained for a minute slides
            its planted feet far more than HuMoR trained on AMASS, and at toy scale the check
            leaves almost no sitting path.
        frame_stride, vertex_stride: subsampling for the collision and ground checks (speed).
    """

    penetration: float = 0.03
    floating: float = 0.06
    floating_frames: int = 12
    sinking: float = 0.03
    knee_hyperextension: float = 10.0
    stationary: float = 0.05
    frame_stride: int = 2
    vertex_stride: int = 2
    joint_limits: Optional[tuple] = None
    skating: Optional[float] = None

    def __post_init__(self):
        if self.joint_limits is not None:
            limits = tuple(float(v) for v in torch.as_tensor(self.joint_limits).reshape(-1).tolist())
            if len(limits) != len(JOINT_NAMES):
                raise ValueError(f"joint_limits: expected {len(JOINT_NAMES)} values, got {len(limits)}")
            object.__setattr__(self, "joint_limits", limits)


def prune_config(scale: str = "toy", **overrides) -> PruneConfig:
    """PruneCheck's thresholds (no scale changes them), fields overridable."""
    return scaled_config(PruneConfig, scale, {}, overrides, factory="prune_config")


# PruneCheck's failure reasons, in the order they are reported.
PRUNE_REASONS = ("collision", "floating", "sinking", "unnatural", "stationary", "skating")
_LIMITS = torch.tensor([math.radians(JOINT_ANGLE_LIMITS[n]) for n in JOINT_NAMES])
_KNEES = [joint_index("left_knee"), joint_index("right_knee")]


def joint_limits_from(motions: Sequence[Motion], margin_degrees: float = 15.0) -> torch.Tensor:
    """Per-joint rotation limits ``(22,)`` radians: the largest angle seen in ``motions`` plus a margin.

    "Unnatural" then means "outside the range of the motion data", which is what a heuristic
    joint-limit check approximates. The pelvis (a free joint) is unlimited.
    """
    if not motions:
        raise ValueError("motions: expected at least one Motion")
    largest = torch.zeros(len(JOINT_NAMES))
    for m in motions:
        largest = torch.maximum(largest, matrix_to_axis_angle(m.local_rotations).norm(dim=-1).amax(0))
    limits = (largest + math.radians(margin_degrees)).clamp_max(math.pi)
    limits[0] = math.pi
    return limits


def skating_limit_from(motions: Sequence[Motion], frames: int = 30) -> float:
    """The worst foot skating of any ``frames``-long window of ``motions``, either toe (m/s).

    "Skates too much" then means "more than the motion data ever does in one node's time", as
    :func:`joint_limits_from` reads "unnatural" as "outside the data's range". Windows start every
    ``frames`` frames; the score is ``metrics.foot_skating`` of each toe vertex.
    """
    if not motions:
        raise ValueError("motions: expected at least one Motion")
    if frames < 2:
        raise ValueError(f"frames: expected at least 2, got {frames}")
    worst = 0.0
    for m in motions:
        toes = toe_vertices(m.global_rotations, m.joints, m.betas)  # (T, 2, 3)
        for start in range(0, len(m) - frames + 1, frames):
            window = toes[start:start + frames].transpose(0, 1)  # (2, frames, 3)
            worst = max(worst, float(np.max(metrics.foot_skating(window))))
    return worst


def prune_check(segment: PoseTrack, betas: torch.Tensor, objects: Sequence, anchor_depth: torch.Tensor,
                config: Optional[PruneConfig] = None) -> dict:
    """PruneCheck of Algorithm 1 for a batch of rollout clips.

    Args:
        segment: ``(N, F, ...)`` poses of N clips of F frames.
        betas: ``(N, 10)`` body shapes.
        objects: N objects (``.sdf(points)`` negative inside), one per clip.
        anchor_depth: ``(N,)`` metres the anchor pose itself penetrates its object (>= 0).
        config: thresholds.
    Returns:
        dict of ``(N,)`` bool tensors: ``valid`` and one flag per failure reason of
        ``PRUNE_REASONS`` (``skating`` is all False when ``config.skating`` is None).
    """
    config = config or PruneConfig()
    N, F = segment.root_position.shape[:2]
    frames = torch.arange(0, F, config.frame_stride)
    rots = segment.local_rotations[:, frames]
    offsets = bone_offsets(betas)[:, None].expand(N, len(frames), -1, -1)
    glob, joints = forward_kinematics(rots, segment.root_position[:, frames], offsets)
    # Betas broadcast over frames: the per-body vertex layout is computed once per clip.
    verts = body_vertices(glob, joints, betas[:, None])[:, :, ::config.vertex_stride]

    # Object collision: deepest vertex inside the object, compared with the anchor's own depth.
    depth = torch.zeros(N)
    groups: dict = {}
    for i, obj in enumerate(objects):
        groups.setdefault(id(obj), (obj, []))[1].append(i)
    for obj, rows in groups.values():  # one SDF query per distinct object
        sdf = obj.sdf(verts[rows].reshape(-1, 3).double()).reshape(len(rows), -1)
        depth[rows] = (-sdf).clamp_min(0.0).amax(dim=-1).float()
    collision = depth > anchor_depth + config.penetration

    # Ground: the lowest vertex of every frame.
    lowest = verts[..., 2].min(dim=-1).values  # (N, F')
    sinking = lowest.min(dim=-1).values < -config.sinking
    above = (lowest > config.floating).int()
    # Longest run of consecutive (subsampled) frames above the threshold.
    run = torch.zeros(N, dtype=torch.int64)
    best = torch.zeros(N, dtype=torch.int64)
    for t in range(above.shape[1]):
        run = (run + 1) * above[:, t]
        best = torch.maximum(best, run)
    floating = best * config.frame_stride > config.floating_frames

    # Unnatural poses: joint rotations beyond their limits, or knees bent backwards.
    angles = matrix_to_axis_angle(segment.local_rotations)  # (N, F, 22, 3)
    # float64 holds the limits exactly, whatever the dtype they were derived in.
    limits = _LIMITS if config.joint_limits is None else torch.tensor(config.joint_limits, dtype=torch.float64)
    too_far = (angles.norm(dim=-1) > limits).any(dim=-1).any(dim=-1)
    # Knees flex about the body's lateral axis (local -x rotates the shin backwards = flexion).
    knee_back = angles[:, :, _KNEES, 0].amax(dim=(1, 2)) > math.radians(config.knee_hyperextension)
    unnatural = too_far | knee_back

    # Stationary: the body barely moves over the whole node.
    moved = (segment.joints[:, -1] - segment.joints[:, 0]).norm(dim=-1).mean(dim=-1)
    stationary = moved < config.stationary

    # Foot skating: the worse toe's score over every frame of the node.
    if config.skating is None:
        skating = torch.zeros(N, dtype=torch.bool)
    else:
        all_glob, all_joints = forward_kinematics(segment.local_rotations, segment.root_position,
                                                  bone_offsets(betas)[:, None].expand(N, F, -1, -1))
        toes = toe_vertices(all_glob, all_joints, betas[:, None]).transpose(1, 2)  # (N, 2, F, 3)
        score = torch.as_tensor(metrics.foot_skating(toes)).amax(dim=-1)
        skating = score > config.skating

    valid = ~(collision | floating | sinking | unnatural | stationary | skating)
    return {"valid": valid, "collision": collision, "floating": floating, "sinking": sinking,
            "unnatural": unnatural, "stationary": stationary, "skating": skating}


@dataclass
class TreeNode:
    """A node of a motion tree: a 1-second clip in *reversed* time (``None`` for the root)."""

    depth: int
    parent: Optional[int]
    segment: Optional[PoseTrack]  # (F, ...) frames, continuing backwards in time from the parent
    last: PoseTrack  # the node's last pose (the seed of its children's rollouts)
    before_last: PoseTrack  # the pose before it (for velocities)
    children: list = field(default_factory=list)


@dataclass
class MotionTree:
    """Algorithm 1's output for one anchor, plus bookkeeping for the chapter's figures."""

    anchor: Anchor
    nodes: list
    attempts_per_depth: dict = field(default_factory=dict)  # depth -> RollOut calls (children asked for)
    created_per_depth: dict = field(default_factory=dict)  # depth -> children created
    tries_per_depth: dict = field(default_factory=dict)  # depth -> rollouts drawn
    passed_per_depth: dict = field(default_factory=dict)  # depth -> rollouts that passed PruneCheck
    failures: dict = field(default_factory=dict)  # reason -> count over all tries

    def survival_rate(self) -> dict:
        """Per depth: the fraction of RollOut calls that returned a motion (a child was created)."""
        return {d: self.created_per_depth.get(d, 0) / n for d, n in self.attempts_per_depth.items() if n}


def _take(track: PoseTrack, index) -> PoseTrack:
    return PoseTrack(track.local_rotations[index], track.root_position[index], track.joints[index])


def _stack(tracks: Sequence[PoseTrack]) -> PoseTrack:
    return PoseTrack(torch.stack([t.local_rotations for t in tracks]),
                     torch.stack([t.root_position for t in tracks]),
                     torch.stack([t.joints for t in tracks]))


def anchor_penetration(anchor: Anchor) -> float:
    """Metres the anchor pose itself reaches into its object (0 when it only touches it)."""
    glob, joints = forward_kinematics(anchor.pose.local_rotations, anchor.pose.root_position, bone_offsets(anchor.betas))
    verts = body_vertices(glob, joints, anchor.betas)
    return float((-anchor.obj.sdf(verts.double())).clamp_min(0.0).max())


@torch.no_grad()
@single_threaded
def grow_trees(prior: ReversePrior, anchors: Sequence[Anchor], generator: torch.Generator,
               config: Optional[TreeConfig] = None, prune: Optional[PruneConfig] = None) -> list[MotionTree]:
    """Algorithm 1 for every anchor (one tree each), all trees grown together level by level."""
    config = config or TreeConfig()
    prev, start = stack_anchor_poses(anchors)
    trees = []
    for i, a in enumerate(anchors):
        root = TreeNode(0, None, None, _take(start, i), _take(prev, i))
        trees.append(MotionTree(a, [root]))
    anchor_depths = torch.tensor([anchor_penetration(a) for a in anchors])
    betas_all = torch.stack([a.betas for a in anchors])

    frontier = [(t, 0) for t in range(len(trees))]  # (tree, node) pairs of the current level
    for depth in range(config.max_depth):
        # One RollOut request per child slot: (tree, parent node).
        requests = []
        for t, n in frontier:
            for _ in range(branching_factor(depth, config)):
                requests.append((t, n))
        if not requests:
            break
        for t, _ in requests:
            tree = trees[t]
            tree.attempts_per_depth[depth + 1] = tree.attempts_per_depth.get(depth + 1, 0) + 1
        result: list[Optional[PoseTrack]] = [None] * len(requests)
        tries_used = [0] * len(requests)
        open_requests = list(range(len(requests)))
        while open_requests:
            chunk = min(config.tries_per_chunk, config.n_tries - min(tries_used[r] for r in open_requests))
            rows = [r for r in open_requests for _ in range(chunk)]
            seeds_prev = _stack([trees[requests[r][0]].nodes[requests[r][1]].before_last for r in rows])
            seeds = _stack([trees[requests[r][0]].nodes[requests[r][1]].last for r in rows])
            tree_idx = torch.tensor([requests[r][0] for r in rows])
            betas = betas_all[tree_idx]
            clips = rollout(prior, seeds_prev, seeds, bone_offsets(betas), config.frames_per_node,
                            generator, config.temperature)
            checks = prune_check(clips, betas, [trees[requests[r][0]].anchor.obj for r in rows],
                                 anchor_depths[tree_idx], prune)
            still_open = []
            for j, r in enumerate(open_requests):
                tree = trees[requests[r][0]]
                for c in range(chunk):
                    row = j * chunk + c
                    if tries_used[r] >= config.n_tries:
                        break
                    tries_used[r] += 1
                    tree.tries_per_depth[depth + 1] = tree.tries_per_depth.get(depth + 1, 0) + 1
                    if bool(checks["valid"][row]):
                        tree.passed_per_depth[depth + 1] = tree.passed_per_depth.get(depth + 1, 0) + 1
                        result[r] = _take(clips, row)
                        break
                    for reason in PRUNE_REASONS:
                        if bool(checks[reason][row]):
                            tree.failures[reason] = tree.failures.get(reason, 0) + 1
                if result[r] is None and tries_used[r] < config.n_tries:
                    still_open.append(r)
            open_requests = still_open
        new_frontier = []
        for r, (t, n) in enumerate(requests):
            motion = result[r]
            if motion is None:
                continue
            tree = trees[t]
            child = TreeNode(depth + 1, n, motion, _take(motion, -1), _take(motion, -2))
            tree.nodes.append(child)
            tree.nodes[n].children.append(len(tree.nodes) - 1)
            tree.created_per_depth[depth + 1] = tree.created_per_depth.get(depth + 1, 0) + 1
            new_frontier.append((t, len(tree.nodes) - 1))
        frontier = new_frontier
    return trees


def tree_paths(tree: MotionTree, leaves_only: bool = False) -> list[Motion]:
    """Root-to-node paths of a tree played *forwards*: each ends exactly in the anchor pose.

    Args:
        tree: a grown tree.
        leaves_only: only root-to-leaf paths (NIFTY converts all nodes; Fig. 4 shows leaves).
    Returns:
        Motions in real time (``meta``: ``depth``, ``node``, ``anchor_frame`` = last frame).
    """
    anchor = tree.anchor
    out = []
    for idx, node in enumerate(tree.nodes):
        if idx == 0 or (leaves_only and node.children):
            continue
        chain = []
        k = idx
        while k != 0:
            chain.append(tree.nodes[k].segment)
            k = tree.nodes[k].parent
        # Reversed time: anchor, then the root-most segment ... down to this node.
        rots = [anchor.pose.local_rotations[None]] + [s.local_rotations for s in reversed(chain)]
        roots = [anchor.pose.root_position[None]] + [s.root_position for s in reversed(chain)]
        rev_rots, rev_roots = torch.cat(rots), torch.cat(roots)
        T = rev_rots.shape[0]
        action = action_id("sit" if anchor.action == "sit" else "lift")
        out.append(Motion(
            rev_rots.flip(0), rev_roots.flip(0), anchor.betas, FPS,
            actions=np.full(T, action, dtype=np.int64),
            meta={"depth": node.depth, "node": idx, "anchor_frame": T - 1, "action": anchor.action,
                  "subject": anchor.subject},
        ))
    return out


@dataclass
class InteractionSequence:
    """One synthetic training sequence: a forward motion ending in its anchor, and its object."""

    motion: Motion
    obj: object
    anchor: Anchor


def start_distance(motion: Motion, obj) -> float:
    """Metres from the first frame's pelvis to the object, in the ground plane.

    NIFTY filters out "sequences that start within 1 meter of the object" without saying how the
    distance is measured; we take the object's position (its canonical origin, the centre of its
    footprint), as an object pose from BEHAVE gives it.
    """
    centre = torch.as_tensor(np.asarray(obj.pose)[:2, 3], dtype=motion.root_position.dtype)
    return float((motion.root_position[0, :2] - centre).norm())


def interaction_dataset(trees: Sequence[MotionTree], config: Optional[TreeConfig] = None) -> tuple[list, dict]:
    """All root-to-node paths of all trees, minus those starting within ``min_start_distance`` m.

    Returns ``(sequences, stats)`` with ``stats`` counting the paths before and after the filter.
    """
    config = config or TreeConfig()
    paths = [InteractionSequence(m, tree.anchor.obj, tree.anchor) for tree in trees for m in tree_paths(tree)]
    kept = [p for p in paths if start_distance(p.motion, p.obj) >= config.min_start_distance]
    return kept, {"paths": len(paths), "kept": len(kept), "filtered_near_start": len(paths) - len(kept)}
