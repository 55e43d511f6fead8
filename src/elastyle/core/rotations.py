"""Rotation helpers over exponential maps (rotation vectors, radians), vectorised in numpy.

Exp maps `(..., 3)` are the rotation format clips carry. Quaternions, scalar-last `(x, y, z, w)` like
scipy (the tests' reference), serve where a sign choice or a product is needed: feature encoding (kept
continuous along time), BVH Euler angles and training. Plain numpy on whole arrays is several times
faster here than building scipy `Rotation` objects for every call.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from elastyle.core.resample import bracket
from elastyle.types import FloatArray


def lengths(vectors: FloatArray, keepdims: bool = False) -> FloatArray:
    """Euclidean lengths over the last axis of (..., D) -> (...) or (..., 1).

    The same as np.linalg.norm(axis=-1), about three times faster on the small arrays used here.
    """
    result = np.sqrt(np.einsum("...i,...i->...", vectors, vectors))
    return result[..., None] if keepdims else result


def to_quat(rotvecs: FloatArray) -> FloatArray:
    """Exp maps (..., 3) -> unit quaternions (..., 4), scalar last."""
    rotvecs = np.asarray(rotvecs)
    angle = lengths(rotvecs)  # (...)
    small = angle < 1e-6
    # sin(angle / 2) / angle, with its Taylor series near zero so the identity stays finite
    scale = np.sin(angle / 2)
    if np.any(small):
        scale = np.where(small, 0.5 - angle**2 / 48, scale / np.where(small, 1.0, angle))
    else:
        scale /= angle
    quats = np.empty((*angle.shape, 4), dtype=np.result_type(rotvecs, scale))
    np.multiply(rotvecs, scale[..., None], out=quats[..., :3])
    np.cos(angle / 2, out=quats[..., 3])
    return quats


def from_quat(quats: FloatArray) -> FloatArray:
    """Quaternions (..., 4), scalar last -> exp maps (..., 3). Keeps the sign: w < 0 gives angles > pi."""
    quats = np.asarray(quats)
    size = lengths(quats, keepdims=True)  # (..., 1)
    vector = quats[..., :3] / size
    sin_half = lengths(vector)  # (...)
    half_angle = np.arctan2(sin_half, quats[..., 3] / size[..., 0])  # (...) in [0, pi]
    small = sin_half < 1e-9
    # angle / sin(angle / 2) -> 2 as the angle -> 0; keeps the identity rotation finite.
    if np.any(small):
        scale = np.where(small, 2.0, 2.0 * half_angle / np.where(small, 1.0, sin_half))
    else:
        scale = 2.0 * half_angle / sin_half
    vector *= scale[..., None]
    return vector


def canonical_log(quats: FloatArray) -> FloatArray:
    """Quaternions (..., 4) -> exp maps (..., 3) with angle in [0, pi] (the shorter way round)."""
    return from_quat(np.where(quats[..., 3:4] < 0, -quats, quats))


def stack_last(parts: list[Any]) -> Any:
    """numpy's stack along a new last axis (the default `stack` of the quaternion helpers)."""
    return np.stack(parts, axis=-1)


def quat_multiply(left: Any, right: Any, stack: Callable[[list[Any]], Any] = stack_last) -> Any:
    """Hamilton product of scalar-last quaternions (..., 4) (numpy arrays, or torch tensors in training):
    the rotation `left @ right`.

    `stack` joins the four components along a new last axis (training passes torch's).
    """
    x1, y1, z1, w1 = (left[..., i] for i in range(4))
    x2, y2, z2, w2 = (right[..., i] for i in range(4))
    return stack(
        [
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        ]
    )


def quat_to_matrix(quats: Any, stack: Callable[[list[Any]], Any] = stack_last) -> Any:
    """Unit quaternions (..., 4) -> rotation matrices (..., 3, 3), for any array type as `quat_multiply`."""
    x, y, z, w = (quats[..., i] for i in range(4))
    matrices = stack(
        [
            1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
        ]
    )  # fmt: skip
    return matrices.reshape(*quats.shape[:-1], 3, 3)


TRACE_FROM_SHEPPERD = -0.9  # 1 + trace = 4 w^2: below 0.1 (rotations past about 162 degrees) use Shepperd


