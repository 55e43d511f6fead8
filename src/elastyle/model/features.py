"""Motion <-> per-frame features (T, C) for learning, and the root path that is not transferred.

Channels per frame, in this order (docs/method.md, "Features"):
  * every joint below the pelvis: exp map of ref_j^-1 R_j (local rotation relative to a reference),
    3 channels each, kept continuous along time;
  * the pelvis: exp map of ref^-1 (heading^-1 R_world), its tilt and roll relative to the heading (3);
  * the pelvis's sway: its horizontal offset from the smoothed path, in the heading frame (2, file units);
  * the pelvis's height above the ground plane y = 0 (1, file units).
What is not transferred, the `RootPath`: the smoothed horizontal path and heading of the pelvis (smoothed
so that steady travel and turning are kept to the clip's ends, `core.smoothing.smooth_path`), and the
joints above it, all from the content.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from elastyle.core.body import heading_yaw, pelvis_forward_local, yaw_matrices
from elastyle.core.motion import Motion
from elastyle.core.resample import interpolate_rows
from elastyle.core.rotations import (
    continuous_quats,
    from_matrix,
    from_quat,
    matrix_to_quat,
    multiply,
    quat_multiply,
    slerp_resample,
    to_matrix,
    to_quat,
)
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import smooth_path
from elastyle.types import FloatArray, IntArray

PATH_SMOOTHING_S = 0.25  # Gaussian sigma separating the path (kept) from the sway (transferred)


@dataclass(frozen=True, eq=False)
class FeatureSpec:
    """How a skeleton's clips become features: which joints, and their reference rotations.

    reference_rotations: (J, 3) exp maps; for the pelvis it is relative to the heading.
    forward_local: (3,) the pelvis's facing direction in its own frame.
    """

    skeleton: Skeleton
    reference_rotations: FloatArray
    forward_local: FloatArray

    @cached_property
    def pose_joints(self) -> IntArray:
        """Joints whose rotations are features (J_pose,): the pelvis and everything below it."""
        pelvis = self.skeleton.pelvis
        below = [pelvis]
        for joint in range(pelvis + 1, self.skeleton.num_joints):
            if self.skeleton.parents[joint] in below:
                below.append(joint)
        return np.array(below, dtype=np.int64)

    @cached_property
    def above_joints(self) -> IntArray:
        """Joints above the pelvis (A,): not features, carried from the content in the `RootPath`."""
        above = np.ones(self.skeleton.num_joints, dtype=bool)
        above[self.pose_joints] = False
        return np.flatnonzero(above)

    @property
    def num_channels(self) -> int:
        return 3 * len(self.pose_joints) + 3

    def channel_names(self) -> list[str]:
        names = [f"{self.skeleton.names[j]}.r{axis}" for j in self.pose_joints for axis in "xyz"]
        return names + ["pelvis.sway_x", "pelvis.sway_z", "pelvis.height"]

    @staticmethod
    def fit(motions: Sequence[Motion]) -> FeatureSpec:
        """Reference rotations as each joint's mean rotation over the clips (sign-aligned quaternion mean)."""
        skeleton = motions[0].skeleton
        forward_local = pelvis_forward_local(skeleton)
        identity = FeatureSpec(skeleton, np.zeros((skeleton.num_joints, 3)), forward_local)
        quats = np.concatenate([identity._heading_relative_quats(m)[0] for m in motions])  # (T, J, 4)
        quats = quats * np.where(quats[..., 3:] < 0, -1.0, 1.0)
        mean = quats.mean(axis=0)  # (J, 4) dominant direction
        quats = quats * np.where(np.sum(quats * mean, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        mean = quats.mean(axis=0)
        return FeatureSpec(skeleton, from_quat(mean), forward_local)

    def _heading_relative_quats(self, motion: Motion) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Local rotations as quaternions (T, J, 4) with the pelvis's made heading-relative; heading yaw (T,);
        pelvis positions (T, 3)."""
        pelvis = self.skeleton.pelvis
        world_rotations, world_positions = motion.world([pelvis])
        yaw = smooth_path(
            heading_yaw(world_rotations[:, pelvis], self.forward_local), PATH_SMOOTHING_S * motion.fps
        )
        quats = to_quat(motion.rotations)
        tilt = np.swapaxes(yaw_matrices(yaw), -1, -2) @ world_rotations[:, pelvis]  # (T, 3, 3)
        quats[:, pelvis] = matrix_to_quat(tilt)
        return quats, yaw, world_positions[:, pelvis]

    def encode(self, motion: Motion) -> tuple[FloatArray, RootPath]:
        """Features (T, C) and the root path of a clip."""
        quats, yaw, pelvis_positions = self._heading_relative_quats(motion)
        joints = self.pose_joints
        relative = quat_multiply(
            to_quat(-self.reference_rotations[joints]), quats[:, joints]
        )  # (T, J_pose, 4)
        quats = continuous_quats(relative, axis=0)
        quats *= np.where(quats[:1, :, 3:] < 0, -1.0, 1.0)  # start on the identity's hemisphere
        path = smooth_path(pelvis_positions[:, [0, 2]], PATH_SMOOTHING_S * motion.fps)  # (T, 2) x, z
        offset = np.zeros_like(pelvis_positions)
        offset[:, [0, 2]] = pelvis_positions[:, [0, 2]] - path
        sway = np.einsum("tji,tj->ti", yaw_matrices(yaw), offset)[:, [0, 2]]  # (T, 2) heading frame
        features = np.concatenate(
            [from_quat(quats).reshape(motion.num_frames, -1), sway, pelvis_positions[:, 1:2]], axis=1
        )
        above = self.above_joints
        root = RootPath(
            path,
            yaw,
            motion.rotations[:, above],
            motion.translations[:, above],
            motion.translations[:, joints],
        )
        return features, root

    def decode(self, features: FloatArray, root: RootPath, fps: float) -> Motion:
        """A clip from features (T, C) and a root path of the same length T."""
        num_frames = features.shape[0]
        if root.path.shape[0] != num_frames:
            raise ValueError(f"root path has {root.path.shape[0]} frames, features {num_frames}")
        joints = self.pose_joints
        pelvis = self.skeleton.pelvis
        num_pose = len(joints)
        relative = features[:, : 3 * num_pose].reshape(num_frames, num_pose, 3)
        rotations = np.zeros((num_frames, self.skeleton.num_joints, 3))
        translations = np.zeros_like(rotations)
        above = self.above_joints
        rotations[:, above] = root.above_rotations
        translations[:, above] = root.above_translations
        rotations[:, joints] = multiply(self.reference_rotations[joints], relative)
        translations[:, joints] = root.joint_translations
        # The pelvis: world rotation = heading x tilt, world position = path + sway, height from features.
        yaw = yaw_matrices(root.yaw)  # (T, 3, 3)
        world_pelvis = yaw @ to_matrix(rotations[:, pelvis])
        sway = np.zeros((num_frames, 3))
        sway[:, [0, 2]] = features[:, 3 * num_pose : 3 * num_pose + 2]
        position = yaw @ sway[..., None]  # (T, 3, 1)
        position = position[..., 0]
        position[:, [0, 2]] += root.path
        position[:, 1] = features[:, -1]
        parent = self.skeleton.parents[pelvis]
        if parent >= 0:
            partial = Motion(self.skeleton, rotations, translations, fps)
            parent_rotations, parent_positions = (a[:, parent] for a in partial.world([parent]))
            world_pelvis = np.swapaxes(parent_rotations, -1, -2) @ world_pelvis
            position = np.einsum("tji,tj->ti", parent_rotations, position - parent_positions)
        rotations[:, pelvis] = from_matrix(world_pelvis)
        translations[:, pelvis] = position
        return Motion(self.skeleton, rotations, translations, fps)


class RootPath(NamedTuple):
    """What a transfer keeps from the content, per frame.

    path: (T, 2) smoothed horizontal pelvis position (x, z), file units.
    yaw: (T,) smoothed heading, radians, unwrapped.
    above_rotations, above_translations: (T, A, 3) joints above the pelvis, as in the content.
    joint_translations: (T, J_pose, 3) local translations of the feature joints (offsets, or animated
        position channels), as in the content.
    """

    path: FloatArray
    yaw: FloatArray
    above_rotations: FloatArray
    above_translations: FloatArray
    joint_translations: FloatArray

    @property
    def num_frames(self) -> int:
        return int(self.path.shape[0])

    def repeated(self, times: int) -> RootPath:
        """The path `times` times end to end (T * times frames): several clips decoded on it as one."""
        return RootPath(*(np.concatenate([values] * times) for values in self))

    def sample(self, frame_times: FloatArray) -> RootPath:
        """The path at fractional frame indices (N,), linear between frames and held past the ends."""
        frame_times = np.clip(frame_times, 0.0, self.num_frames - 1)

        def blend(values: FloatArray) -> FloatArray:
            return interpolate_rows(values, frame_times)

        return RootPath(
            blend(self.path),
            blend(self.yaw),
            slerp_resample(self.above_rotations, frame_times),  # a root-motion joint turns with the heading
            blend(self.above_translations),
            blend(self.joint_translations),
        )
