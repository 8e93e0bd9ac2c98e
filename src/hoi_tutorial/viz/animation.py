"""Stick-figure animations of motions, embedded in a page as HTML (no ffmpeg needed).

``animate_motion`` builds a matplotlib ``FuncAnimation``; ``to_html`` turns it into a
self-contained JavaScript player (the page ``FuncAnimation.to_jshtml`` writes, with each frame drawn
once instead of twice) and ``show_animation`` returns it as an ``IPython.display.HTML`` object,
closing the figure so a notebook shows no static copy. A moving object whose shape and pose did not
change since the last frame keeps its polygons.
Frames are subsampled (``stride``, ``max_frames``) and drawn at a modest dpi to keep the page
small: a 5 s clip (75 frames) at the defaults embeds in 1.5–2.5 MB.
"""
from __future__ import annotations

import base64
import logging
import math
from io import BytesIO
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Callable, Optional, Sequence

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation, HTMLWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import to_rgba
from matplotlib.transforms import Bbox
from PIL import Image
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from .._validate import check_choice
from ..world.motion import ACTIONS
from ..world.skeleton import NUM_JOINTS, PARENTS, joint_index
from .plots import (
    OBJECT_COLOR,
    SPINE_COLOR,
    _VIEW_DEPTH,
    _draw_ground_grid_3d,
    _joints_sequence,
    _object_mesh,
    _set_3d_limits,
    _style_2d_axes,
    bone_colors,
    plot_object_footprint,
    project,
)

__all__ = ["animate_motion", "to_html", "show_animation"]

_TRAIL_COLORS = ("#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2")
_BONES = [(PARENTS[j], j) for j in range(1, NUM_JOINTS)]
_MAX_OBJECT_FACES = 600  # triangles per object drawn in 3D; more are merged by vertex clustering


