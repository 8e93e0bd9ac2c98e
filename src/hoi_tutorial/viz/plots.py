"""Static matplotlib figures of the toy world: skeletons, trajectories, contacts, rooms, voxels.

Every function takes an optional ``ax`` and returns the axes it drew on, so figures compose in a
notebook (``fig, axes = plt.subplots(1, 3)`` then one call per axes). Colours are the same
everywhere: left limbs blue, right limbs red, spine and head grey, objects a neutral brown-grey,
and each action label has one fixed colour (``ACTION_COLORS``).

World conventions: metres, Z up, ground at z = 0, a character faces +Y and +X is its right.
Views used by the 2D plots:

=========  ======================  ==========================  ===================================
view       horizontal axis         vertical axis               seen from
=========  ======================  ==========================  ===================================
front      x (drawn right to left)  z                         +Y, the front of a character facing +Y
side       y                       z                           +X, the character's right side
top        x                       y                           above (+Z)
=========  ======================  ==========================  ===================================
"""
from __future__ import annotations

from typing import Optional, Sequence

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import ListedColormap, Normalize, to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle
from matplotlib.ticker import MultipleLocator

from .._validate import check_choice, check_shape
from ..world.motion import ACTIONS, CONTACT_JOINTS, Motion
from ..world.skeleton import FOOT_JOINT_HEIGHT, JOINT_NAMES, NUM_JOINTS, PARENTS, joint_index

__all__ = [
    "LEFT_COLOR",
    "RIGHT_COLOR",
    "SPINE_COLOR",
    "OBJECT_COLOR",
    "TRAJECTORY_COLOR",
    "HIGHLIGHT_COLOR",
    "ACTION_COLORS",
    "VIEWS",
    "bone_colors",
    "project",
    "plot_skeleton",
    "plot_motion_strip",
    "plot_trajectories_top_down",
    "plot_object_footprint",
    "plot_contacts",
    "plot_foot_heights",
    "plot_room",
    "plot_kitchen_top_down",
    "plot_voxels",
]

LEFT_COLOR = "#1f77b4"
RIGHT_COLOR = "#d62728"
SPINE_COLOR = "#6e6e6e"
OBJECT_COLOR = "#b5a58c"
OBSTACLE_COLOR = "#8c7f6a"
TRAJECTORY_COLOR = "#f4a3b5"  # NIFTY Fig. 4 draws rollout trajectories in light pink ...
HIGHLIGHT_COLOR = "#1f5fbf"  # ... and highlights a few in blue.
PATH_COLOR = "#2ca02c"
ITEM_COLOR = "#ff7f0e"

# One fixed colour per action label, grouped by kind (locomotion greens, sitting oranges, lying
# purples, hand actions pinks and browns) and kept clear of the limb blue and red.
_ACTION_PALETTE = {
    "idle": "#c7c7c7", "walk": "#98df8a", "run": "#2ca02c", "turn": "#9edae5", "side_step": "#bcbd22",
    "sit_down": "#ffbb78", "sit": "#ff7f0e", "stand_up": "#f5d58f", "lie_down": "#c5b0d5", "lie": "#9467bd",
    "lift": "#e377c2", "reach": "#f7b6d2", "grasp": "#c49c94", "open_door": "#8c564b", "open_drawer": "#dbdb8d",
}
ACTION_COLORS: dict[str, tuple] = {
    name: to_rgba(_ACTION_PALETTE.get(name, matplotlib.colormaps["tab20"](i % 20))) for i, name in enumerate(ACTIONS)
}

VIEWS = ("front", "side", "top", "3d")
_VIEW_AXES = {"front": (0, 2), "side": (1, 2), "top": (0, 1)}
_VIEW_DEPTH = {"front": 1, "side": 0, "top": 2}
_AXIS_NAMES = ("x", "y", "z")


# ----------------------------------------------------------------------------- helpers


def _to_numpy(x, name: str) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        return x.detach().cpu().double().numpy()
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array or tensor of numbers, got {type(x).__name__}") from exc


def _joints_sequence(motion, name: str = "motion") -> np.ndarray:
    """``(T, 22, 3)`` numpy joints from a ``Motion``, a ``(T, 22, 3)`` or a ``(22, 3)`` array."""
    if isinstance(motion, Motion):
        return motion.joints.detach().cpu().double().numpy()
    joints = _to_numpy(motion, name)
    if joints.ndim == 2:
        check_shape(joints, (NUM_JOINTS, 3), name)
        return joints[None]
    check_shape(joints, (None, NUM_JOINTS, 3), name)
    return joints


def _side_of(joint: int) -> str:
    name = JOINT_NAMES[joint]
    return "left" if name.startswith("left_") else "right" if name.startswith("right_") else "centre"


