"""Clips of a model's skeleton with joints the model lacks (fingers, props, tips exported as joints, a third
spine joint, a twist joint mid-arm), or its joints listed in another order. Every model joint is in the clip
under its own name (or the same name after a `namespace:` prefix), or found by the hierarchy, below the
match of its model parent; the clip's other joints hang below model joints (or above the model's top joint,
an exporter's `Armature`: their world transform is taken into it), or lie between a model joint and its
model parent (folded: the model reads the chain between the two as one bone, its rotations and translations
composed, so every model joint moves in the world as in the clip). The transfer reads the model's joints
alone, in the model's order; the output carries the others as the content performs them, at the output's
moments, and lists every joint in the clip's order.

    model_joints_in       (J_model,) each model joint's index in the clip, or None (under other names:
                          `core.joint_tree`, which also finds the joints between two of the model's)
    without_extra_joints  the clip on the model's joints alone
    with_extra_joints     an output on the model's joints, back on the clip's whole skeleton
"""

from __future__ import annotations

import numpy as np

from elastyle.core.joint_tree import by_hierarchy, folded_chains
from elastyle.core.motion import Motion
from elastyle.core.roots import below, in_world
from elastyle.core.rotations import from_matrix, to_matrix
from elastyle.core.skeleton import Skeleton, bare_name
from elastyle.types import FloatArray, IntArray


