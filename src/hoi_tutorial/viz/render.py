"""Offscreen 3D renders with pyvista: scenes, bodies with objects, object galleries.

Every render is drawn offscreen and returned as an image (``(H, W, 3)`` uint8), so a page looks
the same in CI, in the built book and in Colab (an interactive pyvista window renders blank in a
static book). pyvista is imported only when a render is requested.

World conventions: metres, Z up, ground at z = 0, characters and objects face +Y.
"""
from __future__ import annotations

from contextlib import contextmanager
from typing import Optional, Sequence

import matplotlib.pyplot as plt
import numpy as np
import torch

from .._validate import check_shape
from ..world.kinematics import forward_kinematics
from ..world.motion import Motion
from ..world.skeleton import NUM_JOINTS, bone_offsets

__all__ = [
    "SKIN_COLOR",
    "OBJECT_COLORS",
    "CAMERAS",
    "RenderingUnavailable",
    "unavailable_image",
    "render_scene",
    "render_body",
    "render_objects_grid",
    "show_image",
]

SKIN_COLOR = "#e3b191"
# Neutral colours for objects, cycled in order.
OBJECT_COLORS = ("#b5a58c", "#8fa3b8", "#a9b59a", "#c2a3a3", "#a8a8a8")
CAMERAS = ("iso", "front", "top", "side")
# Direction from the focal point towards the camera for each named view, and the view-up vector.
_CAMERA_DIRECTIONS = {
    "iso": ((0.55, 1.0, 0.62), (0.0, 0.0, 1.0)),  # front-right, above: faces of +Y-facing things
    "front": ((0.0, 1.0, 0.12), (0.0, 0.0, 1.0)),
    "side": ((1.0, 0.0, 0.12), (0.0, 0.0, 1.0)),
    "top": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
}
_VIEW_ANGLE = 30.0  # VTK's default vertical field of view, degrees


def _import_pyvista():
    try:
        import pyvista
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("hoi_tutorial.viz.render needs pyvista, the render extra: "
                          "pip install 'hoi_tutorial[render]' (or pip install pyvista)") from exc
    pyvista.OFF_SCREEN = True
    return pyvista


@contextmanager
def _vtk_errors_only():
    """Silence VTK's warnings while a window is made: on a headless Linux machine VTK first tries
    X, warns "bad X server connection", then falls back to EGL or OSMesa and renders fine."""
    try:
        from vtkmodules.vtkCommonCore import vtkLogger
    except ImportError:  # pragma: no cover - older VTK
        yield
        return
    previous = vtkLogger.GetCurrentVerbosityCutoff()
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    try:
        yield
    finally:
        vtkLogger.SetStderrVerbosity(previous)


class RenderingUnavailable(RuntimeError):
    """VTK cannot render offscreen here (no OpenGL context: EGL or OSMesa missing)."""


