"""Per-category builders of the procedural objects: each turns sampled parameters into parts
(primitives in the canonical frame) and affordance annotations (sit and lie goals, lift
contacts, grasp points, handles, support surfaces); ``recentre`` centres a build in x/y.
"""
from __future__ import annotations

import numpy as np

from ..primitives import (
    box,
    capsule_between,
    cylinder,
    primitive_bounds,
    rigid_transform,
    rotation_x,
    rotation_z,
    sphere,
)
from .sizes import CATEGORY_SIZES

__all__ = [
    "SEAT_PELVIS_HEIGHT",
    "LIE_PELVIS_HEIGHT",
    "PELVIS_FROM_BACKREST",
    "BUILDERS",
    "POINT_KEYS",
    "DERIVED_PARAMS",
    "recentre",
]

SEAT_PELVIS_HEIGHT = 0.09  # pelvis joint above the seat top when seated, metres
LIE_PELVIS_HEIGHT = 0.10  # pelvis joint above the cushion when lying, metres
PELVIS_FROM_BACKREST = 0.20  # seated pelvis in front of the backrest, metres
_JOIN = 0.005  # parts that touch overlap by this much, so shared faces are interior


# ----------------------------------------------------------------------------- builders (canonical frame)


def _slab(lo, hi, name=""):
    """An axis-aligned box from its min corner ``lo`` (3,) to its max corner ``hi`` (3,)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return box((lo + hi) / 2, (hi - lo) / 2, name=name)


def _heading(yaw):
    """Horizontal unit vector(s) (..., 3): +Y turned by ``yaw`` radians about +Z."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([-np.sin(yaw), np.cos(yaw), np.zeros_like(yaw)], axis=-1)


def _sit_fan(position, n, yaw0):
    """``n`` goals at one seat: positions (n, 3), directions (n, 3) evenly spread from ``yaw0``."""
    yaws = yaw0 + 2.0 * np.pi * np.arange(n) / n
    return np.repeat(np.asarray(position, dtype=np.float64)[None], n, axis=0), _heading(yaws)


def _lift_pair(half_width, height, y=0.0):
    """Hand contacts on the ±x sides; the lifter stands at +Y facing −Y, so the left hand is at +x."""
    return {
        "lift_contacts": np.array([[half_width, y, height], [-half_width, y, height]]),
        "lift_approach": np.array([0.0, -1.0, 0.0]),
    }


def _build_chair(p):
    h, w, d = p["seat_height"], p["seat_width"], p["seat_depth"]
    ts, lw, bt = p["seat_thickness"], p["leg_width"], p["back_thickness"]
    parts = [_slab((-w / 2, -d / 2, h - ts), (w / 2, d / 2, h), "seat")]
    for sx in (-1, 1):
        for sy in (-1, 1):
            cx, cy = sx * (w / 2 - lw / 2 - 0.01), sy * (d / 2 - lw / 2 - 0.01)
            parts.append(_slab((cx - lw / 2, cy - lw / 2, 0.0), (cx + lw / 2, cy + lw / 2, h - ts + _JOIN), "leg"))
    # backrest tilted about its bottom edge so that its top leans towards -Y
    tilt = rotation_x(p["back_tilt"])
    half_back = np.array([w / 2, bt / 2, (p["back_height"] + ts) / 2])
    pivot = np.array([0.0, -d / 2 + bt / 2, h - ts])
    parts.append(box(pivot + tilt @ np.array([0.0, 0.0, half_back[2]]), half_back, tilt, name="back"))
    seat_y = min(-d / 2 + bt + PELVIS_FROM_BACKREST, 0.0)
    ann = {
        "sit_positions": np.array([[0.0, seat_y, h + SEAT_PELVIS_HEIGHT]]),
        "sit_directions": _heading(np.array([p["sit_yaw"]])),
        **_lift_pair(w / 2, h - ts / 2),
    }
    return parts, ann


