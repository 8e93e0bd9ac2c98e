"""The NSM-like baseline's environment sensor (SAMP §5.2 and Table 5; Starke et al. 2019, "Neural State Machine").

SAMP compares MotionNet with NSM, a deterministic mixture of experts that "uses a volumetric sensor to detect
collisions with the environment" instead of SAMP's interaction encoder over the target object's voxels. Our
NSM-like model keeps MotionNet's deterministic decoder (the MoE baseline: no latent) and replaces what the
2048 voxel inputs hold: not the target's 8×8×8 cells seen from the root, but a fixed 8×8×8 grid of cells
that moves with the character (:data:`SENSOR_EXTENT`, in the root frame), each with its centre and the
occupancy it senses there from every object around, the target and the obstacles alike.

NSM's sensor is a cylinder of sample points around the character; a box in the root frame with the same
number of inputs as SAMP's voxels is ours, so that the two models differ only in what they sense. The
occupancy at a sensor cell is that of the nearest cell of an object's own voxel grid
(:meth:`~hoi_tutorial.world.objects.ToyObject.interaction_voxels`), looked up from the grid's lattice.
"""
from __future__ import annotations

import torch

from .._validate import check_shape

__all__ = ["SENSOR_RESOLUTION", "SENSOR_EXTENT", "sensor_cells", "sensor_points", "lattice_occupancy",
           "sensor_voxels"]

SENSOR_RESOLUTION = 8
# (forward, left, up) ranges in metres of the root frame: 1.6 m ahead, 0.8 m behind, 1.2 m to each side, 0-1.6 m up.
SENSOR_EXTENT = ((-0.8, 1.6), (-1.2, 1.2), (0.0, 1.6))
_GRID = 512  # cells of one object's 8×8×8 voxel grid


def sensor_cells() -> torch.Tensor:
    """``(512, 3)`` the sensor's cell centres in the root frame (m), forward index slowest, up fastest."""
    axes = [lo + (hi - lo) * (torch.arange(SENSOR_RESOLUTION, dtype=torch.float32) + 0.5) / SENSOR_RESOLUTION
            for lo, hi in SENSOR_EXTENT]
    return torch.stack(torch.meshgrid(*axes, indexing="ij"), dim=-1).reshape(-1, 3)


def sensor_points(roots: torch.Tensor) -> torch.Tensor:
    """``(B, 512, 3)`` the sensor's cell centres in the world for characters at ``roots (B, 3)`` ``(x, y, heading)``."""
    check_shape(roots, (None, 3), "roots")
    local = sensor_cells().to(roots.dtype)
    c, s = torch.cos(roots[:, 2])[:, None], torch.sin(roots[:, 2])[:, None]
    return torch.stack([roots[:, None, 0] + c * local[:, 0] - s * local[:, 1],
                        roots[:, None, 1] + s * local[:, 0] + c * local[:, 1],
                        local[:, 2].expand(roots.shape[0], -1)], dim=-1)


def lattice_occupancy(points: torch.Tensor, centres: torch.Tensor, occupancy: torch.Tensor) -> torch.Tensor:
    """The occupancy objects' voxel grids give at world points: the nearest cell's, 0 outside every grid.

    Args:
        points: ``(B, P, 3)`` world points (m).
        centres: ``(B, 512 M, 3)`` the cells of ``M`` objects' 8×8×8 grids, each in the order of
            ``interaction_voxels(...).reshape(-1, 4)`` (``motion_data.object_voxel_cells``).
        occupancy: ``(B, 512 M)``.
    Returns:
        ``(B, P)``: the largest occupancy over the objects.
    """
    check_shape(points, (None, None, 3), "points")
    B, P = points.shape[:2]
    check_shape(centres, (B, None, 3), "centres")
    check_shape(occupancy, tuple(centres.shape[:2]), "occupancy")
    if centres.shape[1] % _GRID:
        raise ValueError(f"centres: expected whole 8×8×8 grids (a multiple of {_GRID} cells), got {centres.shape[1]}")
    M = centres.shape[1] // _GRID
    grid = centres.reshape(B, M, 8, 8, 8, 3)
    origin = grid[:, :, 0, 0, 0]  # (B, M, 3)
    # the lattice's three cell steps as columns: centre(i, j, k) = origin + steps @ (i, j, k)
    steps = torch.stack([grid[:, :, 1, 0, 0] - origin, grid[:, :, 0, 1, 0] - origin, grid[:, :, 0, 0, 1] - origin],
                        dim=-1)  # (B, M, 3, 3)
    offsets = points[:, None] - origin[:, :, None]  # (B, M, P, 3)
    index = torch.linalg.solve(steps[:, :, None], offsets[..., None])[..., 0].round()  # (B, M, P, 3)
    inside = ((index >= 0) & (index <= 7)).all(-1)
    flat = index.clamp(0, 7).long()
    flat = (flat[..., 0] * 64 + flat[..., 1] * 8 + flat[..., 2])  # (B, M, P)
    values = torch.gather(occupancy.reshape(B, M, _GRID), 2, flat)
    return (values * inside).amax(dim=1)


def sensor_voxels(centres: torch.Tensor, occupancy: torch.Tensor, roots: torch.Tensor) -> torch.Tensor:
    """The NSM-like model's 2048 voxel inputs: per sensor cell its root-frame centre and the occupancy there.

    Args:
        centres, occupancy: ``(B, 512 M, 3)`` and ``(B, 512 M)`` the objects' cells (as
            :func:`lattice_occupancy`), or ``(512 M, 3)`` and ``(512 M,)`` shared by every character,
            or both None: nothing to sense.
        roots: ``(B, 3)`` ``(x, y, heading)``.
    Returns:
        ``(B, 2048)``, laid out like ``motion_data.voxels_in_root_frame``.
    """
    check_shape(roots, (None, 3), "roots")
    B = roots.shape[0]
    local = sensor_cells().to(roots.dtype)  # (512, 3)
    if centres is None:
        return torch.cat([local.expand(B, -1, -1), roots.new_zeros(B, local.shape[0], 1)], dim=-1).reshape(B, -1)
    if centres.dim() == 2:
        centres, occupancy = centres.expand(B, -1, -1), occupancy.expand(B, -1)
    sensed = lattice_occupancy(sensor_points(roots), centres.to(roots.dtype), occupancy.to(roots.dtype))
    return torch.cat([local.expand(B, -1, -1), sensed[..., None]], dim=-1).reshape(B, -1)