def unavailable_image(window_size, message: str) -> np.ndarray:
    """A ``(height, width, 3)`` uint8 picture that says, in words, why a render is missing."""
    import textwrap

    import matplotlib

    width, height = int(window_size[0]), int(window_size[1])
    fig = matplotlib.figure.Figure(figsize=(width / 100, height / 100), dpi=100)
    canvas = matplotlib.backends.backend_agg.FigureCanvasAgg(fig)
    fig.patch.set_facecolor("#f4f4f0")
    text = "3D rendering is not available here.\n\n" + "\n".join(textwrap.wrap(message, max(20, width // 8)))
    fig.text(0.5, 0.5, text, ha="center", va="center", fontsize=max(6, min(11, width // 60)), wrap=True)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def _new_plotter(pyvista, window_size, background):
    try:
        plotter = pyvista.Plotter(off_screen=True, window_size=list(window_size))
        supported = plotter.ren_win.SupportsOpenGL()
    except Exception as exc:  # VTK raises several kinds when no context can be made
        raise RenderingUnavailable(
            "offscreen rendering failed: VTK could not create an OpenGL context. It needs EGL "
            "(libEGL, e.g. apt-get install libegl1) or OSMesa (libosmesa6) on a machine without a "
            f"display. Original error: {exc}"
        ) from exc
    if not supported:
        plotter.close()
        raise RenderingUnavailable(
            "offscreen rendering failed: VTK found no usable OpenGL (needs EGL via libegl1, or OSMesa "
            "via libosmesa6, on a machine without a display)"
        )
    plotter.set_background(background)
    return plotter


def _to_numpy(x, name: str) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        return x.detach().cpu().double().numpy()
    return np.asarray(x, dtype=float)


def _to_polydata(pyvista, mesh):
    """A pyvista mesh from a trimesh, a ``ToyObject`` (its ``.mesh``) or a pyvista dataset."""
    mesh = getattr(mesh, "mesh", mesh) if not isinstance(mesh, pyvista.DataSet) else mesh
    if isinstance(mesh, pyvista.DataSet):
        return mesh
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices = np.asarray(mesh.vertices, dtype=float)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        cells = np.hstack([np.full((len(faces), 1), 3, dtype=np.int64), faces]).ravel()
        return pyvista.PolyData(vertices, cells)
    raise TypeError(f"meshes: expected trimesh.Trimesh, ToyObject or pyvista mesh, got {type(mesh).__name__}")


def _camera_pose(camera, lo: np.ndarray, hi: np.ndarray, window_size):
    """``(position, focal_point, up)`` framing the box ``[lo, hi]`` for a named view."""
    if not isinstance(camera, str):
        if len(camera) != 3:
            raise ValueError("camera: expected 'iso', 'front', 'side', 'top' or (position, focal_point, up)")
        return tuple(tuple(float(v) for v in np.asarray(c, dtype=float).reshape(3)) for c in camera)
    if camera not in _CAMERA_DIRECTIONS:
        raise ValueError(f"camera: expected one of {list(CAMERAS)} or (position, focal_point, up), got {camera!r}")
    direction, up = _CAMERA_DIRECTIONS[camera]
    direction = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    centre = (lo + hi) / 2
    # Camera basis: looking along -direction, image right and image up.
    right = np.cross(-direction, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, -direction)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - centre
    tan_v = np.tan(np.radians(_VIEW_ANGLE) / 2)  # VTK's view angle is the vertical field of view
    tan_h = tan_v * window_size[0] / window_size[1]
    # Smallest distance at which every corner of the box is inside the frustum, plus a margin.
    toward = corners @ direction
    needed = np.maximum(np.abs(corners @ right) / tan_h, np.abs(corners @ true_up) / tan_v) + toward
    distance = max(float(needed.max()) * 1.08, 0.1)
    return tuple(centre + distance * direction), tuple(centre), up


def _ground(pyvista, lo, hi):
    """A floor plane at z = 0 around the box ``[lo, hi]``, with grid cells of 0.5 m (0.1 m under
    small props). It stays close to the scene: grid edges that reach under a close camera render
    as smeared wedges."""
    size = float(np.max(hi[:2] - lo[:2]))
    spacing = 0.5 if size >= 0.8 else 0.1
    margin = min(0.6, max(spacing, 0.5 * size))
    x0 = np.floor((lo[0] - margin) / spacing) * spacing
    x1 = np.ceil((hi[0] + margin) / spacing) * spacing
    y0 = np.floor((lo[1] - margin) / spacing) * spacing
    y1 = np.ceil((hi[1] + margin) / spacing) * spacing
    nx, ny = int(round((x1 - x0) / spacing)), int(round((y1 - y0) / spacing))
    return pyvista.Plane(center=((x0 + x1) / 2, (y0 + y1) / 2, 0.0), direction=(0, 0, 1), i_size=x1 - x0,
                         j_size=y1 - y0, i_resolution=nx, j_resolution=ny)


def _parse_points(points):
    """List of ``(points (N, 3), color, size)`` from an ``(N, 3)`` array or a list of tuples."""
    if points is None:
        return []
    if isinstance(points, (np.ndarray, torch.Tensor)):
        points = [(points,)]
    out = []
    for k, item in enumerate(points):
        item = tuple(item) if isinstance(item, tuple) else (item,)
        pts = _to_numpy(item[0], f"points[{k}]")
        check_shape(pts, (None, 3), f"points[{k}]")
        color = item[1] if len(item) > 1 else "black"
        size = float(item[2]) if len(item) > 2 else 10.0
        out.append((pts, color, size))
    return out


def _parse_arrows(arrows):
    out = []
    for k, item in enumerate(arrows or ()):
        if len(item) not in (3, 4):
            raise ValueError(f"arrows[{k}]: expected (origin (3,), direction (3,), color[, scale])")
        origin = _to_numpy(item[0], "arrow origin").reshape(-1)
        direction = _to_numpy(item[1], "arrow direction").reshape(-1)
        check_shape(origin, (3,), f"arrows[{k}] origin")
        check_shape(direction, (3,), f"arrows[{k}] direction")
        scale = float(item[3]) if len(item) == 4 else 1.0
        out.append((origin, direction, item[2], scale))
    return out


def render_scene(meshes, *, arrows=None, points=None, camera="iso", window_size=(800, 600), background="white",
                 ground: bool = True, return_image: bool = True, smooth_shading: bool = True,
                 on_unavailable: str = "note"):
    """Render meshes offscreen and return the picture.

    Args:
        meshes: a list of ``(mesh, color)`` pairs (or bare meshes, drawn in neutral colours); a
            mesh is a ``trimesh.Trimesh``, a ``ToyObject`` or a pyvista mesh, in metres.
        arrows: list of ``(origin (3,), direction (3,), color, scale)``; the arrow is
            ``scale * |direction|`` metres long (``scale`` may be left out: 1).
        points: ``(N, 3)`` metres drawn as black spheres, or a list of ``(points (N, 3), color,
            size_in_pixels)``.
        camera: ``"iso"`` (front-right, above), ``"front"`` (from +Y), ``"side"`` (from +X),
            ``"top"``, or ``(position (3,), focal_point (3,), view_up (3,))``.
        window_size: ``(width, height)`` pixels.
        background: background colour.
        ground: draw a light ground plane at z = 0 with grid lines every 0.5 m (0.1 m around
            scenes smaller than 0.8 m).
        return_image: return the image; when False return the open ``pyvista.Plotter`` (the caller
            shows or closes it).
        smooth_shading: smooth normals (sharp box edges kept).
        on_unavailable: when VTK cannot render offscreen (no OpenGL: EGL or OSMesa missing), ``"note"`` warns
            and returns :func:`unavailable_image` saying why, so that a chapter goes on; ``"raise"`` raises.
    Returns:
        ``(height, width, 3)`` uint8 RGB image (or the plotter).
    Raises:
        RenderingUnavailable: when VTK cannot render offscreen and ``on_unavailable="raise"`` (or
            ``return_image=False``).
    """
    if on_unavailable not in ("note", "raise"):
        raise ValueError(f"on_unavailable: expected 'note' or 'raise', got {on_unavailable!r}")
    pyvista = _import_pyvista()
    if len(window_size) != 2 or min(window_size) < 1:
        raise ValueError(f"window_size: expected (width, height) in pixels, got {window_size}")
    window_size = (int(window_size[0]), int(window_size[1]))
    items = []
    for k, item in enumerate(meshes):
        mesh, color = item if isinstance(item, tuple) else (item, OBJECT_COLORS[k % len(OBJECT_COLORS)])
        items.append((_to_polydata(pyvista, mesh), color))
    arrow_items = _parse_arrows(arrows)
    point_items = _parse_points(points)
    # Scene bounds (meshes, arrow tips, points) frame the camera and size the ground.
    corners = [np.array(m.bounds).reshape(3, 2).T for m, _ in items if m.n_points]
    for origin, direction, _, scale in arrow_items:
        corners.append(np.stack([origin, origin + scale * direction]))
    for pts, _, _ in point_items:
        corners.append(pts)
    if corners:
        allpts = np.vstack(corners)
        lo, hi = allpts.min(0), allpts.max(0)
    else:
        lo, hi = np.array([-1.0, -1.0, 0.0]), np.array([1.0, 1.0, 1.0])
    camera_pose = _camera_pose(camera, lo, hi, window_size)
    try:
        with _vtk_errors_only():
            return _draw(pyvista, items, arrow_items, point_items, lo, hi, camera_pose, window_size, background,
                         ground, return_image, smooth_shading)
    except RenderingUnavailable as exc:
        if on_unavailable == "raise" or not return_image:
            raise
        import warnings

        warnings.warn(str(exc), RuntimeWarning, stacklevel=2)
        return unavailable_image(window_size, str(exc))


def _draw(pyvista, items, arrow_items, point_items, lo, hi, camera_pose, window_size, background, ground,
          return_image, smooth_shading):
    """Build the plotter of :func:`render_scene` and return its screenshot (or the open plotter)."""
    plotter = _new_plotter(pyvista, window_size, background)
    try:
        for mesh, color in items:
            plotter.add_mesh(mesh, color=color, smooth_shading=smooth_shading, split_sharp_edges=smooth_shading,
                             ambient=0.2, diffuse=0.85, specular=0.1)
        for origin, direction, color, scale in arrow_items:
            length = scale * float(np.linalg.norm(direction))
            if length <= 0:
                continue
            arrow = pyvista.Arrow(start=origin, direction=direction, scale=length, tip_length=0.25,
                                  tip_radius=0.08, shaft_radius=0.03)
            plotter.add_mesh(arrow, color=color, smooth_shading=True)
        for pts, color, size in point_items:
            plotter.add_points(pts, color=color, point_size=size, render_points_as_spheres=True)
        if ground:
            plane = _ground(pyvista, lo, hi)
            # Unlit: the floor keeps one colour at any camera distance and angle.
            plotter.add_mesh(plane, color="#f4f4f0", show_edges=True, edge_color="#cdcdcd", line_width=1,
                             lighting=False)
        plotter.camera_position = camera_pose
        plotter.camera.view_angle = _VIEW_ANGLE
        plotter.reset_camera_clipping_range()
        plotter.enable_anti_aliasing("ssaa")
        if not return_image:
            return plotter
        image = plotter.screenshot(return_img=True)
    finally:
        if return_image:
            plotter.close()
    return np.ascontiguousarray(image[..., :3]).astype(np.uint8)


def _pose_of(motion_or_pose, frame: int, betas):
    """``(global_rotations (22, 3, 3), joints (22, 3), betas (10,))`` of one frame."""
    if isinstance(motion_or_pose, Motion):
        T = len(motion_or_pose)
        if not -T <= frame < T:
            raise ValueError(f"frame: expected an index in [-{T}, {T}), got {frame}")
        return (motion_or_pose.global_rotations[frame], motion_or_pose.joints[frame],
                motion_or_pose.betas if betas is None else torch.as_tensor(betas, dtype=torch.float32))
    if not (isinstance(motion_or_pose, tuple) and len(motion_or_pose) == 2):
        raise TypeError("motion_or_pose: expected a Motion or a (local_rotations (22, 3, 3), root_position (3,)) "
                        f"pair, got {type(motion_or_pose).__name__}")
    local, root = (torch.as_tensor(np.asarray(x) if not isinstance(x, torch.Tensor) else x, dtype=torch.float32)
                   for x in motion_or_pose)
    check_shape(local, (NUM_JOINTS, 3, 3), "local_rotations")
    check_shape(root, (3,), "root_position")
    betas = torch.zeros(10) if betas is None else torch.as_tensor(betas, dtype=torch.float32)
    glob, joints = forward_kinematics(local, root, bone_offsets(betas))
    return glob, joints, betas


def render_body(motion_or_pose, frame: int = -1, objects: Sequence = (), arrows=None, camera="iso",
                betas=None, points=None, window_size=(800, 600), object_colors: Optional[Sequence] = None,
                body_color=SKIN_COLOR, ground: bool = True):
    """Render the capsule body (``world.body.body_mesh``) of one frame with objects around it.

    Args:
        motion_or_pose: a ``Motion`` or a ``(local_rotations (22, 3, 3), root_position (3,) metres)``
            pair such as ``world.mocap.poses.standing_pose()`` returns.
        frame: frame index of a ``Motion`` (default the last one).
        objects: ``ToyObject``s or trimeshes (world frame) drawn in neutral colours.
        arrows: as in :func:`render_scene`.
        camera: as in :func:`render_scene`.
        betas: ``(10,)`` body shape of a pose pair (a Motion's own ``betas`` by default).
        points: as in :func:`render_scene`.
        window_size: ``(width, height)`` pixels.
        object_colors: colours of the objects (default ``OBJECT_COLORS`` cycled).
        body_color: skin colour.
        ground: draw the ground plane.
    Returns:
        ``(height, width, 3)`` uint8 RGB image.
    """
    from ..world.body import body_mesh

    glob, joints, betas = _pose_of(motion_or_pose, frame, betas)
    mesh = body_mesh(glob, joints, betas)
    colors = list(object_colors) if object_colors is not None else list(OBJECT_COLORS)
    items = [(mesh, body_color)] + [(obj, colors[k % len(colors)]) for k, obj in enumerate(objects)]
    return render_scene(items, arrows=arrows, points=points, camera=camera, window_size=window_size, ground=ground)


def show_image(img, ax=None, title: Optional[str] = None):
    """Show an image without axes.

    Args:
        img: ``(H, W, 3)`` or ``(H, W, 4)`` image (uint8 or floats in [0, 1]).
        ax: matplotlib axes; a new figure sized to the image when ``None``.
        title: axes title.
    Returns:
        The axes.
    """
    img = np.asarray(img)
    if img.ndim != 3 or img.shape[-1] not in (3, 4):
        raise ValueError(f"img: expected shape (H, W, 3) or (H, W, 4), got {img.shape}")
    if ax is None:
        h, w = img.shape[:2]
        _, ax = plt.subplots(figsize=(6.0, 6.0 * h / w))
    ax.imshow(img)
    ax.set_axis_off()
    if title:
        ax.set_title(title, fontsize=10)
    return ax


def render_objects_grid(objects: Sequence, ncols: int = 5, tile_size=(260, 220), camera="iso",
                        titles: Optional[Sequence[str]] = None, colors: Optional[Sequence] = None):
    """A gallery of objects, one small offscreen render each, tiled with their category as title.

    Args:
        objects: ``ToyObject``s (titled by ``category``) or trimeshes.
        ncols: tiles per row.
        tile_size: ``(width, height)`` pixels of each render.
        camera: as in :func:`render_scene`.
        titles: one title per object (default: each object's category).
        colors: one colour per object (default ``OBJECT_COLORS`` cycled).
    Returns:
        The matplotlib figure.
    """
    objects = list(objects)
    if not objects:
        raise ValueError("objects: expected at least one object")
    if ncols < 1:
        raise ValueError(f"ncols: expected a positive number of columns, got {ncols}")
    if titles is not None and len(titles) != len(objects):
        raise ValueError(f"titles: expected {len(objects)} titles, got {len(titles)}")
    colors = list(colors) if colors is not None else list(OBJECT_COLORS)
    ncols = min(ncols, len(objects))
    nrows = -(-len(objects) // ncols)
    w, h = tile_size
    fig, axes = plt.subplots(nrows, ncols, figsize=(ncols * w / 100, nrows * (h / 100 + 0.3)), squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        if k >= len(objects):
            ax.set_axis_off()
            continue
        obj = objects[k]
        image = render_scene([(obj, colors[k % len(colors)])], camera=camera, window_size=tile_size)
        title = titles[k] if titles is not None else getattr(obj, "category", f"object {k}")
        show_image(image, ax=ax, title=str(title))
    fig.tight_layout()
    return fig