def _build_armchair(p):
    h, sw, sd = p["seat_height"], p["seat_width"], p["seat_depth"]
    aw, bt, lh = p["arm_width"], p["back_thickness"], p["leg_height"]
    W, D = sw + 2 * aw, sd + bt
    parts = [_slab((-W / 2, -D / 2, lh), (W / 2, D / 2, h), "base")]
    for s in (-1, 1):
        x0, x1 = sorted((s * W / 2, s * (W / 2 - aw)))
        parts.append(_slab((x0, -D / 2, lh), (x1, D / 2, h + p["arm_height"]), "arm"))
    parts.append(_slab((-W / 2, -D / 2, lh), (W / 2, -D / 2 + bt, h + p["back_height"]), "back"))
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(cylinder((sx * (W / 2 - 0.05), sy * (D / 2 - 0.05), (lh + _JOIN) / 2), 0.025, (lh + _JOIN) / 2, name="leg"))
    seat_y = min(-D / 2 + bt + PELVIS_FROM_BACKREST, (-D / 2 + bt + D / 2) / 2)
    ann = {
        "sit_positions": np.array([[0.0, seat_y, h + SEAT_PELVIS_HEIGHT]]),
        "sit_directions": np.array([[0.0, 1.0, 0.0]]),  # an armchair allows one direction (SAMP Fig. 7)
    }
    return parts, ann


def _build_stool(p):
    h, R, ts = p["seat_height"], p["seat_radius"], p["seat_thickness"]
    lr, n = p["leg_radius"], p["n_legs"]
    parts = [cylinder((0.0, 0.0, h - ts / 2), R, ts / 2, name="seat")]
    for k in range(n):
        phi = 2 * np.pi * (k + 0.5) / n
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        top = 0.65 * R * radial + np.array([0.0, 0.0, h - ts])
        foot = (0.65 * R + p["leg_splay"]) * radial + np.array([0.0, 0.0, lr])
        parts.append(capsule_between(foot, top, lr, name="leg"))
    positions, directions = _sit_fan((0.0, 0.0, h + SEAT_PELVIS_HEIGHT), p["n_sit_directions"], p["sit_yaw"])
    ann = {"sit_positions": positions, "sit_directions": directions, **_lift_pair(R, h - ts / 2)}
    return parts, ann


def _build_table(p):
    H, W, D, tt, lw = p["height"], p["width"], p["depth"], p["top_thickness"], p["leg_width"]
    parts = [_slab((-W / 2, -D / 2, H - tt), (W / 2, D / 2, H), "top")]
    for sx in (-1, 1):
        for sy in (-1, 1):
            cx, cy = sx * (W / 2 - lw / 2 - 0.04), sy * (D / 2 - lw / 2 - 0.04)
            parts.append(_slab((cx - lw / 2, cy - lw / 2, 0.0), (cx + lw / 2, cy + lw / 2, H - tt + _JOIN), "leg"))
    x = p["sit_offset"] * W / 2
    edge_y = D / 2 - 0.15  # pelvis 15 cm in from the edge one sits on
    positions = [[x, edge_y, H + SEAT_PELVIS_HEIGHT], [-x, -edge_y, H + SEAT_PELVIS_HEIGHT]]
    directions = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]
    n = p["n_sit_edges"]
    ann = {
        "sit_positions": np.array(positions[:n]),
        "sit_directions": np.array(directions[:n]),
        "supports": np.array([[H, -W / 2, W / 2, -D / 2, D / 2, 1.0]]),
    }
    return parts, ann


def _seat_row(x0, x1, n):
    """Centres of ``n`` equal seats along the interval [x0, x1]."""
    return x0 + (np.arange(n) + 0.5) * (x1 - x0) / n


def _build_sofa(p):
    W, D, h = p["width"], p["depth"], p["seat_height"]
    bt, aw = p["back_thickness"], p["arm_width"]
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (W / 2, D / 2, h), "base"),
        _slab((-W / 2, -D / 2, 0.0), (W / 2, -D / 2 + bt, h + p["back_height"]), "back"),
        _slab((-W / 2, -D / 2, 0.0), (-W / 2 + aw, D / 2, h + p["arm_height"]), "arm"),
        _slab((W / 2 - aw, -D / 2, 0.0), (W / 2, D / 2, h + p["arm_height"]), "arm"),
    ]
    inner = W - 2 * aw
    n = 2 if inner < 1.45 else 3
    p["n_seats"] = n
    seat_y = min(-D / 2 + bt + PELVIS_FROM_BACKREST, bt / 2)
    xs = _seat_row(-inner / 2, inner / 2, n)
    ann = {
        "sit_positions": np.stack([xs, np.full(n, seat_y), np.full(n, h + SEAT_PELVIS_HEIGHT)], axis=1),
        "sit_directions": np.repeat([[0.0, 1.0, 0.0]], n, axis=0),
        "lie_positions": np.array([[0.0, bt / 2, h + LIE_PELVIS_HEIGHT]] * 2),
        "lie_directions": np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
    }
    return parts, ann


