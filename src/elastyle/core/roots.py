"""Clips of a model's skeleton without the joints above its root: exporters that make the pelvis the BVH
ROOT drop a static joint above it (the dataset rig's `joint_Root` above `Hips`). Such a clip is read with
those joints added at rest, and the output is written without them, on the clip's own skeleton.

    with_added_roots      the clip on the model's hierarchy (None where it is not the model's less its roots)
    without_added_roots   a clip on that hierarchy back on the clip's own skeleton
    in_world, below       a joint's local transform below another joint, in the world, and back
    moved_joints          which joints leave their rest offsets (they need position channels)
    root_carries_pelvis   an output's change to the pelvis's place carried by a root-motion joint above it
"""

from __future__ import annotations

import numpy as np

from elastyle.core.body import same_rest_pose, same_structure
from elastyle.core.motion import Motion
from elastyle.core.rotations import from_matrix, to_matrix
from elastyle.core.skeleton import Skeleton, bare_name
from elastyle.types import FloatArray


def with_added_roots(model: Skeleton, motion: Motion, rest_pose: bool = True) -> Motion | None:
    """The clip on the model's hierarchy where its skeleton is the model's without the model's first k
    joints, a chain above the clip's root and above the model's pelvis (below it the same hierarchy and
    rest pose, unless `rest_pose` is False, under the same names, the same in another namespace, or others:
    `core.body.same_structure`): those joints added at the origin under the model's names, unrotated and
    without offsets, so every joint of the clip stays where it was. None for any other skeleton."""
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
    if not (
        (same_rest_pose(model, skeleton) or not rest_pose)
        if alike
        else same_structure(model, skeleton, rest_pose)
    ):
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


# a joint whose translations stay this close to its offset (a share of the rig's size) has not moved
MOVED_OF_SIZE = 1e-3


def moved_joints(motion: Motion, joints: list[int]) -> list[int]:
    """Those of `joints` whose local translation leaves its rest offset in some frame by more than
    `MOVED_OF_SIZE` of the rig's size: a joint that moves (a root-motion joint, a pelvis with position
    channels). A mirrored clip's joints take the other side's offsets, which a captured rig's slight asymmetry
    leaves up to 0.4 mm apart (the dataset's legs): within the tolerance they have not moved."""
    if not joints or not motion.num_frames:
        return []
    away = np.abs(motion.translations[:, joints] - motion.skeleton.offsets[joints])  # (T, K, 3)
    rest = motion.skeleton.rest_positions()
    tolerance = max(1e-6, MOVED_OF_SIZE * float(np.max(np.ptp(rest, axis=0))))
    return [joint for joint, moves in zip(joints, np.any(away > tolerance, axis=(0, 2))) if moves]


def root_motion_joint(content: Motion) -> int | None:
    """The joint above the pelvis, nearest it, whose translation moves in the clip (`moved_joints`): a game
    rig's root-motion joint carrying the ground path; None where every joint above the pelvis stays put."""
    skeleton = content.skeleton
    chain = skeleton.with_ancestors([skeleton.pelvis]).tolist()  # parents first, the pelvis last
    movers = moved_joints(content, chain[-2::-1])  # the joints above it, nearest first
    return movers[0] if movers else None


def root_carries_pelvis(motion: Motion, content_at: Motion, root: int) -> Motion:
    """An output (T frames, +Y up) whose content moves `root`, a joint above the pelvis (`root_motion_joint`):
    the change the transfer made to the pelvis's place (the foot clean-up's root following the stride), taken
    from the pelvis's local translation into the root's, so the root goes along with the body instead of
    staying on the content's path. All of it where the content's pelvis does not move of its own (a rig whose
    root carries every translation: the output keeps the file's channels), else its horizontal part (the root
    stays on the ground). No joint's world place changes. content_at: the content at the output's T moments,
    on the same skeleton."""
    skeleton = motion.skeleton
    pelvis = skeleton.pelvis
    parent = int(skeleton.parents[pelvis])
    turn = motion.world([parent])[0][:, parent]  # (T, 3, 3) the pelvis's parent in the world
    change = np.einsum(
        "tij,tj->ti", turn, motion.translations[:, pelvis] - content_at.translations[:, pelvis]
    )  # (T, 3) the pelvis's change of place, world
    own_moves = bool(moved_joints(content_at, [pelvis]))
    if own_moves:
        change[:, 1] = 0.0
    translations = motion.translations.copy()
    over_root = int(skeleton.parents[root])
    if over_root < 0:  # the top root: its translation is in the world
        translations[:, root] += change
    else:  # in its parent's frame
        translations[:, root] += np.einsum("tji,tj->ti", motion.world([over_root])[0][:, over_root], change)
    if own_moves:
        translations[:, pelvis] -= np.einsum("tji,tj->ti", turn, change)
    else:
        translations[:, pelvis] = content_at.translations[:, pelvis]
    return Motion(skeleton, motion.rotations, translations, motion.fps)
