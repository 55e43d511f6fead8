"""Analytic two-joint leg IK: hip and knee turned so the ankle reaches a target, the foot's world
orientation kept."""

from __future__ import annotations

import numpy as np

from elastyle.core.rotations import from_matrix, lengths, to_matrix
from elastyle.core.skeleton import Skeleton
from elastyle.types import FloatArray, IntArray


def is_below(skeleton: Skeleton, joint: int, ancestor: int) -> bool:
    while joint > ancestor:
        joint = int(skeleton.parents[joint])
    return joint == ancestor


def _angle(u: FloatArray, v: FloatArray) -> FloatArray:
    """Angles (...) in radians between vectors (..., 3)."""
    cosine = np.sum(u * v, -1) / np.maximum(lengths(u) * lengths(v), 1e-300)
    return np.arccos(np.clip(cosine, -1.0, 1.0))


SOFT_FROM = 0.95  # a hip-ankle distance past this share of the straight leg's length is reached softly
# a knee bent less than this (radians, 180 degrees less its angle) bends, where the IK bends it, in the clip's
# knee plane rather than its own (eased in from straight): the plane of a near-straight leg is noise
CLIP_PLANE_BELOW = np.radians(6.0)


def _soft_reach(wanted: FloatArray, own: FloatArray, thigh: FloatArray, shin: FloatArray) -> FloatArray:
    """The hip-ankle distances (T, F) the IK gives for wanted ones (T, F), with the leg's own (T, F) before.

    Near a straight leg the knee's angle changes fastest with the distance, so a target pulled a few
    millimetres further snapped the knee straight for a frame (169 -> 178 -> 170 degrees). Past `SOFT_FROM`
    of the leg's length the distance approaches the straight leg exponentially (the same slope where it
    starts) and never reaches it; the leg's own distance is kept where that is longer, so a leg that stands
    straight is not bent."""
    straight = thigh + shin
    eps = 1e-9 * straight
    wanted = np.clip(wanted, np.abs(thigh - shin) + eps, straight - eps)
    start = SOFT_FROM * straight
    width = straight - start
    over = np.maximum(wanted - start, 0.0)
    soft = np.where(over > 0, start + width * (1 - np.exp(-over / width)), wanted)
    return np.maximum(soft, np.minimum(wanted, own))