def model_joints_in(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """(J',) the clip index of each model joint the clip has, in the model's order, where the clip is the
    model's skeleton (less the static joints above its root that some exporters drop: `core.roots`) with
    joints added below model joints, or its joints listed in another order; None for any other clip, and
    for one that lists just the model's joints in the model's order.

    Names match exactly, or else without namespaces. Each matched joint's nearest matched ancestor in the
    clip must be the match of its model parent (joints between the two are folded), and the model's joints
    the clip lacks must be a chain above its root. Where no names match, joints under other names are
    matched by the hierarchy (`core.joint_tree.by_hierarchy`), for the caller to check as the model's skeleton under other
    names (`core.body.same_structure`)."""
    key = (_skeleton_key(model), _skeleton_key(clip))
    if key not in _MATCHES:
        if len(_MATCHES) >= MATCHES_KEPT:
            _MATCHES.clear()
        joints = _model_joints_in(model, clip)
        if joints is not None:
            joints.setflags(write=False)  # shared by every caller
        _MATCHES[key] = joints
        return joints
    return _MATCHES[key]


# `model_joints_in` per model skeleton and clip skeleton, read once (the reading by the hierarchy searches; a
# batch's clips of one rig share it), up to this many
MATCHES_KEPT = 256
_MATCHES: dict[tuple[bytes, bytes], IntArray | None] = {}


def _skeleton_key(skeleton: Skeleton) -> bytes:
    """What a reading of the skeleton depends on: its names, parents, offsets and End Sites."""
    return repr(skeleton.names).encode() + b"".join(
        np.ascontiguousarray(array).tobytes()
        for array in (skeleton.parents, skeleton.offsets, skeleton.end_sites)
    )


def _model_joints_in(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """`model_joints_in`, not looked up."""
    by_name = _by_name(model, clip)
    joints = by_name if by_name is not None else by_hierarchy(model, clip)
    if joints is None:
        return None
    in_order = len(joints) == clip.num_joints and np.array_equal(joints, np.arange(len(joints)))
    return None if in_order else joints


def _by_name(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """`model_joints_in` by joint names, or None."""
    for missing, found in _named(model, clip):
        joints = np.array(found, dtype=np.int64)
        index = {int(joint): at for at, joint in enumerate(joints)}
        parents = [int(p) - missing if p >= missing else -1 for p in model.parents[missing:]]
        if all(_matched_parent(clip, joint, index) == parent for joint, parent in zip(joints, parents)):
            return joints
    return None


def _matched_parent(clip: Skeleton, joint: int, index: dict[int, int]) -> int:
    """The place in `index` (clip joint -> its place among the matched joints) of the clip joint's nearest
    matched ancestor, -1 where none is matched."""
    above = int(clip.parents[joint])
    while above >= 0 and above not in index:
        above = int(clip.parents[above])
    return index.get(above, -1)


def _named(model: Skeleton, clip: Skeleton) -> list[tuple[int, list[int]]]:
    """The ways a clip holds the model's joints by name (exactly, then without namespaces): the count of the
    model's leading joints it lacks (a static chain above the root, at most up to the pelvis) and each other
    model joint's clip index. None of a clip with two joints of one name or lacking any other model joint."""
    ways = []
    for key in (str, bare_name):
        where = {key(name): joint for joint, name in enumerate(clip.names)}
        if len(where) < clip.num_joints:
            continue  # two joints of one name: no reading by name
        found = [where.get(key(name)) for name in model.names]
        missing = next((at for at, joint in enumerate(found) if joint is not None), len(found))  # leading
        if missing <= model.pelvis and None not in found[missing:]:
            ways.append((missing, [int(joint) for joint in found[missing:] if joint is not None]))
    return ways


def without_extra_joints(motion: Motion, joints: IntArray) -> Motion:
    """The clip (T, J frames and joints) on its joints `joints` (J',) alone, in that order: their local
    rotations and translations unchanged, as the model reads them, but for the first's where extra joints
    lie above it (an exporter's `Armature` above the hips): their world transform taken into it, and for a
    joint with joints folded above it (`core.joint_tree.folded_chains`): their transforms composed into its own, its offset
    their offsets added, so no joint moves in the world."""
    skeleton = motion.skeleton
    index = {int(joint): at for at, joint in enumerate(joints)}
    parents = np.array([_matched_parent(skeleton, joint, index) for joint in joints], dtype=np.int64)
    ends = skeleton.end_sites[joints].copy()
    for at, joint in enumerate(joints):  # a joint whose children are all extra: their mean place as its tip
        children = np.flatnonzero(skeleton.parents == joint)
        if np.isnan(ends[at, 0]) and len(children) and not np.any(parents == at):
            ends[at] = skeleton.offsets[children].mean(axis=0)
    offsets = skeleton.offsets[joints].copy()
    rotations, translations = motion.rotations[:, joints], motion.translations[:, joints]
    for at, chain in folded_chains(skeleton, joints):
        offsets[at] = skeleton.offset_from(int(skeleton.parents[chain[0]]), int(joints[at]))
        turn, shift = _composed(motion, chain)  # (T, 3, 3), (T, 3)
        rotations[:, at] = from_matrix(turn @ to_matrix(rotations[:, at]))
        translations[:, at] = shift + np.einsum("tij,tj->ti", turn, translations[:, at])
    subset = Skeleton(tuple(skeleton.names[j] for j in joints), parents, offsets, ends, skeleton.unit_cm)
    above = int(skeleton.parents[joints[0]])
    if above >= 0:  # into the world's frame: the extra joints above multiplied in
        rotations[:, 0], translations[:, 0] = in_world(motion, above, rotations[:, 0], translations[:, 0])
    return Motion(subset, rotations, translations, motion.fps)


def with_extra_joints(motion: Motion, clip_at: Motion, joints: IntArray) -> Motion:
    """An output on the clip's joints `joints` (N, J' frames and joints) on the clip's whole skeleton: the
    other joints as `clip_at` (the clip at the output's N moments) has them, the first joint, placed in the
    world, put back below the extra joints above it, and a joint with folded joints above it turned so that
    it turns in the world as the output's, below them as `clip_at` has them (`without_extra_joints`)."""
    rotations, translations = clip_at.rotations.copy(), clip_at.translations.copy()
    rotations[:, joints] = motion.rotations
    translations[:, joints] = motion.translations
    for at, chain in folded_chains(clip_at.skeleton, joints):  # the composition undone, below the chain as
        turn, shift = _composed(
            clip_at, chain
        )  # the clip has it: the output's own place (the hips' path) kept
        back = np.swapaxes(turn, -1, -2)  # (N, 3, 3)
        joint = joints[at]
        rotations[:, joint] = from_matrix(back @ to_matrix(motion.rotations[:, at]))
        translations[:, joint] = np.einsum("tij,tj->ti", back, motion.translations[:, at] - shift)
    above = int(clip_at.skeleton.parents[joints[0]])
    if above >= 0:  # from the world's frame into the frame of the joint above
        top = joints[0]
        rotations[:, top], translations[:, top] = below(
            clip_at, above, motion.rotations[:, 0], motion.translations[:, 0]
        )
    return Motion(clip_at.skeleton, rotations, translations, motion.fps)


def _composed(motion: Motion, chain: list[int]) -> tuple[FloatArray, FloatArray]:
    """The transform of a chain of joints (top down, each the next one's parent) in the frame of the first's
    parent: rotation matrices (T, 3, 3) and the last joint's position (T, 3)."""
    turn = np.broadcast_to(np.eye(3), (motion.num_frames, 3, 3))
    shift = np.zeros((motion.num_frames, 3))
    for joint in chain:
        shift = shift + np.einsum("tij,tj->ti", turn, motion.translations[:, joint])
        turn = turn @ to_matrix(motion.rotations[:, joint])
    return turn, shift
