"""Figures for the book: matplotlib plots, offscreen pyvista renders and motion animations.

- ``plots``: skeletons, motion strips, top-down trajectories (NIFTY Fig. 4 style), contact and
  foot-height timelines, rooms, kitchens and SAMP's occupancy voxels.
- ``render``: offscreen 3D images of meshes, bodies with objects, object galleries.
- ``animation``: stick-figure animations embedded as HTML (no ffmpeg needed).

Colours are shared: left limbs blue, right limbs red, spine grey, objects neutral.
"""
from .animation import animate_motion, show_animation, to_html
from .plots import (
    ACTION_COLORS,
    LEFT_COLOR,
    RIGHT_COLOR,
    SPINE_COLOR,
    plot_contacts,
    plot_foot_heights,
    plot_kitchen_top_down,
    plot_motion_strip,
    plot_object_footprint,
    plot_room,
    plot_skeleton,
    plot_trajectories_top_down,
    plot_voxels,
)
from .render import render_body, render_objects_grid, render_scene, show_image

__all__ = [
    "ACTION_COLORS",
    "LEFT_COLOR",
    "RIGHT_COLOR",
    "SPINE_COLOR",
    "animate_motion",
    "show_animation",
    "to_html",
    "plot_contacts",
    "plot_foot_heights",
    "plot_kitchen_top_down",
    "plot_motion_strip",
    "plot_object_footprint",
    "plot_room",
    "plot_skeleton",
    "plot_trajectories_top_down",
    "plot_voxels",
    "render_body",
    "render_objects_grid",
    "render_scene",
    "show_image",
]
