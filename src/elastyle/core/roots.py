"""Clips of a model's skeleton without the joints above its root: exporters that make the pelvis the BVH
ROOT drop a static joint above it (the dataset rig's `joint_Root` above `Hips`). Such a clip is read with
those joints added at rest, and the output is written without them, on the clip's own skeleton.

    with_added_roots      the clip on the model's hierarchy (None where it is not the model's less its roots)
    without_added_roots   a clip on that hierarchy back on the clip's own skeleton
    in_world, below       a joint's local transform below another joint, in the world, and back
"""

from __future__ import annotations

import numpy as np

from elastyle.core.body import same_rest_pose, same_structure
from elastyle.core.motion import Motion
from elastyle.core.rotations import from_matrix, to_matrix
from elastyle.core.skeleton import Skeleton, bare_name
from elastyle.types import FloatArray


def with_added_roots(model: Skeleton, motion: Motion) -> Motion | None:
    """The clip on the model's hierarchy where its skeleton is the model's without the model's first k
    joints, a chain above the clip's root and above the model's pelvis (below it the same hierarchy and
    rest pose, under the same names, the same in another namespace, or others: `core.body.same_structure`):
    those joints added at the origin under the model's names, unrotated and without offsets, so every joint
    of the clip stays where it was. None for any other skeleton."""
    clip = motion.skeleton
    added = model.num_joints - clip.num_joints
    if added <= 0 or added > model.pelvis:
        return None
    chain = np.arange(-1, added - 1)  # each added joint the child of the one before
    below = np.where(clip.parents >= 0, clip.parents + added, added - 1)
    if not (np.array_equal(model.parents[:added], chain) and np.array_equal(model.parents[added:], below)):
        return None
    zeros = np.zeros((added, 3))
    skeleton = Skeleton(
        (*model.names[:added], *clip.names), model.parents, np.concatenate([zeros, clip.offsets]),
        np.concatenate([np.full((added, 3), np.nan), clip.end_sites]), clip.unit_cm,
    )  # fmt: skip
    # the same names, in a namespace or not
    alike = list(map(bare_name, clip.names)) == list(map(bare_name, model.names[added:]))
    if not (same_rest_pose(model, skeleton) if alike else same_structure(model, skeleton)):
        return None
    frames = motion.num_frames
    rotations = np.concatenate([np.zeros((frames, added, 3)), motion.rotations], axis=1)
    translations = np.concatenate([np.zeros((frames, added, 3)), motion.translations], axis=1)
    return Motion(skeleton, rotations, translations, motion.fps)


def without_added_roots(motion: Motion, skeleton: Skeleton) -> Motion:
    """A clip on a model's hierarchy (`with_added_roots`) on `skeleton`, the clip's own: the added joints
    dropped, their world transform taken into the root's rotation and position, so no joint moves."""
    added = motion.skeleton.num_joints - skeleton.num_joints
    rotations, translations = motion.rotations[:, added:].copy(), motion.translations[:, added:].copy()
    if not (np.any(motion.rotations[:, :added]) or np.any(motion.translations[:, :added])):
        return Motion(skeleton, rotations, translations, motion.fps)  # still at the origin: nothing to move
    rotations[:, 0], translations[:, 0] = in_world(motion, added - 1, rotations[:, 0], translations[:, 0])
    return Motion(skeleton, rotations, translations, motion.fps)


def in_world(
    motion: Motion, above: int, rotation: FloatArray, translation: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """A joint's local rotation (T, 3, exp maps) and translation (T, 3) below joint `above` of the clip (T
    frames), in the world: the joint above's world transform taken in."""
    world_rotations, world_positions = motion.world([above])
    turn, origin = world_rotations[:, above], world_positions[:, above]  # (T, 3, 3), (T, 3)
    return from_matrix(turn @ to_matrix(rotation)), origin + np.einsum("tij,tj->ti", turn, translation)


def below(
    motion: Motion, above: int, rotation: FloatArray, translation: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """`in_world` undone: a world rotation (T, 3) and position (T, 3) as local ones below joint `above`."""
    world_rotations, world_positions = motion.world([above])
    inverse = np.swapaxes(world_rotations[:, above], -1, -2)  # (T, 3, 3)
    local = np.einsum("tij,tj->ti", inverse, translation - world_positions[:, above])
    return from_matrix(inverse @ to_matrix(rotation)), local