def _build_l_sofa(p):
    W, D, C, h = p["width"], p["depth"], p["chaise_length"], p["seat_height"]
    bt, aw, s = p["back_thickness"], p["arm_width"], p["l_side"]
    top_back, top_arm = h + p["back_height"], h + p["arm_height"]
    y0 = -C / 2  # back of the main part; the L part reaches to y0 + C

    def xs(a, b):  # an x interval written for s = +1, mirrored for s = -1
        return sorted((s * a, s * b))

    (mx0, mx1), (cx0, cx1) = xs(-W / 2, W / 2), xs(W / 2 - D, W / 2)
    (bx0, bx1), (ax0, ax1) = xs(W / 2 - bt, W / 2), xs(-W / 2, -W / 2 + aw)
    parts = [
        _slab((mx0, y0, 0.0), (mx1, y0 + D, h), "base"),
        _slab((cx0, y0, 0.0), (cx1, y0 + C, h), "chaise"),
        _slab((mx0, y0, 0.0), (mx1, y0 + bt, top_back), "back"),
        _slab((bx0, y0, 0.0), (bx1, y0 + C, top_back), "side_back"),
        _slab((ax0, y0, 0.0), (ax1, y0 + D, top_arm), "arm"),
        _slab((cx0, y0 + C - aw, 0.0), (cx1, y0 + C, top_arm), "arm"),
    ]
    seat_z = h + SEAT_PELVIS_HEIGHT
    # main part: seats facing +Y from the arm to the side back (the corner seat included)
    main_len = W - aw - bt
    n_main = int(np.clip(round(main_len / 0.7), 2, 3))
    main_x = s * _seat_row(-W / 2 + aw, W / 2 - bt, n_main)
    main_y = min(y0 + bt + PELVIS_FROM_BACKREST, y0 + (bt + D) / 2)
    # L part: seats facing sideways (towards the inside of the L), beyond the main part's depth
    chaise_len = C - D - aw
    n_side = int(np.clip(np.floor(chaise_len / 0.55), 1, 2))
    side_y = _seat_row(y0 + D, y0 + C - aw, n_side)
    side_x = s * min(W / 2 - bt - PELVIS_FROM_BACKREST, W / 2 - (D + bt) / 2)
    p["n_seats"] = n_main + n_side
    positions = np.concatenate(
        [
            np.stack([main_x, np.full(n_main, main_y), np.full(n_main, seat_z)], axis=1),
            np.stack([np.full(n_side, side_x), side_y, np.full(n_side, seat_z)], axis=1),
        ]
    )
    directions = np.concatenate([np.repeat([[0.0, 1.0, 0.0]], n_main, 0), np.repeat([[-s, 0.0, 0.0]], n_side, 0)])
    lie_z = h + LIE_PELVIS_HEIGHT
    main_mid = s * (-W / 2 + aw + W / 2 - bt) / 2
    ann = {
        "sit_positions": positions,
        "sit_directions": directions.astype(np.float64),
        "lie_positions": np.array(
            [[main_mid, y0 + (bt + D) / 2, lie_z]] * 2 + [[s * (W / 2 - (D + bt) / 2), y0 + (D + C - aw) / 2, lie_z]]
        ),
        "lie_directions": np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
    }
    return parts, ann


def _build_yoga_ball(p):
    r = p["radius"]
    positions, directions = _sit_fan((0.0, 0.0, 2 * r + SEAT_PELVIS_HEIGHT), p["n_sit_directions"], p["sit_yaw"])
    ann = {"sit_positions": positions, "sit_directions": directions, **_lift_pair(r, r)}
    return [sphere((0.0, 0.0, r), r, name="ball")], ann


def _build_suitcase(p):
    W, D, H, wr = p["width"], p["depth"], p["height"], p["wheel_radius"]
    z0 = 1.6 * wr  # body bottom: wheels poke 0.4 r into it
    parts = [_slab((-W / 2, -D / 2, z0), (W / 2, D / 2, z0 + H), "body")]
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(sphere((sx * (W / 2 - wr - 0.01), sy * (D / 2 - wr - 0.01), wr), wr, name="wheel"))
    hh = p["handle_height"]
    parts.append(_slab((-0.06, -0.012, z0 + H - _JOIN), (0.06, 0.012, z0 + H + hh), "handle"))
    return parts, _lift_pair(W / 2, z0 + 0.6 * H)


