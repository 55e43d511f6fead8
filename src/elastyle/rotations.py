"""Rotation helpers over exponential maps (rotation vectors, radians).

Exp maps `(..., 3)` are the one rotation format outside `io/bvh`. Quaternions appear only inside this
module and are scalar-last `(x, y, z, w)`, like scipy, which does the heavy lifting.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from elastyle.types import FloatArray


def _as_rotation(rotvecs: FloatArray) -> Rotation:
    return Rotation.from_rotvec(np.array(rotvecs, dtype=np.float64).reshape(-1, 3))


def to_matrix(rotvecs: FloatArray) -> FloatArray:
    """Exp maps (..., 3) -> rotation matrices (..., 3, 3) acting on column vectors."""
    return _as_rotation(rotvecs).as_matrix().reshape(*rotvecs.shape[:-1], 3, 3)


def from_matrix(matrices: FloatArray) -> FloatArray:
    """Rotation matrices (..., 3, 3) -> exp maps (..., 3) with angle in [0, pi]."""
    return Rotation.from_matrix(matrices.reshape(-1, 3, 3)).as_rotvec().reshape(*matrices.shape[:-2], 3)


def to_quat(rotvecs: FloatArray) -> FloatArray:
    """Exp maps (..., 3) -> unit quaternions (..., 4), scalar last."""
    return _as_rotation(rotvecs).as_quat().reshape(*rotvecs.shape[:-1], 4)


def from_quat(quats: FloatArray) -> FloatArray:
    """Quaternions (..., 4), scalar last -> exp maps (..., 3). Keeps the sign: w < 0 gives angles > pi."""
    quats = quats / np.linalg.norm(quats, axis=-1, keepdims=True)
    vector = quats[..., :3]
    sin_half = np.linalg.norm(vector, axis=-1, keepdims=True)  # (..., 1)
    half_angle = np.arctan2(sin_half, quats[..., 3:4])  # (..., 1) in [0, pi]
    small = sin_half < 1e-9
    # angle / sin(angle / 2) -> 2 as the angle -> 0; keeps the identity rotation finite.
    scale = np.where(small, 2.0, 2.0 * half_angle / np.where(small, 1.0, sin_half))
    return vector * scale


def multiply(left: FloatArray, right: FloatArray) -> FloatArray:
    """Compose exp maps (..., 3): the rotation `left @ right` (right applied first)."""
    shape = np.broadcast_shapes(left.shape, right.shape)
    left_b = np.broadcast_to(left, shape)
    right_b = np.broadcast_to(right, shape)
    return (_as_rotation(left_b) * _as_rotation(right_b)).as_rotvec().reshape(shape)


def inverse(rotvecs: FloatArray) -> FloatArray:
    """Inverse rotation of exp maps (..., 3)."""
    return -rotvecs


def continuous_quats(quats: FloatArray, axis: int = 0) -> FloatArray:
    """Flip quaternion signs (..., 4) so consecutive ones along `axis` lie on one hemisphere."""
    quats = np.moveaxis(quats, axis, 0).copy()  # (T, ..., 4)
    dots = np.sum(quats[1:] * quats[:-1], axis=-1)  # (T-1, ...)
    flips = np.cumsum(dots < 0, axis=0) % 2  # (T-1, ...)
    quats[1:] *= np.where(flips[..., None] == 1, -1.0, 1.0)
    return np.moveaxis(quats, 0, axis)


def continuous_log(rotvecs: FloatArray, axis: int = 0) -> FloatArray:
    """Exp maps (T, ..., 3) made continuous along time: angles may exceed pi where that avoids a jump."""
    quats = continuous_quats(to_quat(rotvecs), axis=axis)
    # Keep the whole sequence on the hemisphere of its mean so most angles stay below pi.
    mean = np.sum(quats, axis=axis, keepdims=True)
    sign = np.where(np.sum(mean * quats, axis=-1, keepdims=True).sum(axis=axis, keepdims=True) < 0, -1.0, 1.0)
    return from_quat(quats * sign)


def slerp_resample(rotvecs: FloatArray, times: FloatArray) -> FloatArray:
    """Sample rotations (T, J, 3) at fractional frame indices `times` (N,) in [0, T-1] by slerp -> (N, J, 3)."""
    num_frames = rotvecs.shape[0]
    times = np.clip(times, 0.0, num_frames - 1)
    lower = np.minimum(np.floor(times).astype(np.int64), max(num_frames - 2, 0))  # (N,)
    upper = np.minimum(lower + 1, num_frames - 1)
    weight = (times - lower)[:, None, None]  # (N, 1, 1)
    start = rotvecs[lower]  # (N, J, 3)
    # relative rotation from start to end, scaled by the weight, applied after start
    delta = multiply(inverse(start), rotvecs[upper])
    return multiply(start, delta * weight)


def yaw_rotation(yaw: FloatArray) -> FloatArray:
    """Exp maps (..., 3) of rotations by `yaw` radians (...,) about +Y."""
    out = np.zeros((*np.shape(yaw), 3))
    out[..., 1] = yaw
    return out
