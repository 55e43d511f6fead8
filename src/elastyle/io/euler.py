"""Euler angles in degrees <-> exp maps: the only place with degrees.

BVH rotation channels are intrinsic Euler angles in the order the CHANNELS line lists them, so a joint
with `Zrotation Xrotation Yrotation` is `Rotation.from_euler("ZXY", degrees)`.
"""

from __future__ import annotations

import warnings

import numpy as np

from elastyle.core.rotations import from_quat, quat_multiply, to_matrix
from elastyle.types import FloatArray

_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


def euler_to_rotvec(order: str, angles_deg: FloatArray) -> FloatArray:
    """Intrinsic Euler angles (..., 3) in degrees, axes in `order` (e.g. 'ZXY') -> exp maps (..., 3).

    The product of the three axis quaternions, q = q1 q2 q3: numpy on whole arrays, several times faster
    than scipy's `from_euler`, which the tests use as the reference.
    """
    half = np.radians(angles_deg) / 2
    quat = np.zeros((*angles_deg.shape[:-1], 4))
    quat[..., 3] = 1.0
    for position, axis in enumerate(order):
        axis_quat = np.zeros_like(quat)
        axis_quat[..., _AXIS_INDEX[axis]] = np.sin(half[..., position])
        axis_quat[..., 3] = np.cos(half[..., position])
        quat = quat_multiply(quat, axis_quat)
    return from_quat(np.where(quat[..., 3:] < 0, -quat, quat))


def rotvec_to_euler(order: str, rotvecs: FloatArray) -> FloatArray:
    """Exp maps (..., 3) -> intrinsic Euler angles (..., 3) in degrees for a three-axis `order`.

    Closed form for the six Tait-Bryan orders, with the middle angle in [-90, 90]; frames at gimbal lock
    (and any other order) go through scipy.
    """
    first, second, third = (_AXIS_INDEX[a] for a in order)
    if len({first, second, third}) != 3:
        from scipy.spatial.transform import Rotation  # imported only here: it takes about 0.7 s

        with warnings.catch_warnings():  # a rest pose is at gimbal lock for these orders: the third angle 0
            warnings.simplefilter("ignore", UserWarning)  # is a right solution, not worth a warning per file
            rotation = Rotation.from_rotvec(rotvecs.reshape(-1, 3))
            return rotation.as_euler(order, degrees=True).reshape(rotvecs.shape)
    matrix = to_matrix(rotvecs)
    parity = 1.0 if (first, second, third) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    sine = np.clip(parity * matrix[..., first, third], -1.0, 1.0)
    angles = np.stack(
        [
            np.arctan2(-parity * matrix[..., second, third], matrix[..., third, third]),
            np.arcsin(sine),
            np.arctan2(-parity * matrix[..., first, second], matrix[..., first, first]),
        ],
        axis=-1,
    )
    locked = np.abs(sine) > 1 - 1e-9
    if np.any(locked):
        from scipy.spatial.transform import Rotation

        with warnings.catch_warnings():  # at gimbal lock scipy picks one of the equal answers: fine
            warnings.simplefilter("ignore", UserWarning)
            angles[locked] = np.radians(Rotation.from_rotvec(rotvecs[locked]).as_euler(order, degrees=True))
    return np.degrees(angles)