def _cluster_decimate(vertices: np.ndarray, faces: np.ndarray, max_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """Fewer triangles by merging vertices that share a grid cell (mplot3d slows with many faces).

    Args:
        vertices: ``(V, 3)`` metres; faces: ``(F, 3)`` vertex indices.
    Returns:
        ``(vertices (V', 3), faces (F', 3))`` with ``F'`` at most about ``max_faces``.
    """
    if len(faces) <= max_faces:
        return vertices, faces
    extent = float(np.ptp(vertices, axis=0).max())
    cells = 24
    while cells >= 2:
        keys = np.floor((vertices - vertices.min(0)) / (extent / cells)).astype(np.int64)
        _, cluster, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        cluster = cluster.reshape(-1)
        merged = np.zeros((len(counts), 3))
        np.add.at(merged, cluster, vertices)
        merged /= counts[:, None]
        new_faces = cluster[faces]
        keep = ((new_faces[:, 0] != new_faces[:, 1]) & (new_faces[:, 1] != new_faces[:, 2])
                & (new_faces[:, 0] != new_faces[:, 2]))
        new_faces = np.unique(np.sort(new_faces[keep], axis=1), axis=0)
        if len(new_faces) <= max_faces:
            return merged, new_faces
        cells = int(cells * 0.75)
    return merged, new_faces


_ZOOM_NORM = 1.8294640721620434  # mplot3d's box-aspect norm at zoom 1 (Axes3D.set_box_aspect)


def _content_bbox(fig, ax):
    """Pixel bounding box of a 3D axes' drawn box, ticks and labels."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return Bbox.union([axis.get_tightbbox(renderer) for axis in (ax.xaxis, ax.yaxis, ax.zaxis)])


def _fit_3d_axes(fig, ax, top_px: float = 26.0, margin_px: float = 4.0) -> None:
    """Crop a 3D figure to its content: mplot3d draws into a square, which leaves a flat scene (a
    long walk) floating in empty space. The figure keeps its width, gets the content's height, and
    the zoom is adjusted (a few measured passes) so the box, ticks and labels fill it."""
    width, height = fig.bbox.width, fig.bbox.height
    box = _content_bbox(fig, ax)
    aspect = np.asarray(ax.get_box_aspect())
    zoom = float(np.linalg.norm(aspect)) / _ZOOM_NORM
    side_before = min(ax.get_position().width * width, ax.get_position().height * height)
    grow = (width - 2 * margin_px) / box.width
    new_height = min(height, box.height * grow + top_px + 2 * margin_px)
    fig.set_size_inches(width / fig.dpi, new_height / fig.dpi)
    ax.set_position([0.0, 0.0, 1.0, 1.0])
    zoom *= grow * side_before / min(width, new_height)
    # Content now reaches past the axes' square, so nothing may be clipped to it.
    for artist in ax.get_children():
        artist.set_clip_on(False)
    for _ in range(3):
        ax.set_box_aspect(aspect, zoom=zoom)
        box = _content_bbox(fig, ax)
        zoom *= min((width - 2 * margin_px) / box.width, (new_height - top_px - 2 * margin_px) / box.height)
        ax.set_box_aspect(aspect, zoom=zoom)
        box = _content_bbox(fig, ax)
        dx = (width - box.x1 - box.x0) / 2
        dy = (new_height - top_px - box.y1 - box.y0) / 2
        pos = ax.get_position()
        ax.set_position([pos.x0 + dx / width, pos.y0 + dy / new_height, pos.width, pos.height])


def _shaded_faces(vertices: np.ndarray, faces: np.ndarray, alpha: float = 0.45) -> np.ndarray:
    """RGBA per face ``(F, 4)``: the object colour lit by a light above the camera (Lambert), so a
    mesh reads as a solid without edge lines (which would also inflate every embedded frame)."""
    tris = vertices[faces]
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    light = np.array([0.35, 0.6, 0.72]) / np.linalg.norm([0.35, 0.6, 0.72])
    # Face winding may vary between parts; |n . l| lights both sides alike.
    shade = 0.55 + 0.45 * np.abs(normals @ light)
    rgba = np.tile(to_rgba(OBJECT_COLOR, alpha), (len(faces), 1))
    rgba[:, :3] *= shade[:, None]
    return rgba


def _frame_indices(T: int, stride: int, max_frames: int) -> tuple[np.ndarray, int]:
    if stride < 1:
        raise ValueError(f"stride: expected a positive integer, got {stride}")
    if max_frames < 1:
        raise ValueError(f"max_frames: expected a positive integer, got {max_frames}")
    stride = max(stride, math.ceil(T / max_frames))
    return np.arange(0, T, stride), stride


def animate_motion(motions, *, view: str = "3d", objects: Sequence = (), moving_objects: Sequence[Callable] = (),
                   fps: Optional[float] = None,
                   stride: int = 2, trail_joint: Optional[str] = "pelvis", figsize=(5, 5), max_frames: int = 150,
                   dpi: int = 64, color_by_side: bool = True, title: Optional[str] = None,
                   elev: float = 22.0, azim: float = 60.0, frame_points=None) -> FuncAnimation:
    """Animate one or several motions as stick figures with fixed axes and the objects around them.

    Args:
        motions: a ``Motion`` or joints ``(T, 22, 3)`` metres, or a list of them (played together;
            a shorter clip holds its last frame).
        view: ``"3d"`` (perspective, ground grid, objects as see-through shaded meshes), ``"side"``
            (from +X), ``"front"`` (from +Y) or ``"top"`` (object footprints).
        objects: ``ToyObject``s or trimeshes in the world frame.
        moving_objects: callables ``frame -> ToyObject or trimesh`` (world frame) for objects that move or
            change shape (a door that opens, a carried bottle); ``frame`` indexes the first motion. 3D view only.
        fps: frame rate of the input clips (default: the first Motion's ``fps``, else 30); the
            animation plays in real time.
        stride: show every ``stride``-th frame (raised further so at most ``max_frames`` are drawn).
        trail_joint: joint whose path is drawn as it is traversed (on the ground in 3D), or None.
        figsize: figure size in inches.
        max_frames: cap on the number of animation frames (the embedded page grows with it).
        dpi: resolution of the frames.
        color_by_side: left limbs blue, right limbs red.
        title: text shown above the time (and action label, when the clip has labels).
        elev, azim: 3D camera angles in degrees (the default looks from the front-right, above).
        frame_points: world points ``(..., 3)`` metres (e.g. joints ``(T, 22, 3)``) the axes must also hold, or None.
            Two animations shown side by side get the same axes when both are given the joints of both (with the
            same objects).
    Returns:
        ``matplotlib.animation.FuncAnimation`` (see :func:`to_html`, :func:`show_animation`).
    """
    check_choice(view, ("3d", "side", "top", "front"), "view")
    clips = list(motions) if isinstance(motions, (list, tuple)) else [motions]
    if not clips:
        raise ValueError("motions: expected at least one motion")
    seqs = [_joints_sequence(m, f"motions[{k}]") for k, m in enumerate(clips)]
    fps = float(fps or getattr(clips[0], "fps", 30.0))
    T = max(s.shape[0] for s in seqs)
    frames, stride = _frame_indices(T, stride, max_frames)
    trail = joint_index(trail_joint) if trail_joint is not None else None
    actions = [getattr(m, "actions", None) for m in clips]
    objects = list(objects)
    moving_objects = list(moving_objects)
    if moving_objects and view != "3d":
        raise ValueError(f"moving_objects: expected view='3d' (moving objects are drawn in 3D only), got {view!r}")
    if not all(callable(m) for m in moving_objects):
        raise ValueError("moving_objects: expected callables frame -> object")

    fig = plt.figure(figsize=figsize, dpi=dpi)
    colors = bone_colors(color_by_side)
    bone_idx = np.array(_BONES)
    object_points = [_object_mesh(o)[0] for o in objects] + [_object_mesh(m(0))[0] for m in moving_objects]
    framed = []  # points the axes hold besides the bodies and objects
    if frame_points is not None:
        frame_points = np.asarray(frame_points, dtype=float)
        if frame_points.ndim < 2 or frame_points.shape[-1] != 3 or frame_points.size == 0 \
                or not np.isfinite(frame_points).all():
            raise ValueError(f"frame_points: expected finite world points (..., 3) in metres, got shape "
                             f"{frame_points.shape}")
        framed.append(frame_points.reshape(-1, 3))
    allpts = np.vstack([s.reshape(-1, 3) for s in seqs] + object_points + framed)

    if view == "3d":
        ax = fig.add_subplot(projection="3d")
        # Fixed drawing order (ground, objects, trails, bodies): a body stays readable even where
        # the depth sort of mplot3d's painter's algorithm would hide it behind a see-through object.
        ax.computed_zorder = False
        _set_3d_limits(ax, allpts, margin=0.2, ground=True)
        _draw_ground_grid_3d(ax)
        for obj in objects:
            vertices, faces = _cluster_decimate(*_object_mesh(obj), _MAX_OBJECT_FACES)
            ax.add_collection3d(Poly3DCollection(vertices[faces], facecolors=_shaded_faces(vertices, faces),
                                                 edgecolors="none", zorder=1))
        moving = []
        for m in moving_objects:
            vertices, faces = _cluster_decimate(*_object_mesh(m(0)), _MAX_OBJECT_FACES)
            moving.append(ax.add_collection3d(Poly3DCollection(vertices[faces], facecolors=_shaded_faces(vertices, faces),
                                                               edgecolors="none", zorder=1)))
        ax.view_init(elev=elev, azim=azim)
        skeletons = [ax.add_collection3d(Line3DCollection(s[0][bone_idx], colors=colors, linewidths=2.5, zorder=3))
                     for s in seqs]
        heads = [ax.plot(*s[0, joint_index("head")][:, None], "o", color=SPINE_COLOR, markersize=6, zorder=4)[0]
                 for s in seqs]
        trails = [ax.plot([], [], [], color=_TRAIL_COLORS[k % len(_TRAIL_COLORS)], linewidth=1.5, zorder=2)[0]
                  for k in range(len(seqs))] if trail is not None else []
    else:
        moving = []
        ax = fig.add_subplot()
        for obj in objects:
            plot_object_footprint(obj, ax=ax, view=view, annotate=False)
        pts2d = project(allpts, view)
        pad = 0.2
        lo, hi = pts2d.min(0) - pad, pts2d.max(0) + pad
        if view != "top":
            lo[1] = min(lo[1], -pad)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        # Fit the figure to the data's aspect so a long walk is not a thin strip in a square.
        ratio = float(np.clip((hi[1] - lo[1]) / (hi[0] - lo[0]), 0.3, 1.5))
        fig.set_size_inches(figsize[0], figsize[0] * ratio + 0.9)
        if view != "top":
            ax.axhline(0.0, color="0.5", linewidth=1.0, zorder=1)
        _style_2d_axes(ax, view)
        ax.set_aspect("equal", adjustable="box")
        skeletons = [ax.add_collection(LineCollection(project(s[0], view)[bone_idx], colors=colors, linewidths=2.5,
                                                      zorder=3, capstyle="round")) for s in seqs]
        heads = [ax.plot(*project(s[0, joint_index("head")], view), "o", color=SPINE_COLOR, markersize=7,
                         zorder=4)[0] for s in seqs]
        trails = [ax.plot([], [], color=_TRAIL_COLORS[k % len(_TRAIL_COLORS)], linewidth=1.5, zorder=2)[0]
                  for k in range(len(seqs))] if trail is not None else []
    # In 3D the axes fill the figure (see _fit_3d_axes), so the caption belongs to the figure.
    caption = fig.suptitle("", fontsize=10, y=0.99, va="top") if view == "3d" else ax.set_title("", fontsize=10)

    last_key = [None] * len(moving)

    def update(i: int):
        f = int(frames[i])
        labels = []
        for k, (collection, m) in enumerate(zip(moving, moving_objects)):
            obj = m(f)
            key = _object_key(obj)
            if key is not None and key == last_key[k]:
                continue  # the same shape and pose as the last frame drawn: its polygons stand
            vertices, faces = _cluster_decimate(*_object_mesh(obj), _MAX_OBJECT_FACES)
            collection.set_verts(vertices[faces])
            collection.set_facecolor(_shaded_faces(vertices, faces))
            last_key[k] = key
        for k, s in enumerate(seqs):
            fk = min(f, s.shape[0] - 1)
            pose = s[fk]
            if view == "3d":
                skeletons[k].set_segments(pose[bone_idx])
                heads[k].set_data_3d(*pose[joint_index("head")][:, None])
                if trails:
                    path = s[: fk + 1, trail]
                    trails[k].set_data_3d(path[:, 0], path[:, 1], np.zeros(len(path)))
            else:
                segs = project(pose, view)[bone_idx]
                # Nearer bones on top: sort by depth along the viewing direction.
                depth = pose[bone_idx, _VIEW_DEPTH[view]].mean(1)
                order = np.argsort(depth)
                skeletons[k].set_segments(segs[order])
                skeletons[k].set_color([colors[b] for b in order])
                heads[k].set_data(*project(pose[joint_index("head")], view)[:, None])
                if trails:
                    path = project(s[: fk + 1, trail], view)
                    trails[k].set_data(path[:, 0], path[:, 1])
            if actions[k] is not None:
                labels.append(ACTIONS[int(actions[k][fk])].replace("_", " "))
        text = f"t = {f / fps:.2f} s"
        if labels:
            text += "   " + ", ".join(dict.fromkeys(labels))
        caption.set_text(f"{title}\n{text}" if title else text)
        return skeletons + heads + trails + moving + [caption]

    update(0)
    if view == "3d":
        _fit_3d_axes(fig, ax, top_px=(2 if title else 1) * 14.0 + 6.0)
    else:
        fig.tight_layout()
    anim = FuncAnimation(fig, update, frames=len(frames), interval=1000.0 * stride / fps, blit=False)
    anim._hoi_frames = (update, len(frames))  # what to_html draws frame by frame (_drawn_frames)
    return anim


def _object_key(obj):
    """What decides a ``ToyObject``'s mesh (category, parameters, pose), or None for anything else."""
    params = getattr(obj, "params", None)
    pose = getattr(obj, "pose", None)
    if not isinstance(params, dict) or not isinstance(pose, np.ndarray):
        return None
    return (getattr(obj, "category", None), repr(sorted(params.items())), pose.tobytes())


class _DrawnFrameWriter(HTMLWriter):
    """``HTMLWriter`` that embeds the frame the animation has just drawn on its Agg canvas.

    ``Animation.save`` draws every frame (``draw_idle`` after the update) and then ``grab_frame`` saves the
    figure, which draws it a second time; here the drawn pixels are encoded as they are, halving the drawing.
    A canvas that is not Agg, or a figure changed since its draw, goes through ``savefig`` as before.
    """

    def grab_frame(self, **savefig_kwargs):
        canvas = self.fig.canvas
        # Animation.save asks for the figure's own face colour, opaque: what the canvas has drawn
        kept = (set(savefig_kwargs) <= {"facecolor", "transparent"} and not savefig_kwargs.get("transparent", False)
                and to_rgba(savefig_kwargs.get("facecolor", self.fig.get_facecolor())) == to_rgba(self.fig.get_facecolor()))
        if (not self.embed_frames or not kept or self._hit_limit or self.fig.stale
                or self.frame_format != "png" or not isinstance(canvas, FigureCanvasAgg)
                or self.dpi != self.fig.dpi or getattr(canvas, "renderer", None) is None):
            return super().grab_frame(**savefig_kwargs)
        pixels = np.asarray(canvas.buffer_rgba())
        width, height = canvas.get_width_height(physical=True)
        if pixels.shape[:2] != (height, width):
            return super().grab_frame(**savefig_kwargs)
        self.add_pixels(pixels)

    def add_pixels(self, pixels: np.ndarray) -> bool:
        """Embed ``(H, W, 4)`` RGBA pixels as the next frame; False (nothing embedded) past the size limit."""
        if self._hit_limit:
            return False
        buffer = BytesIO()
        Image.fromarray(pixels).save(buffer, format="png")
        data = base64.encodebytes(buffer.getvalue()).decode("ascii")
        if self._total_bytes + len(data) >= self._bytes_limit:  # as HTMLWriter: warn, drop this frame and the later ones
            logging.getLogger("matplotlib.animation").warning(
                "Animation size has reached %s bytes, exceeding the limit of %s. This and further frames will be "
                "dropped.", self._total_bytes + len(data), self._bytes_limit)
            self._hit_limit = True
            return False
        self._total_bytes += len(data)
        self._saved_frames.append(data)
        return True


# to_html draws the still parts of an animate_motion figure once and each frame's moving artists over them; False:
# every frame drawn whole (the tests compare the two)
_DRAW_STILL_PARTS_ONCE = True


def _sorted_children(ax) -> list:
    """The artists an axes' draw sorts by zorder, ties in the order they were added (matplotlib's stable sort):
    its children but its background patch, and in 3D its axes, ticks and panes (drawn first, before them all)."""
    first = {id(ax.patch)} | ({id(axis) for axis in ax._axis_map.values()} if ax.name == "3d" else set())
    children = [a for a in ax.get_children() if id(a) not in first]
    return sorted(children, key=lambda a: a.get_zorder())


def _draw_order(fig) -> dict:
    """``{id(artist): rank}`` in the order a full draw of ``fig`` takes: each axes' sorted children, in the order
    of the axes, then the figure's own texts (a title over the axes)."""
    order = [a for ax in fig.axes for a in _sorted_children(ax)] + sorted(fig.texts, key=lambda a: a.get_zorder())
    return {id(a): rank for rank, a in enumerate(order)}


def _drawn_frames(anim: FuncAnimation):
    """Each frame of an :func:`animate_motion` animation as ``(H, W, 4)`` RGBA pixels of its Agg canvas.

    The still parts (axes, ticks, ground, objects that do not move) are drawn once; each frame restores them and
    draws the artists the update changes, with every still artist that a full draw puts above them (so the order,
    and the pixels, are those of drawing each frame whole). Yields the canvas buffer: read it before the next.
    """
    update, n_frames = anim._hoi_frames
    fig = anim._fig
    canvas = fig.canvas
    moving = list(update(0))
    rank = _draw_order(fig)
    if any(id(a) not in rank for a in moving):
        raise ValueError("anim: an artist its update returns is neither an axes' child nor a figure text")
    lowest = min(rank[id(a)] for a in moving)
    kept = {id(a) for a in moving}
    still_above = [a for ax in fig.axes for a in _sorted_children(ax)
                   if id(a) not in kept and a.get_visible() and rank[id(a)] > lowest]
    redrawn = sorted(moving + still_above, key=lambda a: rank[id(a)])
    for artist in redrawn:
        artist.set_animated(True)  # left out of a full draw
    try:
        canvas.draw()
        background = canvas.copy_from_bbox(fig.bbox)
        for i in range(n_frames):
            update(i)
            canvas.restore_region(background)
            for artist in redrawn:
                if hasattr(artist, "do_3d_projection"):  # a 3D collection: what Axes3D.draw does before drawing it
                    artist.do_3d_projection()
                (artist.axes or fig).draw_artist(artist)
            yield np.asarray(canvas.buffer_rgba())
    finally:
        for artist in redrawn:
            artist.set_animated(False)


def to_html(anim: FuncAnimation, default_mode: str = "loop") -> str:
    """The animation as a self-contained HTML/JavaScript player (what ``FuncAnimation.to_jshtml`` writes).

    Each frame is drawn once (``_DrawnFrameWriter``); ``to_jshtml`` draws it twice. For an animation of
    :func:`animate_motion`, the still parts (axes, ticks, ground, objects) are drawn once and each frame draws only
    what moves (``_drawn_frames``: the same pixels).

    Args:
        anim: an animation from :func:`animate_motion`.
        default_mode: ``"loop"``, ``"once"`` or ``"reflect"``.
    Returns:
        HTML text with the frames embedded as base64 PNGs.
    """
    check_choice(default_mode, ("loop", "once", "reflect"), "default_mode")
    # The default embed limit (20 MB) is far above what animate_motion produces; keep it explicit.
    with matplotlib.rc_context({"animation.embed_limit": 50.0}), TemporaryDirectory() as folder:
        path = Path(folder, "animation.html")
        writer = _DrawnFrameWriter(fps=1000.0 / anim._interval, embed_frames=True, default_mode=default_mode)
        if (_DRAW_STILL_PARTS_ONCE and getattr(anim, "_hoi_frames", None) is not None
                and isinstance(anim._fig.canvas, FigureCanvasAgg)):
            with writer.saving(anim._fig, str(path), anim._fig.dpi):
                for pixels in _drawn_frames(anim):
                    writer.add_pixels(pixels)
            anim._draw_was_started = True  # drawn: no "deleted without rendering" warning
        else:
            anim.save(str(path), writer=writer)
        return path.read_text()


def show_animation(anim: FuncAnimation, default_mode: str = "loop"):
    """``IPython.display.HTML`` of the animation; closes its figure so no static copy is shown.

    Args:
        anim: an animation from :func:`animate_motion`.
        default_mode: ``"loop"``, ``"once"`` or ``"reflect"``.
    Returns:
        ``IPython.display.HTML``.
    """
    from IPython.display import HTML

    html = to_html(anim, default_mode=default_mode)
    plt.close(anim._fig)
    return HTML(html)