def bone_colors(color_by_side: bool = True, color=SPINE_COLOR) -> list:
    """Colour of each bone ``(parent -> j)`` for ``j = 1..21``: left blue, right red, centre grey."""
    if not color_by_side:
        return [color] * (NUM_JOINTS - 1)
    table = {"left": LEFT_COLOR, "right": RIGHT_COLOR, "centre": color}
    return [table[_side_of(j)] for j in range(1, NUM_JOINTS)]


def project(points, view: str) -> np.ndarray:
    """Project world points onto the plane of a 2D view.

    Args:
        points: ``(..., 3)`` metres.
        view: ``"front"``, ``"side"`` or ``"top"`` (see the module table).
    Returns:
        ``(..., 2)`` metres (horizontal, vertical). The front view keeps world x; the plots flip
        that axis so the picture is the one seen from +Y.
    """
    check_choice(view, ("front", "side", "top"), "view")
    points = _to_numpy(points, "points")
    check_shape(points, (..., 3), "points")
    h, v = _VIEW_AXES[view]
    return np.stack([points[..., h], points[..., v]], axis=-1)


def _new_axes(ax, view: str, figsize=(5, 5)):
    if ax is not None:
        if view == "3d" and getattr(ax, "name", "") != "3d":
            raise ValueError("ax: view='3d' needs 3D axes (fig.add_subplot(projection='3d'))")
        return ax
    fig = plt.figure(figsize=figsize)
    return fig.add_subplot(projection="3d") if view == "3d" else fig.add_subplot()


def _style_2d_axes(ax, view: str) -> None:
    h, v = _VIEW_AXES[view]
    ax.set_xlabel(f"{_AXIS_NAMES[h]} (m)")
    ax.set_ylabel(f"{_AXIS_NAMES[v]} (m)")
    ax.set_aspect("equal", adjustable="datalim")
    # Seen from +Y the world's +X (the character's right) is on the viewer's left.
    if view == "front" and not ax.xaxis_inverted():
        ax.invert_xaxis()


def _set_3d_limits(ax, points: np.ndarray, margin: float = 0.1, ground: bool = True, zoom: float = 1.0,
                   min_extent: float = 1.0) -> None:
    """Equal-scale 3D limits around ``points (N, 3)`` metres, with z starting at the ground.

    Each axis spans the data plus ``margin`` (at least ``min_extent`` metres); the box aspect is set
    to the spans so one metre has the same length along x, y and z.
    """
    lo = points.min(axis=0) - margin
    hi = points.max(axis=0) + margin
    if ground:
        lo[2] = 0.0
    span = hi - lo
    grow = np.maximum(min_extent - span, 0.0) / 2
    lo, hi = lo - grow, hi + grow
    if ground:  # grow upwards only, the ground stays at the bottom
        hi[2] += grow[2]
        lo[2] = 0.0
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo), zoom=zoom)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    # Plain white panes and no pane grid: the ground grid carries the scale, and frames stay small.
    for axis, extent in zip((ax.xaxis, ax.yaxis, ax.zaxis), hi - lo):
        axis.set_pane_color((1.0, 1.0, 1.0, 0.0))
        # Few ticks on round metres: foreshortened 3D axes crowd their labels quickly.
        step = next((s for s in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0) if extent / s <= 4.0), extent / 4.0)
        axis.set_major_locator(MultipleLocator(step))
    ax.grid(False)


def _object_mesh(obj):
    """``(vertices (V, 3), faces (F, 3))`` of a ``ToyObject`` (its ``.mesh``) or a trimesh."""
    mesh = getattr(obj, "mesh", obj)
    if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
        raise TypeError(f"objects: expected ToyObject or trimesh.Trimesh items, got {type(obj).__name__}")
    return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64)