def _build_box(p):
    W, D, H = p["width"], p["depth"], p["height"]
    positions, directions = _sit_fan((0.0, 0.0, H + SEAT_PELVIS_HEIGHT), p["n_sit_directions"], p["sit_yaw"])
    ann = {"sit_positions": positions, "sit_directions": directions, **_lift_pair(W / 2, H / 2)}
    return [_slab((-W / 2, -D / 2, 0.0), (W / 2, D / 2, H), "box")], ann


def _build_shelf(p):
    W, D, H, t = p["width"], p["depth"], p["height"], p["board_thickness"]
    ph, n = p["plinth_height"], p["n_boards"]
    back_t = 0.012
    xi = W / 2 - t  # inner half width
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (-xi, D / 2, H), "side"),
        _slab((xi, -D / 2, 0.0), (W / 2, D / 2, H), "side"),
        _slab((-xi - _JOIN, -D / 2, 0.0), (xi + _JOIN, -D / 2 + back_t, H - t), "back"),
        _slab((-xi - _JOIN, D / 2 - 0.03, 0.0), (xi + _JOIN, D / 2 - 0.01, ph), "plinth"),
        _slab((-xi - _JOIN, -D / 2 + back_t - _JOIN, ph), (xi + _JOIN, D / 2, ph + t), "board"),
        _slab((-xi - _JOIN, -D / 2, H - t), (xi + _JOIN, D / 2, H), "top"),
    ]
    floor_z, ceil_z = ph + t, H - t
    gap = (ceil_z - floor_z - n * t) / (n + 1)
    surfaces = [floor_z]
    for k in range(n):
        z = floor_z + (k + 1) * gap + k * t
        parts.append(_slab((-xi - _JOIN, -D / 2 + back_t - _JOIN, z), (xi + _JOIN, D / 2, z + t), "board"))
        surfaces.append(z + t)
    supports = [[z, -xi, xi, -D / 2 + back_t, D / 2, gap] for z in surfaces]
    supports.append([H, -W / 2, W / 2, -D / 2, D / 2, 0.5])
    return parts, {"supports": np.array(supports)}


def _check_state(p, name, category):
    r = CATEGORY_SIZES[category][name]
    if not (r.low <= p[name] <= r.high):
        raise ValueError(f"{name}: expected a value in [{r.low}, {r.high}] {r.unit}, got {p[name]}")


def _build_cabinet(p):
    _check_state(p, "door_angle", "cabinet")
    W, D, H, t = p["width"], p["depth"], p["height"], p["wall_thickness"]
    ph, dt, s = p["plinth_height"], p["door_thickness"], p["hinge_side"]
    back_t = 0.012
    xi = W / 2 - t
    floor_z, ceil_z = ph + t, H - t
    board_z = floor_z + p["board_fraction"] * (ceil_z - floor_z - t)
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (-xi, D / 2, H), "side"),
        _slab((xi, -D / 2, 0.0), (W / 2, D / 2, H), "side"),
        _slab((-xi - _JOIN, -D / 2, H - t), (xi + _JOIN, D / 2, H), "top"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, D / 2, ph + t), "bottom"),
        _slab((-xi - _JOIN, -D / 2 + 0.03, 0.0), (xi + _JOIN, D / 2 - 0.03, ph + _JOIN), "plinth"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, -D / 2 + back_t, H - t + _JOIN), "back"),
        _slab((-xi - _JOIN, -D / 2 + back_t - _JOIN, board_z), (xi + _JOIN, D / 2 - 0.02, board_z + t), "board"),
    ]
    # door: hinged on a vertical axis at the front edge of the side ``s``; the free edge swings to +Y
    hinge = np.array([s * W / 2, D / 2 - _JOIN, 0.0])
    swing = rotation_z(-s * p["door_angle"])
    door_lo, door_hi = np.array([-W / 2, D / 2 - _JOIN, ph]), np.array([W / 2, D / 2 - _JOIN + dt, H])
    door_centre = swing @ ((door_lo + door_hi) / 2 - hinge) + hinge
    parts.append(box(door_centre, (door_hi - door_lo) / 2, swing, name="door"))
    handle_z = ph + 0.7 * (H - ph)
    handle_closed = np.array([-s * (W / 2 - 0.05), D / 2 - _JOIN + dt + 0.015, handle_z])
    handle_centre = swing @ (handle_closed - hinge) + hinge
    parts.append(box(handle_centre, (0.01, 0.015 + _JOIN, 0.06), swing, name="handle"))
    handle_point = swing @ (handle_closed + np.array([0.0, 0.015 + _JOIN, 0.0]) - hinge) + hinge
    ann = {
        "handle_point": handle_point,
        "grasp_points": handle_point[None],
        "supports": np.array(
            [
                [floor_z, -xi, xi, -D / 2 + back_t, D / 2 - 0.02, board_z - floor_z],
                [board_z + t, -xi, xi, -D / 2 + back_t, D / 2 - 0.02, ceil_z - board_z - t],
            ]
        ),
    }
    return parts, ann


