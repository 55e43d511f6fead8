"""Body-level conventions: which way a skeleton faces, and its heading over time.

Axes: +Y up. The heading yaw is the rotation about +Y that turns +Z into the body's facing direction.
"""

from __future__ import annotations

import numpy as np

from elastyle.skeleton import Skeleton
from elastyle.types import FloatArray


def pelvis_forward_local(skeleton: Skeleton) -> FloatArray:
    """Facing direction (3,) in the pelvis's local frame, from its left/right and upward children.

    Left-to-right children give the lateral axis, the first centre child (the spine) the up axis, and
    forward = lateral x up (a body facing +Z with +Y up has its left at +X). Falls back to local +Z.
    """
    pelvis = skeleton.pelvis
    partner = skeleton.mirror_pairs()
    children = skeleton.children(pelvis)
    sided = [c for c in children if partner[c] != c and partner[c] in children]
    centre = [c for c in children if partner[c] == c]
    if not sided or not centre:
        return np.array([0.0, 0.0, 1.0])
    left = next((c for c in sided if _is_left(skeleton.names[c])), sided[0])
    lateral = skeleton.offsets[left] - skeleton.offsets[partner[left]]
    up = skeleton.offsets[centre[0]]
    up = up - lateral * (up @ lateral) / max(lateral @ lateral, 1e-12)
    forward = np.cross(lateral, up)
    norm = np.linalg.norm(forward)
    return forward / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])


def _is_left(name: str) -> bool:
    lower = name.lower()
    return lower.endswith(("_l", ".l")) or lower.startswith(("l_", "l.")) or "left" in lower


def heading_yaw(pelvis_world_rotations: FloatArray, forward_local: FloatArray) -> FloatArray:
    """Unwrapped heading yaw (T,) radians from pelvis world rotation matrices (T, 3, 3)."""
    forward = pelvis_world_rotations @ forward_local  # (T, 3)
    return np.unwrap(np.arctan2(forward[:, 0], forward[:, 2]))


def smooth(values: FloatArray, sigma_frames: float) -> FloatArray:
    """Gaussian low-pass along time (axis 0) of (T, ...) values; edges held constant.

    The same as scipy.ndimage.gaussian_filter1d(values, sigma, axis=0, mode="nearest") (a test checks),
    written here because importing scipy.ndimage costs about 0.6 s, more than a whole transfer.
    """
    if sigma_frames <= 0 or values.shape[0] < 2:
        return values.copy()
    radius = int(4.0 * sigma_frames + 0.5)
    offsets = np.arange(-radius, radius + 1)
    kernel = np.exp(-0.5 * (offsets / sigma_frames) ** 2)
    kernel /= kernel.sum()
    flat = values.reshape(values.shape[0], -1)  # (T, N)
    padded = np.pad(flat, ((radius, radius), (0, 0)), mode="edge")  # (T + 2r, N)
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * radius + 1, axis=0)  # (T, N, K)
    return (windows @ kernel).reshape(values.shape)


def yaw_matrices(yaw: FloatArray) -> FloatArray:
    """Rotation matrices (T, 3, 3) about +Y by yaw (T,) radians."""
    cos, sin = np.cos(yaw), np.sin(yaw)
    matrices = np.zeros((*yaw.shape, 3, 3))
    matrices[..., 0, 0] = cos
    matrices[..., 0, 2] = sin
    matrices[..., 1, 1] = 1.0
    matrices[..., 2, 0] = -sin
    matrices[..., 2, 2] = cos
    return matrices