def leg_ik(
    world_rotations: FloatArray,
    positions: FloatArray,
    parents: IntArray,
    chains: IntArray,
    targets: FloatArray,
    frames: IntArray | None = None,
) -> FloatArray:
    """Analytic two-joint IK of F legs at once: local exp maps (T, F, 3, 3) of upper leg, knee and ankle
    putting each ankle on its target, or (n, F, 3, 3) at frames (n,) only (the same values there).

    world_rotations: (T, J, 3, 3); positions: (T, J, 3); parents: (F,) each upper leg's parent (-1: none);
    chains: (F, 3) upper leg, knee, ankle; targets: (T, F, 3).
    The leg is straightened in its own plane (normal (ankle - hip) x (knee - hip)) onto its hip-ankle line,
    bent by the law of cosines to the hip-target distance, and that line swung onto the target (minimal
    arc); the ankle keeps its world rotation, so the foot keeps its orientation. It bends in its own plane,
    a near-straight knee in the clip's knee plane (its frames' normals in the upper leg's frame summed, each
    as long as its knee is bent, so the bent frames decide), eased between the two up to a bend of
    `CLIP_PLANE_BELOW`, and a knee bent against the clip's plane (backwards) in the clip's: a near-straight
    leg's own plane is whichever way the knee strays by a hair. A straightened leg bends exactly in any
    plane through its line. Targets near the straight leg's reach are reached softly (`_soft_reach`), under
    2 % of the leg short.
    """
    upper_world, knee_world, ankle_world = (
        world_rotations[:, chains[:, i]] for i in range(3)
    )  # (T, F, 3, 3)
    hip, knee, ankle = (positions[:, chains[:, i]] for i in range(3))  # (T, F, 3)
    normal = np.cross(ankle - hip, knee - hip)  # (T, F, 3), |hip-ankle| |hip-knee| sin(the hip's angle) long
    size = lengths(normal)
    local_normal = np.einsum("tfji,tfj->tfi", upper_world, normal)  # (T, F, 3) in the upper leg's frame
    clip_normal = np.sum(local_normal, axis=0)  # (F, 3)
    across = np.cross(np.einsum("fj,fji->fi", (knee - hip)[0], upper_world[0]), [1e-3, 1e-2, 1.0])  # (F, 3)
    straight = lengths(clip_normal) <= 1e-6 * np.sum(lengths(ankle - hip) * lengths(knee - hip), axis=0)
    clip_normal = np.where(straight[:, None], across, clip_normal)  # a leg straight throughout: any plane
    if frames is not None:  # the clip's knee plane read, the rest at these frames only
        upper_world, knee_world, ankle_world, hip, knee, ankle, normal, size, targets = (
            values[frames]
            for values in (upper_world, knee_world, ankle_world, hip, knee, ankle, normal, size, targets)
        )
        world_rotations = world_rotations[frames]
    line = (ankle - hip) / np.maximum(lengths(ankle - hip, keepdims=True), 1e-300)  # (T, F, 3)
    hinge = np.einsum("tfij,fj->tfi", upper_world, clip_normal)  # (T, F, 3) the clip's plane, in the world
    hinge -= np.sum(hinge * line, axis=-1, keepdims=True) * line
    hinge /= np.maximum(lengths(hinge, keepdims=True), 1e-300)
    own_normal = np.where((size > 0)[..., None], normal / np.maximum(size, 1e-300)[..., None], hinge)
    # the own plane's share: from the clip's at a straight knee to its own at `CLIP_PLANE_BELOW`, none where the
    # knee bends against the clip's plane (eased off from 60 degrees off it, so no share jumps)
    knee_angle_now = _angle(hip - knee, ankle - knee)  # (T, F) radians, pi straight
    own = np.clip((np.pi - knee_angle_now) / CLIP_PLANE_BELOW, 0.0, 1.0)
    along = np.clip(2 * np.sum(own_normal * hinge, axis=-1), 0.0, 1.0)
    own = (own * own * (3 - 2 * own)) * (along * along * (3 - 2 * along))
    axes = own[..., None] * own_normal + (1 - own[..., None]) * hinge  # within 90 degrees where both count
    axes /= np.maximum(lengths(axes, keepdims=True), 1e-300)  # (T, F, 3), across the hip-ankle line

    thigh, shin = lengths(knee - hip), lengths(ankle - knee)  # (T, F)
    distance = _soft_reach(lengths(targets - hip), lengths(ankle - hip), thigh, shin)
    hip_angle = np.arccos(np.clip((thigh**2 + distance**2 - shin**2) / (2 * thigh * distance), -1, 1))
    knee_angle = np.arccos(np.clip((thigh**2 + shin**2 - distance**2) / (2 * thigh * shin), -1, 1))
    cross = np.cross(ankle - hip, targets - hip)
    swing_axis = cross / np.maximum(lengths(cross), 1e-300)[..., None]
    # straightened in its own plane onto its hip-ankle line, bent about `axes`, and that line swung onto the target
    unbend, unturn, bend, turn, swing = to_matrix(
        np.stack(
            [
                own_normal * (np.pi - knee_angle_now)[..., None],
                own_normal * -_angle(ankle - hip, knee - hip)[..., None],
                axes * (knee_angle - np.pi)[..., None],
                axes * hip_angle[..., None],
                swing_axis * _angle(ankle - hip, targets - hip)[..., None],
            ]
        )
    )  # (T, F, 3, 3) each
    # in the world, in order: the knee unbent, the thigh turned onto the line (carrying the shin), the knee bent,
    # the thigh turned off it, the line swung
    new_upper = swing @ turn @ unturn @ upper_world
    new_knee = swing @ turn @ bend @ unturn @ unbend @ knee_world
    parent_world = np.where(
        (parents >= 0)[:, None, None], world_rotations[:, np.maximum(parents, 0)], np.eye(3)
    )  # (T, F, 3, 3)
    local = [np.swapaxes(parent_world, -1, -2) @ new_upper, np.swapaxes(new_upper, -1, -2) @ new_knee]
    local.append(np.swapaxes(new_knee, -1, -2) @ ankle_world)
    return from_matrix(np.stack(local, axis=2))