def _build_drawer(p):
    _check_state(p, "drawer_open", "drawer")
    W, D, H, t = p["width"], p["depth"], p["height"], p["wall_thickness"]
    ph, ft, n, pull = p["plinth_height"], p["front_thickness"], p["n_drawers"], p["drawer_open"]
    back_t = 0.012
    xi = W / 2 - t
    floor_z, ceil_z = ph + t, H - t
    slot = (ceil_z - floor_z - (n - 1) * t) / n
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (-xi, D / 2, H), "side"),
        _slab((xi, -D / 2, 0.0), (W / 2, D / 2, H), "side"),
        _slab((-xi - _JOIN, -D / 2, H - t), (xi + _JOIN, D / 2, H), "top"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, D / 2, ph + t), "bottom"),
        _slab((-xi - _JOIN, -D / 2 + 0.03, 0.0), (xi + _JOIN, D / 2 - 0.03, ph + _JOIN), "plinth"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, -D / 2 + back_t, H - t + _JOIN), "back"),
    ]
    slot_bottoms = [floor_z + k * (slot + t) for k in range(n)]
    for z in slot_bottoms[1:]:
        parts.append(_slab((-xi - _JOIN, -D / 2, z - t), (xi + _JOIN, D / 2, z), "divider"))
    gap = 0.004  # clearance of a drawer inside its slot
    for z in slot_bottoms[:-1]:  # closed lower drawers: fronts only
        parts.append(_slab((-xi + gap, D / 2 - ft, z + gap), (xi - gap, D / 2, z + slot - gap), "front"))
    # the top drawer: a tray (bottom, sides, back) behind a front, all shifted by ``pull`` towards +Y
    z = slot_bottoms[-1]
    tray_t, tray_top = 0.012, z + 0.75 * slot
    y_back, y_front = -D / 2 + back_t + 0.02 + pull, D / 2 - ft + pull
    x_out = xi - gap
    parts += [
        _slab((-x_out, y_front, z + gap), (x_out, y_front + ft, z + slot - gap), "front"),
        _slab((-x_out, y_back, z + gap), (x_out, y_front + _JOIN, z + gap + tray_t), "tray_bottom"),
        _slab((-x_out, y_back, z + gap), (-x_out + tray_t, y_front + _JOIN, tray_top), "tray_side"),
        _slab((x_out - tray_t, y_back, z + gap), (x_out, y_front + _JOIN, tray_top), "tray_side"),
        _slab((-x_out, y_back, z + gap), (x_out, y_back + tray_t, tray_top), "tray_back"),
    ]
    handle_z = z + slot / 2
    handle_y = y_front + ft + 0.015
    parts.append(_slab((-0.06, y_front + ft - _JOIN, handle_z - 0.01), (0.06, handle_y, handle_z + 0.01), "handle"))
    handle_point = np.array([0.0, handle_y, handle_z])
    inner_floor = z + gap + tray_t
    ann = {
        "handle_point": handle_point,
        "grasp_points": handle_point[None],
        "supports": np.array(
            [[inner_floor, -x_out + tray_t, x_out - tray_t, y_back + tray_t, y_front, z + slot - gap - inner_floor]]
        ),
    }
    return parts, ann