def matrix_to_quat(matrices: FloatArray) -> FloatArray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4) with w >= 0.

    From the trace where the rotation is below about 162 degrees (accurate there, and most rotations are),
    by Shepperd's method for the rest.
    """
    m = matrices
    trace = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    quats = np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1], 1 + trace],
        axis=-1,
    )  # (..., 4): 2 (1 + trace)^(1/2) times the quaternion
    near_half_turn = trace < TRACE_FROM_SHEPPERD
    if np.any(near_half_turn):
        quats[near_half_turn] = _shepperd(m[near_half_turn])
    return quats / lengths(quats, keepdims=True)


def _shepperd(matrices: FloatArray) -> FloatArray:
    """Rotation matrices (N, 3, 3) -> unit quaternions (N, 4) with w >= 0, accurate for any angle."""
    m = matrices
    trace = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    # four candidate quaternions, each accurate when its own component is the largest
    candidates = np.stack(
        [
            np.stack([1 + 2 * m[..., 0, 0] - trace, m[..., 1, 0] + m[..., 0, 1], m[..., 0, 2] + m[..., 2, 0],
                      m[..., 2, 1] - m[..., 1, 2]], axis=-1),
            np.stack([m[..., 1, 0] + m[..., 0, 1], 1 + 2 * m[..., 1, 1] - trace, m[..., 2, 1] + m[..., 1, 2],
                      m[..., 0, 2] - m[..., 2, 0]], axis=-1),
            np.stack([m[..., 0, 2] + m[..., 2, 0], m[..., 2, 1] + m[..., 1, 2], 1 + 2 * m[..., 2, 2] - trace,
                      m[..., 1, 0] - m[..., 0, 1]], axis=-1),
            np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1],
                      1 + trace], axis=-1),
        ],
        axis=-2,
    )  # (..., 4 candidates, 4)  # fmt: skip
    diagonal = np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2], trace], axis=-1)
    best = np.argmax(diagonal, axis=-1)[..., None, None]
    quats = np.take_along_axis(candidates, best, axis=-2)[..., 0, :]
    quats /= lengths(quats, keepdims=True)
    return np.where(quats[..., 3:4] < 0, -quats, quats)


def to_matrix(rotvecs: FloatArray) -> FloatArray:
    """Exp maps (..., 3) -> rotation matrices (..., 3, 3) acting on column vectors."""
    return quat_to_matrix(to_quat(rotvecs))


def least_turn(sources: FloatArray, targets: FloatArray) -> FloatArray:
    """Exp maps (..., 3) of the least turns that take the directions of sources (..., 3) onto those of
    targets (..., 3); a half turn, about the axis across the source and its smallest coordinate's axis,
    where they point exactly opposite ways."""
    axis = np.cross(sources, targets)
    size = lengths(axis, keepdims=True)  # (..., 1)
    angle = np.arctan2(size, np.sum(sources * targets, axis=-1, keepdims=True))
    opposite = (size[..., 0] < 1e-12 * lengths(sources) * lengths(targets)) & (angle[..., 0] > np.pi / 2)
    if np.any(opposite):
        across = np.eye(3)[np.argmin(np.abs(sources[opposite]), axis=-1)]  # (K, 3)
        axis[opposite] = np.cross(sources[opposite], across)
        size[opposite] = lengths(axis[opposite], keepdims=True)
        angle[opposite] = np.pi
    return np.where(size > 0, axis / np.maximum(size, 1e-300) * angle, 0.0)


def from_matrix(matrices: FloatArray) -> FloatArray:
    """Rotation matrices (..., 3, 3) -> exp maps (..., 3) with angle in [0, pi]."""
    return from_quat(matrix_to_quat(matrices))


def multiply(left: FloatArray, right: FloatArray) -> FloatArray:
    """Compose exp maps (..., 3), broadcasting: the rotation `left @ right` (right applied first)."""
    return canonical_log(quat_multiply(to_quat(left), to_quat(right)))


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
    """Exp maps (T, ..., 3) made continuous along time from the first frame's angle in [0, pi]: later angles
    may exceed pi where that avoids a jump."""
    return continuous_log_of_quats(to_quat(rotvecs), axis)


def continuous_log_of_quats(quats: FloatArray, axis: int = 0) -> FloatArray:
    """Quaternions (T, ..., 4) as exp maps (T, ..., 3) continuous along time (see `continuous_log`)."""
    first = np.take(quats, [0], axis=axis)[..., 3:4]  # (1, ..., 1) the first frame's w
    return from_quat(continuous_quats(np.where(first < 0, -quats, quats), axis=axis))


def slerp_resample(rotvecs: FloatArray, times: FloatArray) -> FloatArray:
    """Sample rotations (T, J, 3) at fractional frame indices `times` (N,) in [0, T-1] by slerp -> (N, J, 3)
    (the shorter way between neighbouring frames; angles in [0, pi])."""
    lower, upper, weight = bracket(times, rotvecs.shape[0])  # (N,) each
    weight = weight[:, None, None]  # (N, 1, 1)
    quats = to_quat(rotvecs)  # (T, J, 4)
    start, end = quats[lower], quats[upper]  # (N, J, 4)
    cosine = np.sum(start * end, axis=-1, keepdims=True)  # (N, J, 1)
    end = np.where(cosine < 0, -end, end)  # the shorter way
    angle = np.arccos(np.minimum(np.abs(cosine), 1.0))  # half the angle between them
    sine = np.sin(angle)
    near = sine < 1e-9  # (nearly) the same rotation: linear weights, then normalised
    sine = np.where(near, 1.0, sine)
    start_weight = np.where(near, 1 - weight, np.sin((1 - weight) * angle) / sine)
    end_weight = np.where(near, weight, np.sin(weight * angle) / sine)
    return canonical_log(start_weight * start + end_weight * end)
