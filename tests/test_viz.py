"""Tests of hoi_tutorial.viz: every plot, render and animation runs headless and returns what it says."""
import importlib

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402
from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from matplotlib.animation import FuncAnimation  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from hoi_tutorial import viz  # noqa: E402
from hoi_tutorial.viz import animation as viz_animation  # noqa: E402
from hoi_tutorial.viz import plots as viz_plots  # noqa: E402
from hoi_tutorial.world.kinematics import forward_kinematics  # noqa: E402
from hoi_tutorial.world.mocap.poses import standing_pose  # noqa: E402
from hoi_tutorial.world.motion import ACTIONS, Motion, action_id  # noqa: E402
from hoi_tutorial.world.skeleton import bone_offsets, joint_index  # noqa: E402


def _optional(module: str):
    """Import a world module that other chapters provide, or skip the test that needs it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        pytest.skip(f"{module} is not importable yet ({exc}); this test draws its meshes")


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def standing_joints():
    local, root = standing_pose()
    _, joints = forward_kinematics(local, root, bone_offsets(None))
    return joints


@pytest.fixture(scope="module")
def small_motion():
    """12 frames of the standing pose sliding forward 0.6 m, with contact and action labels."""
    local, root = standing_pose()
    T = 12
    roots = root.repeat(T, 1).clone()
    roots[:, 1] = torch.linspace(0.0, 0.6, T)
    contacts = np.zeros((T, 5), dtype=bool)
    contacts[:6, 1] = True
    contacts[4:, 2] = True
    actions = np.array([action_id("idle")] * 4 + [action_id("walk")] * 8)
    return Motion(local.repeat(T, 1, 1, 1), roots, actions=actions, contacts=contacts)


@pytest.fixture(scope="module")
def chair():
    objects = _optional("hoi_tutorial.world.objects")
    return objects.make_object("chair", seed=0)


# ----------------------------------------------------------------------------- skeleton plots


@pytest.mark.parametrize("view", ["front", "side", "top"])
def test_plot_skeleton_2d_draws_21_bones(standing_joints, view):
    ax = viz.plot_skeleton(standing_joints, view=view, joint_labels=True)
    assert isinstance(ax, plt.Axes)
    bones = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(bones) == 1 and len(bones[0].get_segments()) == 21
    assert ax.get_xlabel().endswith("(m)") and ax.get_ylabel().endswith("(m)")
    assert ax.get_aspect() == 1.0


def test_plot_skeleton_front_view_is_seen_from_the_front(standing_joints):
    ax = viz.plot_skeleton(standing_joints, view="front")
    # Seen from +Y the character's right (+X) is on the viewer's left.
    assert ax.xaxis_inverted()
    ax_side = viz.plot_skeleton(standing_joints, view="side")
    assert not ax_side.xaxis_inverted()


def test_plot_skeleton_3d(standing_joints):
    ax = viz.plot_skeleton(standing_joints, view="3d")
    assert ax.name == "3d"
    assert ax.get_zlim()[0] == 0.0 and ax.get_zlim()[1] > float(standing_joints[:, 2].max())
    # Equal metric scale: the box aspect is proportional to the axis spans.
    spans = np.array([np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())])
    box = np.asarray(ax.get_box_aspect())
    np.testing.assert_allclose(box / box.max(), spans / spans.max(), rtol=1e-6)


def test_plot_skeleton_rejects_wrong_shapes(standing_joints):
    with pytest.raises(ValueError, match=r"\(22, 3\)"):
        viz.plot_skeleton(standing_joints[:21])
    with pytest.raises(ValueError, match="view"):
        viz.plot_skeleton(standing_joints, view="back")
    _, ax = plt.subplots()
    with pytest.raises(ValueError, match="3D axes"):
        viz.plot_skeleton(standing_joints, view="3d", ax=ax)


def test_bone_colours_follow_body_sides():
    colors = viz_plots.bone_colors()
    assert colors[joint_index("left_knee") - 1] == viz.LEFT_COLOR
    assert colors[joint_index("right_elbow") - 1] == viz.RIGHT_COLOR
    assert colors[joint_index("spine2") - 1] == viz.SPINE_COLOR
    assert set(viz_plots.bone_colors(color_by_side=False)) == {viz.SPINE_COLOR}


def test_plot_motion_strip_draws_n_poses(small_motion):
    ax = viz.plot_motion_strip(small_motion, n=4, view="side")
    skeletons = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(skeletons) == 4
    labels = [t.get_text() for t in ax.texts]
    assert labels[0] == "0.00 s" and labels[-1] == f"{11 / 30:.2f} s"
    with pytest.raises(ValueError, match=r"\(\*, 22, 3\)"):
        viz.plot_motion_strip(np.zeros((5, 21, 3)))


# ----------------------------------------------------------------------------- top-down plots


def test_plot_trajectories_top_down(chair):
    rng = np.random.default_rng(0)
    paths = [np.cumsum(rng.normal(size=(20, 2)) * 0.1, axis=0) + 1.0 for _ in range(5)]
    paths.append(np.c_[np.linspace(2, 0, 10), np.zeros(10), np.full(10, 0.9)])  # (T, 3) is accepted
    ax = viz.plot_trajectories_top_down(paths, highlight=[0, -1], objects=[chair])
    assert ax.get_aspect() == 1.0
    highlighted = [ln for ln in ax.lines if ln.get_color() == viz_plots.HIGHLIGHT_COLOR]
    assert len(highlighted) == 2
    plain = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(plain) == 1 and len(plain[0].get_segments()) == 4
    # The chair's footprint covers exactly its horizontal bounds.
    footprint = [c for c in ax.collections if isinstance(c, PolyCollection) and not isinstance(c, LineCollection)]
    verts = np.concatenate([p.vertices for p in footprint[0].get_paths()])
    np.testing.assert_allclose(verts.min(0), chair.bounds[0, :2], atol=1e-6)
    np.testing.assert_allclose(verts.max(0), chair.bounds[1, :2], atol=1e-6)
    assert {"start", "end", "highlighted", "object"} <= set(ax.get_legend_handles_labels()[1])


def test_plot_trajectories_accepts_arrays_and_motions(small_motion):
    ax = viz.plot_trajectories_top_down(torch.zeros(3, 8, 2) + torch.arange(8.0)[None, :, None])
    assert len(ax.collections[0].get_segments()) == 3
    ax = viz.plot_trajectories_top_down([small_motion])
    xy = ax.collections[0].get_segments()[0]
    np.testing.assert_allclose(xy, small_motion.joint("pelvis")[:, :2].numpy(), atol=1e-6)


def test_plot_trajectories_rejects_bad_input():
    with pytest.raises(ValueError, match=r"\(T, 2\) or \(T, 3\)"):
        viz.plot_trajectories_top_down([np.zeros((10, 4))])
    with pytest.raises(ValueError, match="highlight"):
        viz.plot_trajectories_top_down([np.zeros((10, 2))], highlight=3)


def test_plot_room_matches_the_occupancy_grid():
    scenes = _optional("hoi_tutorial.world.scenes")
    room = scenes.make_room(seed=0)
    path = np.linspace(room.start_positions(1, seed=0)[0], room.approach_point(), 10)
    ax = viz.plot_room(room, path=path)
    image = ax.images[0]
    np.testing.assert_array_equal(np.asarray(image.get_array()), room.occupancy)
    np.testing.assert_allclose(image.get_extent(), room.extent)
    assert ax.get_aspect() == 1.0
    np.testing.assert_allclose(ax.lines[0].get_xydata(), path)
    with pytest.raises(ValueError, match=r"\(N, 2\) or \(N, 3\)"):
        viz.plot_room(room, path=np.zeros((3, 4)))


def test_plot_room_grid_path_and_kitchen():
    scenes = _optional("hoi_tutorial.world.scenes")
    room = scenes.make_room(seed=1)
    cells = np.array([[2, 3], [2, 4], [3, 4]])
    ax = viz.plot_room(room, path=cells)
    np.testing.assert_allclose(ax.lines[0].get_xydata(), room.grid_to_world(cells))
    kitchen = scenes.make_kitchen(seed=0)
    ax = viz.plot_kitchen_top_down(kitchen)
    footprints = [c for c in ax.collections if isinstance(c, PolyCollection) and not isinstance(c, LineCollection)]
    assert len(footprints) == len(kitchen.objects)
    assert "furniture" in [t.get_text() for t in ax.get_legend().get_texts()]


def test_plot_voxels(chair):
    occ = chair.occupancy_grid(8)
    ax = viz.plot_voxels(occ)
    assert ax.name == "3d"
    assert f"{int((occ > 0.05).sum())} of 512" in ax.get_title()
    with pytest.raises(ValueError, match=r"\(\*, \*, \*\)"):
        viz.plot_voxels(np.zeros((8, 8)))


# ----------------------------------------------------------------------------- time lines


def test_plot_contacts_shows_actions_and_contacts(small_motion):
    ax = viz.plot_contacts(small_motion)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["idle", "walk"]
    assert ax.get_xlim() == (0.0, 12 / 30)
    assert ax.get_xlabel() == "time (s)"
    assert [t.get_text() for t in ax.get_yticklabels()][-1] == "action"
    # Left foot in contact for frames 0..5: one bar of 6 frames.
    bars = ax.collections[1].get_paths()
    assert len(bars) == 1
    np.testing.assert_allclose(np.ptp(bars[0].vertices[:, 0]), 6 / 30)


def test_plot_contacts_needs_contact_labels(small_motion):
    bare = Motion(small_motion.local_rotations, small_motion.root_position)
    with pytest.raises(ValueError, match=r"contacts of shape \(T, 5\)"):
        viz.plot_contacts(bare)


def test_plot_foot_heights(small_motion):
    ax = viz.plot_foot_heights(small_motion)
    feet = [ln for ln in ax.lines if ln.get_label() in ("left foot", "right foot", "left ankle", "right ankle")]
    assert len(feet) == 4
    np.testing.assert_allclose(feet[0].get_ydata(), small_motion.joint("left_foot")[:, 2].numpy(), atol=1e-6)
    assert ax.get_ylabel() == "height above ground (m)"


def test_action_colours_are_distinct():
    colours = [viz.ACTION_COLORS[a] for a in ACTIONS]
    assert len(set(colours)) == len(ACTIONS)
    assert matplotlib.colors.to_rgba(viz.LEFT_COLOR) not in colours


@given(st.lists(st.booleans(), max_size=40))
def test_runs_cover_exactly_the_true_frames(mask):
    mask = np.array(mask, dtype=bool)
    rebuilt = np.zeros_like(mask)
    for a, b in viz_plots._runs(mask):
        assert a < b
        rebuilt[a:b] = True
    np.testing.assert_array_equal(rebuilt, mask)


@given(st.lists(st.integers(0, 3), min_size=1, max_size=40))
def test_label_runs_rebuild_the_labels(labels):
    labels = np.array(labels)
    runs = viz_plots._label_runs(labels)
    rebuilt = np.concatenate([np.full(b - a, v) for a, b, v in runs])
    np.testing.assert_array_equal(rebuilt, labels)
    assert all(r1[2] != r2[2] for r1, r2 in zip(runs, runs[1:]))


# ----------------------------------------------------------------------------- renders


def _red_pixels(image):
    r, g, b = (image[..., c].astype(int) for c in range(3))
    return (r > 120) & (r > 2 * g) & (r > 2 * b)


def _skin_pixels(image):
    """Pixels with the hue of ``SKIN_COLOR`` (r:g:b near 1.28:1:0.64) at any brightness."""
    r, g, b = (image[..., c].astype(float) + 1.0 for c in range(3))
    return (r > 60) & (r / g > 1.18) & (r / g < 1.45) & (r / b > 1.4) & (r / b < 1.9)


def test_render_scene_returns_a_non_blank_image_of_the_requested_size():
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=(0.4, 0.4, 0.4))
    box.apply_translation((0.0, 0.0, 0.2))
    image = viz.render_scene([(box, "#ff0000")], window_size=(160, 120))
    assert image.shape == (120, 160, 3) and image.dtype == np.uint8
    assert image.std() > 10.0
    assert _red_pixels(image).mean() > 0.02  # the box's colour shows
    assert _red_pixels(image)[60, 80]  # and it is framed in the middle


def test_render_scene_arrows_points_and_cameras():
    trimesh = pytest.importorskip("trimesh")
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.2)
    sphere.apply_translation((0.0, 0.0, 0.2))
    arrows = [((0.0, 0.0, 0.5), (0.0, 1.0, 0.0), "#ff0000", 0.6)]
    image = viz.render_scene([(sphere, "#3060c0")], arrows=arrows, points=np.zeros((1, 3)), camera="top",
                             window_size=(120, 100), ground=False)
    assert image.shape == (100, 120, 3)
    assert _red_pixels(image).any()
    corner = image[:5, :5].reshape(-1, 3)
    assert (corner == 255).all()  # white background without the ground
    custom = ((3.0, 0.0, 1.0), (0.0, 0.0, 0.2), (0.0, 0.0, 1.0))
    assert viz.render_scene([sphere], camera=custom, window_size=(64, 48)).shape == (48, 64, 3)
    with pytest.raises(ValueError, match="camera"):
        viz.render_scene([sphere], camera="below")
    pyvista = pytest.importorskip("pyvista")
    plotter = viz.render_scene([sphere], window_size=(40, 30), return_image=False)
    try:
        assert isinstance(plotter, pyvista.Plotter)
        assert plotter.screenshot(return_img=True).shape[:2] == (30, 40)
    finally:
        plotter.close()


def test_render_scene_reports_missing_opengl(monkeypatch):
    pyvista = pytest.importorskip("pyvista")

    def no_context(*args, **kwargs):
        raise OSError("could not create an OpenGL context")

    monkeypatch.setattr(pyvista, "Plotter", no_context)
    with pytest.raises(RuntimeError, match="EGL.*OSMesa"):
        viz.render_scene([pyvista.Sphere()], window_size=(32, 32), on_unavailable="raise")
    # by default a chapter goes on: a warning, and a picture that says why instead of the render
    with pytest.warns(RuntimeWarning, match="EGL.*OSMesa"):
        image = viz.render_scene([pyvista.Sphere()], window_size=(120, 80))
    assert image.shape == (80, 120, 3) and image.dtype == np.uint8
    assert (image < 100).any() and (image > 200).mean() > 0.5  # dark text on a light page
    with pytest.raises(ValueError, match="on_unavailable"):
        viz.render_scene([pyvista.Sphere()], on_unavailable="ignore")


def test_render_body_with_a_chair_and_an_arrow(small_motion, chair):
    _optional("hoi_tutorial.world.body")
    positions, directions = chair.sit_goals
    pose = standing_pose(position=(0.3, 0.9), heading=np.pi)
    image = viz.render_body(pose, objects=[chair], arrows=[(positions[0], directions[0], "red", 0.5)],
                            window_size=(160, 120))
    assert image.shape == (120, 160, 3) and image.std() > 10.0
    assert _skin_pixels(image).mean() > 0.02  # the body shows
    assert not _skin_pixels(viz.render_scene([chair], window_size=(160, 120))).any()  # the test tells them apart
    image = viz.render_body(small_motion, frame=0, camera="front", window_size=(80, 60))
    assert image.shape == (60, 80, 3)
    with pytest.raises(ValueError, match="frame"):
        viz.render_body(small_motion, frame=50)
    with pytest.raises(ValueError, match=r"\(22, 3, 3\)"):
        viz.render_body((torch.eye(3).repeat(21, 1, 1), torch.zeros(3)))


def test_render_objects_grid_and_show_image(chair):
    objects = _optional("hoi_tutorial.world.objects")
    fig = viz.render_objects_grid([chair, objects.make_object("mug", seed=0)], ncols=5, tile_size=(80, 60))
    axes = [ax for ax in fig.axes if ax.images]
    assert [ax.get_title() for ax in axes] == ["chair", "mug"]
    assert axes[0].images[0].get_array().shape == (60, 80, 3)
    ax = viz.show_image(np.zeros((10, 20, 3), dtype=np.uint8), title="blank")
    assert not ax.axison and ax.get_title() == "blank"
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        viz.show_image(np.zeros((10, 20)))


# ----------------------------------------------------------------------------- animations


def test_animation_html_has_one_frame_per_stride(small_motion):
    anim = viz.animate_motion(small_motion, view="3d", stride=2, figsize=(3, 3), dpi=40)
    assert isinstance(anim, FuncAnimation)
    html = viz.to_html(anim)
    assert "<script" in html
    assert html.count("data:image/png;base64") == 6  # 12 frames, every 2nd


@pytest.mark.parametrize("view", ["side", "top"])
def test_animation_2d_views_with_objects_and_frame_cap(small_motion, chair, view):
    anim = viz.animate_motion([small_motion, small_motion.slice(0, 5)], view=view, objects=[chair], stride=1,
                              max_frames=4, figsize=(3, 3), dpi=40)
    html = viz.to_html(anim, default_mode="once")
    assert html.count("data:image/png;base64") == 4  # 12 frames capped at 4 (every 3rd)
    ax = anim._fig.axes[0]
    assert any(isinstance(c, PolyCollection) and not isinstance(c, LineCollection) for c in ax.collections)
    assert ax.get_aspect() == 1.0


@pytest.mark.parametrize("view", ["3d", "side"])
def test_animations_given_each_others_joints_share_their_axes(small_motion, view):
    moved = small_motion.joints.numpy() + np.array([1.5, 1.5, 0.0])  # the same body 2 m away on the ground
    alone = viz.animate_motion(small_motion, view=view, stride=1, figsize=(3, 3), dpi=40)
    first = viz.animate_motion(small_motion, view=view, stride=1, figsize=(3, 3), dpi=40, frame_points=moved)
    second = viz.animate_motion(moved, view=view, stride=1, figsize=(3, 3), dpi=40,
                                frame_points=small_motion.joints.numpy())

    def limits(anim):
        ax = anim._fig.axes[0]
        return np.array([ax.get_xlim(), ax.get_ylim()] + ([ax.get_zlim()] if view == "3d" else []))

    np.testing.assert_allclose(limits(first), limits(second))
    assert limits(first)[0, 1] > limits(alone)[0, 1] + 1.0  # the other body widened the view
    with pytest.raises(ValueError, match=r"frame_points: expected finite world points"):
        viz.animate_motion(small_motion, frame_points=np.zeros((4, 2)))
    for anim in (alone, first, second):
        plt.close(anim._fig)


def test_animation_caption_tracks_time_and_action(small_motion):
    anim = viz.animate_motion(small_motion, view="side", stride=1, figsize=(3, 3), dpi=40)
    anim._func(5)
    assert anim._fig.axes[0].get_title() == f"t = {5 / 30:.2f} s   walk"
    anim._func(0)
    assert anim._fig.axes[0].get_title() == "t = 0.00 s   idle"
    assert "<script" in viz.to_html(anim)


def test_show_animation_closes_its_figure(small_motion):
    anim = viz.animate_motion(small_motion.slice(0, 4), view="top", stride=1, figsize=(2, 2), dpi=30)
    number = anim._fig.number
    html = viz.show_animation(anim)
    assert "<script" in html.data
    assert not plt.fignum_exists(number)


def test_animation_moves_its_moving_objects(small_motion, chair):
    calls = []

    def moved(frame):  # the chair slides along x, one centimetre a frame
        calls.append(frame)
        shift = np.eye(4)
        shift[0, 3] = 0.01 * frame
        return chair.with_pose(shift @ chair.pose)

    anim = viz.animate_motion(small_motion, moving_objects=[moved], stride=1, figsize=(3, 3), dpi=40)
    collection = [c for c in anim._fig.axes[0].collections if isinstance(c, Poly3DCollection)][-1]
    anim._func(0)
    first = np.array(collection._faces).copy()  # (faces, 3, 3) the 3D vertices
    anim._func(10)
    shift = np.array(collection._faces) - first
    assert 10 in calls
    np.testing.assert_allclose(shift[..., 0], 0.10, atol=1e-6)  # every vertex moved 10 cm along x
    np.testing.assert_allclose(shift[..., 1:], 0.0, atol=1e-9)
    with pytest.raises(ValueError, match="moving_objects: expected view='3d'"):
        viz.animate_motion(small_motion, view="top", moving_objects=[moved])
    with pytest.raises(ValueError, match="moving_objects: expected callables"):
        viz.animate_motion(small_motion, moving_objects=[chair])


def _embedded_frames(html):
    """The frames an animation page embeds, as (H, W, 4) pixel arrays."""
    import base64
    import io
    import re

    from PIL import Image

    found = re.findall(r'data:image/png;base64,([^"]+)"', html.replace("\\n", ""))
    return [np.asarray(Image.open(io.BytesIO(base64.b64decode(data)))) for data in found]


def test_to_html_embeds_the_frames_to_jshtml_draws(small_motion, chair):
    """Each frame drawn once (to_html) gives the pixels of matplotlib's own to_jshtml, which draws it twice;
    a moving object that stops, moves and stops again is redrawn only when it changes, and still shows where it is."""

    def moved(frame):  # still for 4 frames, then 2 cm a frame, still again from frame 8
        shift = np.eye(4)
        shift[0, 3] = 0.02 * min(max(frame - 3, 0), 5)
        return chair.with_pose(shift @ chair.pose)

    def animation():
        return viz.animate_motion(small_motion, objects=[chair], moving_objects=[moved], stride=1, figsize=(3, 3),
                                  dpi=40, title="moving chair")

    ours = _embedded_frames(viz.to_html(animation()))
    with matplotlib.rc_context({"animation.embed_limit": 50.0}):
        theirs = _embedded_frames(animation().to_jshtml(default_mode="loop"))
    assert len(ours) == len(theirs) == 12
    for a, b in zip(ours, theirs):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("view", ["3d", "side", "top", "front"])
def test_still_parts_drawn_once_give_the_pixels_of_whole_frames(small_motion, chair, monkeypatch, view):
    """to_html draws an animation's axes, ground and still objects once and each frame's moving artists over them
    (with every still artist a full draw puts above them): the frames are those of drawing every frame whole."""
    def frames():
        moving = [lambda f: chair.with_pose(np.diag([1.0, 1.0, 1.0, 1.0]) @ chair.pose)] if view == "3d" else []
        anim = viz.animate_motion(small_motion, objects=[chair], moving_objects=moving, view=view, stride=1,
                                  figsize=(3, 3), dpi=40, title="still parts")
        return _embedded_frames(viz.to_html(anim))

    once = frames()
    monkeypatch.setattr(viz_animation, "_DRAW_STILL_PARTS_ONCE", False)
    whole = frames()
    assert len(once) == len(whole) == 12
    for a, b in zip(once, whole):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(once[0], once[-1])  # the body moved


def test_moving_object_reuse_matches_redrawing_every_frame(small_motion, chair, monkeypatch):
    """The polygons of a moving object kept from the last frame (same shape and pose) are the ones a fresh
    mesh gives: the frames equal those drawn with the reuse turned off."""
    door = _optional("hoi_tutorial.world.objects").make_object("cabinet", seed=0)
    angles = [0.0, 0.0, 0.0, 0.3, 0.6, 0.9, 0.9, 0.9, 0.5, 0.5, 0.0, 0.0]

    def opening(frame):
        return door.with_params(door_angle=angles[frame])

    def frames():
        anim = viz.animate_motion(small_motion, moving_objects=[opening], stride=1, figsize=(3, 3), dpi=40)
        return _embedded_frames(viz.to_html(anim))

    kept = frames()
    monkeypatch.setattr(viz_animation, "_object_key", lambda obj: None)
    redrawn = frames()
    assert len(kept) == len(redrawn) == 12
    for a, b in zip(kept, redrawn):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(kept[2], kept[5])  # the door opened between frames 2 and 5


def test_animation_rejects_bad_input(standing_joints):
    with pytest.raises(ValueError, match=r"\(\*, 22, 3\)"):
        viz.animate_motion(np.zeros((5, 20, 3)))
    with pytest.raises(ValueError, match="view"):
        viz.animate_motion(standing_joints, view="back")
    with pytest.raises(ValueError, match="stride"):
        viz.animate_motion(standing_joints, stride=0)


def test_cluster_decimation_caps_the_face_count():
    trimesh = pytest.importorskip("trimesh")
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.3)
    vertices, faces = viz_animation._cluster_decimate(np.asarray(sphere.vertices), np.asarray(sphere.faces), 600)
    assert 50 < len(faces) <= 600
    assert faces.max() < len(vertices)
    # Merged vertices stay near the sphere.
    np.testing.assert_allclose(np.linalg.norm(vertices, axis=1), 0.3, atol=0.05)