def _build_bottle(p):
    r, bh, nr, nh = p["body_radius"], p["body_height"], p["neck_radius"], p["neck_height"]
    cap_h = 0.015
    parts = [
        cylinder((0.0, 0.0, bh / 2), r, bh / 2, name="body"),
        cylinder((0.0, 0.0, bh + nh / 2 - _JOIN / 2), nr, nh / 2 + _JOIN / 2, name="neck"),
        cylinder((0.0, 0.0, bh + nh + cap_h / 2 - _JOIN / 2), nr + 0.003, cap_h / 2 + _JOIN / 2, name="cap"),
    ]
    ann = {"grasp_points": np.array([[0.0, r, 0.55 * bh], [0.0, nr, bh + nh / 2]])}
    return parts, ann


def _build_mug(p):
    r, h, th, reach = p["radius"], p["height"], p["handle_thickness"], p["handle_reach"]
    x_in, x_out = r - 2 * _JOIN, r + reach
    parts = [
        cylinder((0.0, 0.0, h / 2), r, h / 2, name="body"),
        _slab((x_in, -th / 2, 0.8 * h - th / 2), (x_out, th / 2, 0.8 * h + th / 2), "handle"),
        _slab((x_in, -th / 2, 0.3 * h - th / 2), (x_out, th / 2, 0.3 * h + th / 2), "handle"),
        _slab((x_out - th, -th / 2, 0.3 * h - th / 2), (x_out, th / 2, 0.8 * h + th / 2), "handle"),
    ]
    ann = {"grasp_points": np.array([[x_out, 0.0, 0.55 * h], [0.0, r, 0.5 * h]])}
    return parts, ann


def _build_teapot(p):
    R, ls, reach, kr = p["body_radius"], p["spout_length"], p["handle_reach"], p["knob_radius"]
    th = 0.012
    spout_start = np.array([0.5 * R, 0.0, 0.8 * R])
    spout_end = np.array([R + 0.7 * ls, 0.0, 0.8 * R + 0.7 * ls])
    x_in, x_out = -0.8 * R, -(R + reach)
    parts = [
        sphere((0.0, 0.0, R), R, name="body"),
        cylinder((0.0, 0.0, 0.01), 0.55 * R, 0.01, name="base"),
        capsule_between(spout_start, spout_end, 0.012, name="spout"),
        _slab((x_out, -th / 2, 1.5 * R - th / 2), (x_in, th / 2, 1.5 * R + th / 2), "handle"),
        _slab((x_out, -th / 2, 0.7 * R - th / 2), (x_in, th / 2, 0.7 * R + th / 2), "handle"),
        _slab((x_out, -th / 2, 0.7 * R - th / 2), (x_out + th, th / 2, 1.5 * R + th / 2), "handle"),
        sphere((0.0, 0.0, 2 * R + 0.5 * kr), kr, name="knob"),
    ]
    ann = {"grasp_points": np.array([[x_out, 0.0, 1.1 * R], [0.0, 0.0, 2 * R + 1.5 * kr]])}
    return parts, ann


BUILDERS = {
    "chair": _build_chair, "armchair": _build_armchair, "stool": _build_stool, "table": _build_table,
    "sofa": _build_sofa, "l_sofa": _build_l_sofa, "yoga_ball": _build_yoga_ball,
    "suitcase": _build_suitcase, "box": _build_box, "shelf": _build_shelf, "cabinet": _build_cabinet,
    "drawer": _build_drawer, "bottle": _build_bottle, "mug": _build_mug, "teapot": _build_teapot,
}
# annotation entries that are points (moved with the object) and directions (rotated only)
POINT_KEYS = ("sit_positions", "lie_positions", "lift_contacts", "grasp_points", "handle_point")
_DIRECTION_KEYS = ("sit_directions", "lie_directions", "lift_approach")
# parameters a builder adds to the sampled ones (left out when an instance is rebuilt)
DERIVED_PARAMS = ("n_seats",)


def recentre(parts, ann):
    """Shift parts and annotations so the x/y bounding box is centred on the origin."""
    bounds = np.stack([primitive_bounds(q) for q in parts])
    lo, hi = bounds[:, 0].min(0), bounds[:, 1].max(0)
    offset = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, 0.0])
    if np.allclose(offset, 0.0):
        return parts, ann
    shift = rigid_transform(translation=offset)
    ann = dict(ann)
    for key in POINT_KEYS:
        if key in ann:
            ann[key] = ann[key] + offset
    if "supports" in ann:
        s = ann["supports"].copy()
        s[:, 1:3] += offset[0]
        s[:, 3:5] += offset[1]
        ann["supports"] = s
    return [q.transformed(shift) for q in parts], ann