def _object_label(obj) -> Optional[str]:
    return getattr(obj, "category", None)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` frame intervals where a boolean ``(T,)`` mask is True."""
    mask = np.asarray(mask, dtype=bool)
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


def _label_runs(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """``(start, stop, label)`` for each maximal run of equal labels in ``(T,)``."""
    labels = np.asarray(labels)
    if labels.size == 0:
        return []
    change = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [labels.size]])
    return [(int(a), int(b), int(labels[a])) for a, b in zip(starts, stops)]


# ----------------------------------------------------------------------------- skeletons


def _draw_skeleton_2d(ax, joints: np.ndarray, view: str, colors: list, linewidth: float,
                      alpha: float = 1.0, zorder: float = 3.0, offset: float = 0.0):
    pts = project(joints, view)
    pts = pts + np.array([offset, 0.0])
    depth = joints[:, _VIEW_DEPTH[view]]
    # Nearer bones are drawn on top; the front view looks along -Y, so larger y is nearer.
    segs, cols, depths = [], [], []
    for j in range(1, NUM_JOINTS):
        p = PARENTS[j]
        segs.append([pts[p], pts[j]])
        cols.append(colors[j - 1])
        depths.append((depth[p] + depth[j]) / 2)
    order = np.argsort(depths)
    lc = LineCollection([segs[i] for i in order], colors=[cols[i] for i in order], linewidths=linewidth,
                        alpha=alpha, zorder=zorder, capstyle="round")
    ax.add_collection(lc)
    head = joint_index("head")
    ax.scatter(pts[:, 0], pts[:, 1], s=linewidth * 3, color="k", alpha=alpha, zorder=zorder + 0.1, linewidths=0)
    ax.scatter([pts[head, 0]], [pts[head, 1]], s=linewidth * 40, color=SPINE_COLOR, alpha=alpha,
               zorder=zorder + 0.2, linewidths=0)
    return lc


def plot_skeleton(joints, ax=None, view: str = "front", color_by_side: bool = True,
                  joint_labels: bool = False, color=SPINE_COLOR, linewidth: float = 3.0, ground: bool = True,
                  elev: float = 20.0, azim: float = 60.0):
    """Draw one pose as a stick figure, bones taken from the SMPL-22 ``PARENTS``.

    Args:
        joints: ``(22, 3)`` joint positions, metres (numpy or torch).
        ax: matplotlib axes (3D axes for ``view="3d"``); a new figure when ``None``.
        view: ``"front"``, ``"side"``, ``"top"`` or ``"3d"`` (see the module table).
        color_by_side: left limbs blue, right limbs red, the rest ``color``; otherwise all ``color``.
        joint_labels: write each joint's name next to it.
        color: colour of the centre bones (and of every bone when ``color_by_side`` is False).
        linewidth: bone width in points.
        ground: draw the ground line (2D side/front views) or the ground grid (3D).
        elev, azim: 3D camera angles in degrees (the default looks from the front-right, above).
    Returns:
        The axes.
    """
    check_choice(view, VIEWS, "view")
    joints = _to_numpy(joints, "joints")
    check_shape(joints, (NUM_JOINTS, 3), "joints")
    ax = _new_axes(ax, view)
    colors = bone_colors(color_by_side, color)
    if view == "3d":
        for j in range(1, NUM_JOINTS):
            p = PARENTS[j]
            ax.plot(*joints[[p, j]].T, color=colors[j - 1], linewidth=linewidth, solid_capstyle="round")
        ax.scatter(*joints.T, s=8, color="k", depthshade=False)
        _set_3d_limits(ax, joints, margin=0.15, ground=ground)
        ax.view_init(elev=elev, azim=azim)
        if ground:
            _draw_ground_grid_3d(ax)
        if joint_labels:
            for j, name in enumerate(JOINT_NAMES):
                ax.text(*joints[j], name, fontsize=6)
        return ax
    _draw_skeleton_2d(ax, joints, view, colors, linewidth)
    pts = project(joints, view)
    if joint_labels:
        for j, name in enumerate(JOINT_NAMES):
            ax.annotate(name, pts[j], fontsize=6, xytext=(3, 2), textcoords="offset points")
    if ground and view != "top":
        ax.axhline(0.0, color="0.5", linewidth=1.0, zorder=1)
    pad = 0.15
    ax.update_datalim(np.vstack([pts.min(0) - pad, pts.max(0) + pad]))
    if ground and view != "top":
        ax.update_datalim([[pts[:, 0].min(), 0.0]])
    ax.autoscale_view()
    _style_2d_axes(ax, view)
    if color_by_side:
        ax.legend(handles=_side_legend_handles(), loc="best", fontsize=8, framealpha=0.8)
    return ax


def _side_legend_handles():
    return [Line2D([], [], color=LEFT_COLOR, lw=3, label="left"),
            Line2D([], [], color=RIGHT_COLOR, lw=3, label="right"),
            Line2D([], [], color=SPINE_COLOR, lw=3, label="spine, head")]


def _draw_ground_grid_3d(ax, spacing: float = 0.5):
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    xs = np.arange(np.ceil(x0 / spacing), np.floor(x1 / spacing) + 1) * spacing
    ys = np.arange(np.ceil(y0 / spacing), np.floor(y1 / spacing) + 1) * spacing
    for x in xs:
        ax.plot([x, x], [y0, y1], [0, 0], color="0.85", linewidth=0.6, zorder=0)
    for y in ys:
        ax.plot([x0, x1], [y, y], [0, 0], color="0.85", linewidth=0.6, zorder=0)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def plot_motion_strip(motion, n: int = 6, view: str = "side", ax=None, spacing: Optional[float] = None,
                      color_by_side: bool = True, fps: Optional[float] = None):
    """Show a motion in one static figure: ``n`` evenly spaced frames drawn side by side.

    Each pose is centred on its pelvis along the view's horizontal axis and shifted by
    ``k * spacing``, like a film strip; its time in seconds is written under it.

    Args:
        motion: a ``Motion`` or joints ``(T, 22, 3)`` metres.
        n: number of frames shown (at most ``T``).
        view: ``"side"``, ``"front"`` or ``"top"``.
        ax: matplotlib axes; a new wide figure when ``None``.
        spacing: horizontal distance between poses, metres (default: widest pose + 0.25 m).
        color_by_side: left limbs blue, right red.
        fps: frame rate for the time labels (default ``motion.fps`` or 30).
    Returns:
        The axes.
    """
    check_choice(view, ("front", "side", "top"), "view")
    joints = _joints_sequence(motion)
    if n < 1:
        raise ValueError(f"n: expected a positive number of frames, got {n}")
    fps = float(fps or getattr(motion, "fps", 30.0))
    T = joints.shape[0]
    frames = np.unique(np.linspace(0, T - 1, min(n, T)).round().astype(int))
    h = _VIEW_AXES[view][0]
    centred = joints[frames].copy()
    centred[..., h] -= centred[:, :1, h]
    widths = project(centred, view)[..., 0]
    if spacing is None:
        spacing = float(np.max(widths.max(1) - widths.min(1))) + 0.25
    # The front view's x axis is flipped, so its strip runs in -x to read left to right.
    direction = -1.0 if view == "front" else 1.0
    if ax is None:
        _, ax = plt.subplots(figsize=(max(4.0, 1.3 * len(frames)), 3.2), layout="constrained")
    colors = bone_colors(color_by_side)
    vertical = project(centred, view)[..., 1]
    for k, f in enumerate(frames):
        _draw_skeleton_2d(ax, centred[k], view, colors, linewidth=2.5, offset=direction * k * spacing)
        ax.annotate(f"{f / fps:.2f} s", (direction * k * spacing, vertical.min()), xytext=(0, -14),
                    textcoords="offset points", ha="center", va="top", fontsize=8)
    if view != "top":
        ax.axhline(0.0, color="0.5", linewidth=1.0, zorder=1)
    span = np.array([direction * (len(frames) - 1) * spacing, 0.0])
    lo = np.array([min(0.0, span[0]) - spacing / 2, min(vertical.min(), 0.0) - 0.25])
    hi = np.array([max(0.0, span[0]) + spacing / 2, vertical.max() + 0.1])
    ax.update_datalim([lo, hi])
    ax.autoscale_view()
    _style_2d_axes(ax, view)
    ax.set_xlabel(f"{_AXIS_NAMES[h]} (m), each pose re-centred and shifted by {spacing:.2f} m")
    return ax


# ----------------------------------------------------------------------------- top-down views


def plot_object_footprint(obj, ax=None, view: str = "top", color=OBJECT_COLOR, label: Optional[str] = None,
                          alpha: float = 1.0, annotate: bool = False, zorder: float = 1.0):
    """Fill the projection of an object's mesh onto a 2D view (its footprint seen from above).

    The mesh's triangles are projected and filled in one colour, so concave shapes (an L-sofa,
    a chair with an open back) keep their true outline.

    Args:
        obj: a ``ToyObject`` (uses ``.mesh``, world frame) or a ``trimesh.Trimesh``.
        ax: matplotlib axes; a new figure when ``None``.
        view: ``"top"``, ``"front"`` or ``"side"``.
        color: fill colour.
        label: legend label.
        alpha: opacity of the fill.
        annotate: write the object's category at its centre.
    Returns:
        The axes.
    """
    check_choice(view, ("front", "side", "top"), "view")
    vertices, faces = _object_mesh(obj)
    ax = ax if ax is not None else plt.subplots(figsize=(4, 4))[1]
    tris = project(vertices, view)[faces]
    # Triangles seen edge-on (a box's walls from above) fill nothing. Of a closed, consistently wound surface (every
    # toy object's), those turned one way in the view (positive area) cover its whole projection on their own.
    edge_a, edge_b = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    area = edge_a[:, 0] * edge_b[:, 1] - edge_a[:, 1] * edge_b[:, 0]
    mesh = getattr(obj, "mesh", obj)
    closed = bool(getattr(mesh, "is_watertight", False) and getattr(mesh, "is_winding_consistent", False))
    drawn = area > 1e-12 if closed else np.abs(area) > 1e-12
    tris = tris[drawn] if drawn.any() else tris
    # Edges in the fill colour close the hairline gaps antialiasing leaves between triangles.
    rgba = to_rgba(color, alpha)
    coll = PolyCollection(tris, facecolors=rgba, edgecolors=rgba, linewidths=0.4, zorder=zorder, label=label)
    ax.add_collection(coll)
    pts = tris.reshape(-1, 2)
    ax.update_datalim(np.vstack([pts.min(0), pts.max(0)]))
    if annotate:
        name = _object_label(obj)
        if name:
            c = (pts.min(0) + pts.max(0)) / 2
            ax.text(c[0], c[1], name, ha="center", va="center", fontsize=7, color="0.15", zorder=zorder + 0.5)
    ax.autoscale_view()
    return ax


def _as_trajectory_list(trajectories) -> list[np.ndarray]:
    if isinstance(trajectories, Motion):
        trajectories = [trajectories]
    if isinstance(trajectories, (np.ndarray, torch.Tensor)):
        arr = _to_numpy(trajectories, "trajectories")
        if arr.ndim == 2:
            arr = arr[None]
        if arr.ndim != 3:
            raise ValueError(f"trajectories: expected shape (N, T, 2) or (N, T, 3), got {arr.shape}")
        trajectories = list(arr)
    out = []
    for i, traj in enumerate(trajectories):
        if isinstance(traj, Motion):
            traj = traj.joint("pelvis")
        arr = _to_numpy(traj, f"trajectories[{i}]")
        if arr.ndim != 2 or arr.shape[1] not in (2, 3) or arr.shape[0] < 1:
            raise ValueError(f"trajectories[{i}]: expected shape (T, 2) or (T, 3), got {arr.shape}")
        out.append(arr[:, :2])
    return out


def plot_trajectories_top_down(trajectories, ax=None, highlight=None, objects=None, start_markers: bool = True,
                               end_markers: bool = True, color=TRAJECTORY_COLOR, alpha: float = 0.7,
                               highlight_color=HIGHLIGHT_COLOR, linewidth: float = 1.0, legend: bool = True,
                               annotate_objects: bool = True):
    """Bird's-eye view of many pelvis paths around objects (the style of NIFTY Fig. 4).

    Args:
        trajectories: a list of ``(T_i, 2)`` or ``(T_i, 3)`` paths in metres (only x, y are used),
            an array ``(N, T, 2 or 3)``, or ``Motion`` objects (their pelvis path).
        ax: matplotlib axes; a new figure when ``None``.
        highlight: index or indices of paths drawn on top in ``highlight_color``.
        objects: ``ToyObject``s or trimeshes drawn as filled footprints.
        start_markers: mark each path's first point (a circle).
        end_markers: mark each path's last point (a cross).
        color: colour of the ordinary paths (NIFTY's light pink by default).
        alpha: opacity of the ordinary paths.
        highlight_color: colour of the highlighted paths (blue).
        linewidth: path width in points (highlighted paths are drawn twice as wide).
        legend: add a legend.
        annotate_objects: write each object's category on its footprint.
    Returns:
        The axes.
    """
    paths = _as_trajectory_list(trajectories)
    if highlight is None:
        highlight = []
    elif np.isscalar(highlight):
        highlight = [int(highlight)]
    highlight = [int(i) for i in highlight]
    for i in highlight:
        if not -len(paths) <= i < len(paths):
            raise ValueError(f"highlight: expected indices in [0, {len(paths)}), got {i}")
    highlight = sorted({i % len(paths) for i in highlight})
    ax = ax if ax is not None else plt.subplots(figsize=(5.5, 5.5))[1]
    for k, obj in enumerate(objects or ()):
        plot_object_footprint(obj, ax=ax, label="object" if k == 0 else None, annotate=annotate_objects)
    plain = [p for i, p in enumerate(paths) if i not in highlight]
    if plain:
        ax.add_collection(LineCollection(plain, colors=color, alpha=alpha, linewidths=linewidth, zorder=2,
                                         label="trajectories"))
    for n, i in enumerate(highlight):
        ax.plot(*paths[i].T, color=highlight_color, linewidth=2 * linewidth, zorder=4,
                label="highlighted" if n == 0 else None)
    starts = np.array([p[0] for p in paths])
    ends = np.array([p[-1] for p in paths])
    if start_markers:
        ax.scatter(*starts.T, s=14, facecolors="white", edgecolors="0.3", linewidths=0.8, zorder=5, label="start")
    if end_markers:
        ax.scatter(*ends.T, s=22, marker="x", color="k", linewidths=1.0, zorder=5, label="end")
    allpts = np.vstack(paths)
    ax.update_datalim(np.vstack([allpts.min(0) - 0.2, allpts.max(0) + 0.2]))
    ax.autoscale_view()
    _style_2d_axes(ax, "top")
    ax.set_title("pelvis trajectories, top-down view", fontsize=10)
    if legend:
        ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
    return ax


# ----------------------------------------------------------------------------- time lines


def _motion_fps(motion) -> float:
    return float(getattr(motion, "fps", 30.0))


def _action_bands(ax, actions: np.ndarray, fps: float, y0: float, height: float, legend: bool = True):
    present = []
    for a, b, label in _label_runs(actions):
        name = ACTIONS[label]
        ax.add_patch(Rectangle((a / fps, y0), (b - a) / fps, height, facecolor=ACTION_COLORS[name],
                               edgecolor="white", linewidth=0.5, zorder=2))
        if name not in present:
            present.append(name)
    if legend and present:
        handles = [Patch(facecolor=ACTION_COLORS[n], label=n) for n in present]
        ax.legend(handles=handles, title="action", loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
                  title_fontsize=8, frameon=False)
    return present


def _contact_color(name: str) -> str:
    return LEFT_COLOR if name.startswith("left_") else RIGHT_COLOR if name.startswith("right_") else SPINE_COLOR


def plot_contacts(motion, ax=None):
    """Contact timeline: one row per contact joint (SAMP Eq. 1's ``c_i``), actions as bands on top.

    Args:
        motion: a ``Motion`` with ``contacts (T, 5)`` bool (``CONTACT_JOINTS`` order) and
            optionally ``actions (T,)``.
        ax: matplotlib axes; a new figure when ``None``.
    Returns:
        The axes (time in seconds on x; a legend of the actions present).
    """
    contacts = getattr(motion, "contacts", None)
    if contacts is None:
        raise ValueError("motion: expected a Motion with contact labels (contacts of shape (T, 5))")
    contacts = np.asarray(contacts, dtype=bool)
    check_shape(contacts, (None, len(CONTACT_JOINTS)), "motion.contacts")
    fps = _motion_fps(motion)
    T = contacts.shape[0]
    ax = ax if ax is not None else plt.subplots(figsize=(8, 2.8))[1]
    rows = list(CONTACT_JOINTS)
    for r, name in enumerate(rows):
        y = len(rows) - 1 - r
        spans = [(a / fps, (b - a) / fps) for a, b in _runs(contacts[:, r])]
        ax.broken_barh(spans, (y - 0.35, 0.7), facecolors=_contact_color(name), zorder=2)
    ticks = list(range(len(rows)))
    labels = [rows[len(rows) - 1 - y].replace("_", " ") for y in ticks]
    actions = getattr(motion, "actions", None)
    if actions is not None:
        _action_bands(ax, np.asarray(actions), fps, len(rows) - 0.3, 0.8)
        ticks.append(len(rows) + 0.1)
        labels.append("action")
    ax.set_yticks(ticks, labels)
    ax.set_ylim(-0.6, len(rows) + (0.7 if actions is not None else -0.4))
    ax.set_xlim(0, T / fps)
    ax.set_xlabel("time (s)")
    ax.set_title("contacts (bars: in contact)", fontsize=10)
    ax.grid(axis="x", color="0.9", zorder=0)
    return ax


def plot_foot_heights(motion, ax=None, joints: Sequence[str] = ("left_foot", "right_foot", "left_ankle",
                                                                     "right_ankle")):
    """Foot and ankle heights over time, with the labelled foot-contact intervals shaded.

    A planted foot shows as a flat line at ``FOOT_JOINT_HEIGHT`` inside its shaded interval.

    Args:
        motion: a ``Motion`` (contacts optional) or joints ``(T, 22, 3)`` metres at 30 fps.
        ax: matplotlib axes; a new figure when ``None``.
        joints: joint names to draw (feet solid, ankles dashed).
    Returns:
        The axes.
    """
    seq = _joints_sequence(motion)
    fps = _motion_fps(motion)
    t = np.arange(seq.shape[0]) / fps
    ax = ax if ax is not None else plt.subplots(figsize=(8, 3))[1]
    for name in joints:
        j = joint_index(name)
        ax.plot(t, seq[:, j, 2], color=_contact_color(name), linestyle="--" if "ankle" in name else "-",
                linewidth=1.5, label=name.replace("_", " "))
    contacts = getattr(motion, "contacts", None)
    if contacts is not None:
        for name in ("left_foot", "right_foot"):
            col = CONTACT_JOINTS.index(name)
            for n, (a, b) in enumerate(_runs(np.asarray(contacts)[:, col])):
                ax.axvspan(a / fps, b / fps, color=_contact_color(name), alpha=0.12, linewidth=0, zorder=0,
                           label=f"{name.replace('_', ' ')} contact" if n == 0 else None)
    ax.axhline(FOOT_JOINT_HEIGHT, color="0.4", linewidth=0.8, linestyle=":", label="flat-foot height")
    ax.set_xlim(t[0], max(t[-1], t[0] + 1.0 / fps))
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("height above ground (m)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return ax


# ----------------------------------------------------------------------------- scenes


def _grid_extent(room) -> tuple[float, float, float, float]:
    """``(x0, x1, y0, y1)`` metres covered by a scene's occupancy grid."""
    if hasattr(room, "extent"):
        return tuple(float(v) for v in room.extent)
    occ = np.asarray(room.occupancy)
    cell = float(room.cell_size)
    first = np.asarray(room.grid_to_world(np.array([0, 0])), dtype=float)[:2]
    last = np.asarray(room.grid_to_world(np.array([occ.shape[0] - 1, occ.shape[1] - 1])), dtype=float)[:2]
    lo = np.minimum(first, last) - cell / 2
    hi = np.maximum(first, last) + cell / 2
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def _occupancy_image(room) -> np.ndarray:
    """The occupancy grid as an image whose rows follow +y and columns +x (for ``origin="lower"``)."""
    occ = np.asarray(room.occupancy, dtype=bool)
    probe = np.asarray(room.grid_to_world(np.array([[0, 0], [1, 0], [0, 1]])), dtype=float)[:, :2]
    row_step, col_step = probe[1] - probe[0], probe[2] - probe[0]
    if abs(row_step[0]) > abs(row_step[1]):  # first index runs along x: transpose to rows along y
        occ, row_step, col_step = occ.T, col_step, row_step
    if row_step[1] < 0:
        occ = occ[::-1]
    if col_step[0] < 0:
        occ = occ[:, ::-1]
    return occ


def plot_room(room, ax=None, path=None, show_grid: bool = True, annotate: bool = True, show_goals: bool = True,
              object_colors: Optional[Sequence] = None):
    """Top-down room: the navigation occupancy grid, the objects' footprints and an optional path.

    Args:
        room: a ``world.scenes.Room`` (``occupancy (H, W)`` bool with rows along +y, ``cell_size``
            metres, ``grid_to_world``, ``objects``; the ``target`` is outlined in blue).
        ax: matplotlib axes; a new figure when ``None``.
        path: ``(N, 2)`` or ``(N, 3)`` world path in metres (floats), or ``(N, 2)`` integer grid
            cells ``[i, j]`` (converted with ``room.grid_to_world``).
        show_grid: draw the cell boundaries (grids up to 200 cells a side).
        annotate: write object categories.
        show_goals: draw the target's sit goals as arrows (when the scene has a ``target``).
        object_colors: one fill colour per object (default: all a neutral brown).
    Returns:
        The axes.
    """
    occ = np.asarray(room.occupancy, dtype=bool)
    check_shape(occ, (None, None), "room.occupancy")
    ax = ax if ax is not None else plt.subplots(figsize=(6.5, 6), layout="constrained")[1]
    x0, x1, y0, y1 = _grid_extent(room)
    image = _occupancy_image(room)
    ax.imshow(image, origin="lower", extent=(x0, x1, y0, y1), cmap=ListedColormap(["#f7f7f2", "#d9cfbd"]),
              vmin=0, vmax=1, interpolation="nearest", zorder=0)
    cell = float(room.cell_size)
    if show_grid and max(image.shape) <= 200:
        xs = np.linspace(x0, x1, image.shape[1] + 1)
        ys = np.linspace(y0, y1, image.shape[0] + 1)
        segs = [[(x, y0), (x, y1)] for x in xs] + [[(x0, y), (x1, y)] for y in ys]
        ax.add_collection(LineCollection(segs, colors="0.9", linewidths=0.3, zorder=0.5))
    objects = list(getattr(room, "objects", ()))
    colors = list(object_colors) if object_colors is not None else [OBSTACLE_COLOR] * len(objects)
    if len(colors) != len(objects):
        raise ValueError(f"object_colors: expected {len(objects)} colours, got {len(colors)}")
    target = getattr(room, "target", None)
    for k, obj in enumerate(objects):
        plot_object_footprint(obj, ax=ax, color=colors[k], annotate=annotate, zorder=1 + 0.01 * k,
                              alpha=0.85, label="object footprint" if k == 0 else None)
        if obj is target:
            verts = project(_object_mesh(obj)[0], "top")
            lo, hi = verts.min(0), verts.max(0)
            ax.add_patch(Rectangle(lo, *(hi - lo), fill=False, edgecolor=HIGHLIGHT_COLOR, linewidth=1.5,
                                   zorder=2, label="target"))
    if show_goals and target is not None and hasattr(target, "sit_goals"):
        pos, direction = (np.asarray(a, dtype=float) for a in target.sit_goals)
        ax.quiver(pos[:, 0], pos[:, 1], direction[:, 0], direction[:, 1], color=HIGHLIGHT_COLOR, angles="xy",
                  scale_units="xy", scale=2.5, width=0.006, zorder=5, label="sit goal")
    if path is not None:
        raw = np.asarray(path.detach().cpu() if isinstance(path, torch.Tensor) else path)
        if raw.ndim != 2 or raw.shape[1] not in (2, 3):
            raise ValueError(f"path: expected shape (N, 2) or (N, 3), got {raw.shape}")
        if np.issubdtype(raw.dtype, np.integer):
            if raw.shape[1] != 2:
                raise ValueError(f"path: integer grid cells must have shape (N, 2), got {raw.shape}")
            pts = np.asarray(room.grid_to_world(raw), dtype=float)
        else:
            pts = raw.astype(float)
        ax.plot(pts[:, 0], pts[:, 1], color=PATH_COLOR, linewidth=2, zorder=3, label="path")
        ax.scatter(*pts[0, :2], s=40, color=PATH_COLOR, edgecolors="k", zorder=4, label="start")
        ax.scatter(*pts[-1, :2], s=90, marker="*", color=PATH_COLOR, edgecolors="k", zorder=4, label="end")
    ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="0.2", linewidth=1.2, zorder=2))
    ax.set_xlim(x0 - cell, x1 + cell)
    ax.set_ylim(y0 - cell, y1 + cell)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    handles = [Patch(facecolor="#d9cfbd", edgecolor="0.7", label="occupied cell")]
    handles += ax.get_legend_handles_labels()[0]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.set_title(f"top-down view, occupancy grid of {cell:.2f} m cells", fontsize=10)
    return ax


def plot_kitchen_top_down(kitchen, ax=None, annotate: bool = True):
    """Top-down kitchen: occupancy grid, furniture, floor obstacles and the small items on them.

    Args:
        kitchen: a ``world.scenes.Kitchen`` (``furniture``, ``obstacles``, ``items``; ``objects`` in
            that order; ``occupancy``, ``cell_size`` and ``grid_to_world`` as for a room).
        ax: matplotlib axes; a new figure when ``None``.
        annotate: write the furniture's and obstacles' categories (items are marked by colour).
    Returns:
        The axes.
    """
    furniture = list(getattr(kitchen, "furniture", ()))
    obstacles = list(getattr(kitchen, "obstacles", ()))
    items = list(getattr(kitchen, "items", ()))
    objects = list(kitchen.objects)
    if len(objects) != len(furniture) + len(obstacles) + len(items):
        # A scene without the kitchen's groups: every object is drawn alike.
        return plot_room(kitchen, ax=ax, show_grid=False, annotate=annotate)
    colors = [OBSTACLE_COLOR] * len(furniture) + ["0.45"] * len(obstacles) + [ITEM_COLOR] * len(items)
    ax = plot_room(kitchen, ax=ax, show_grid=False, annotate=False, object_colors=colors)
    if annotate:
        for obj in furniture + obstacles:
            c = project(_object_mesh(obj)[0], "top")
            centre = (c.min(0) + c.max(0)) / 2
            ax.text(*centre, obj.category.replace("_", " "), ha="center", va="center", fontsize=7, color="0.1",
                    zorder=6, bbox=dict(boxstyle="round,pad=0.15", facecolor="white", alpha=0.6, linewidth=0))
    extra = [Patch(facecolor=OBSTACLE_COLOR, label="furniture"), Patch(facecolor="0.45", label="obstacle"),
             Patch(facecolor=ITEM_COLOR, label="item (bottle, mug, teapot)")]
    ax.legend(handles=[Patch(facecolor="#d9cfbd", edgecolor="0.7", label="occupied cell")] + extra,
              loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.set_title("kitchen, top-down view", fontsize=10)
    return ax


# ----------------------------------------------------------------------------- voxels


def plot_voxels(occupancy, ax=None, threshold: float = 0.05, cmap: str = "viridis", edgecolor="0.3",
                elev: float = 25.0, azim: float = 60.0):
    """SAMP's 8×8×8 interaction code drawn as voxels, opacity and colour growing with occupancy.

    Args:
        occupancy: ``(N, N, N)`` occupancy in [0, 1] indexed ``[x, y, z]`` (8×8×8 in SAMP).
        ax: 3D matplotlib axes; a new figure when ``None``.
        threshold: cells at or below this occupancy are left empty.
        cmap: matplotlib colormap for the occupancy.
        edgecolor: voxel edge colour.
        elev, azim: camera angles in degrees (the default looks from the front-right, above).
    Returns:
        The axes.
    """
    occ = _to_numpy(occupancy, "occupancy")
    check_shape(occ, (None, None, None), "occupancy")
    ax = _new_axes(ax, "3d", figsize=(4.5, 4.5))
    filled = occ > threshold
    colors = matplotlib.colormaps[cmap](np.clip(occ, 0.0, 1.0))
    colors[..., 3] = 0.25 + 0.7 * np.clip(occ, 0.0, 1.0)
    ax.voxels(filled, facecolors=colors, edgecolors=edgecolor, linewidth=0.3)
    ax.set_xlim(0, occ.shape[0])
    ax.set_ylim(0, occ.shape[1])
    ax.set_zlim(0, occ.shape[2])
    ax.set_box_aspect(occ.shape)
    ax.view_init(elev=elev, azim=azim)
    ax.set_xlabel("x cell")
    ax.set_ylabel("y cell")
    ax.set_zlabel("z cell")
    mappable = matplotlib.cm.ScalarMappable(cmap=cmap, norm=Normalize(0.0, 1.0))
    ax.figure.colorbar(mappable, ax=ax, shrink=0.6, pad=0.15, label="occupancy")
    ax.set_title(f"occupancy voxels ({int(filled.sum())} of {filled.size} above {threshold:g})", fontsize=10)
    return ax
