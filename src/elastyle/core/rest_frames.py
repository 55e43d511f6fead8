"""A clip whose joints' axes are all turned alike from a model's: some exporters write a rig in their own
axes (Z up), turning every bone offset and every joint's local frame. The same motion is read in the model's
axes (every frame turned back, so each local rotation means what the model's does) and written back in the
clip's.

    AXIS_TURNS     the 23 quarter and half turns that map the axes onto themselves (the identity left out)
    frames_turned  the same motion with every joint's axes turned
"""

from __future__ import annotations

import itertools

import numpy as np

from elastyle.core.body import find_limbs, pelvis_forward_local
from elastyle.core.joint_tree import folded_joints
from elastyle.core.motion import Motion
from elastyle.core.parts import subtree
from elastyle.core.rotations import from_matrix, least_turn, to_matrix
from elastyle.core.skeleton import Skeleton
from elastyle.types import FloatArray, IntArray


def _axis_turns() -> tuple[FloatArray, ...]:
    """Every rotation (3, 3) that takes each axis to an axis, either way, but the identity (23 of them); the
    quarter turns about X first (+Z up to +Y up and back, the commonest)."""
    turns = [np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])]
    turns.append(turns[0].T)
    for order in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            turn = np.zeros((3, 3))
            turn[range(3), order] = signs
            if np.linalg.det(turn) > 0 and not any(
                np.array_equal(turn, known) for known in [np.eye(3), *turns]
            ):
                turns.append(turn)
    return tuple(turns)


AXIS_TURNS = _axis_turns()


def frames_turned(motion: Motion, turn: FloatArray) -> Motion:
    """The same world motion (T frames, J joints) with every joint's axes turned by `turn` (3, 3): bone
    offsets, End Sites and joints' local translations turned, each joint's local rotation R becoming
    turn R turn^T, the root's R turn^T (its position stays in the world's axes)."""
    skeleton = motion.skeleton
    turned = Skeleton(
        skeleton.names,
        skeleton.parents,
        skeleton.offsets @ turn.T,
        skeleton.end_sites @ turn.T,
        skeleton.unit_cm,
    )
    matrices = to_matrix(motion.rotations)  # (T, J, 3, 3)
    matrices[:, 1:] = turn @ matrices[:, 1:] @ turn.T
    matrices[:, 0] = matrices[:, 0] @ turn.T
    translations = motion.translations.copy()
    translations[:, 1:] = translations[:, 1:] @ turn.T
    return Motion(turned, from_matrix(matrices), translations, motion.fps)


def rest_rotations(clip: Skeleton, reference: Skeleton, joints: IntArray, first: int = 0) -> FloatArray:
    """(J, 3, 3) per clip joint, the rotation D that takes the reference's rest bones below the matching
    reference joint to the clip's (directions only: the best fit over its children, their offsets' or its
    End Site's where it has none, least squares where several); the identity where a joint has no bone
    below it or no reference joint (extra joints), the one above's for a joint between two matched ones (a
    chain read as one bone turns as one). The pelvis's and the joints' above it are not bones: their
    position channels place them. joints: (J_ref - first,) each reference joint's clip
    joint from `first` on (`core.extra_joints.model_joints_in`)."""
    rest = np.broadcast_to(np.eye(3), (clip.num_joints, 3, 3)).copy()
    for ours, theirs in zip(range(first, reference.num_joints), joints.tolist()):
        pairs = _bone_pairs(clip, reference, joints, first, ours, theirs, np.eye(3))
        if pairs:
            rest[theirs] = best_rotation(*(np.array(side) for side in zip(*pairs)))
    # top down: a chain read as one bone turns as the joint above it
    for joint in folded_joints(clip, joints):
        rest[joint] = rest[clip.parents[joint]]
    return rest


def rest_rotations_from_pose(
    clip: Skeleton, reference: Skeleton, joints: IntArray, pose: FloatArray, first: int = 0
) -> tuple[FloatArray, FloatArray]:
    """`rest_rotations` for a clip whose rest stands as a body does (a T- or an A-pose, its joints' frames the
    world's, as most rigs are exported): per clip joint, D starts from the reference joint's world rotation in
    a typical pose of the reference's (`pose`, (J_ref, 3, 3): where its bones point and how they twist about
    themselves), the whole body turned by the turn that best takes that pose's trunk and legs onto the clip's
    rest (its facing and up axis), then as its parent's was (an arm raised to a T raises the forearm and the
    hand), then by the turn that best takes the joint's bones below it there onto the clip's. Returns the
    rotations (J, 3, 3) and, per clip joint, how far that last turn goes (J,) in degrees (0 for joints it
    does not turn)."""
    rest = np.broadcast_to(np.eye(3), (clip.num_joints, 3, 3)).copy()
    degrees = np.zeros(clip.num_joints)
    trunk_and_legs = set(range(reference.num_joints))
    for arm in find_limbs(reference).arm_roots.tolist():
        trunk_and_legs -= set(subtree(reference, arm))

    def pairs_of(ours: int, theirs: int, turn: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
        return _bone_pairs(clip, reference, joints, first, ours, theirs, turn)

    matched = list(zip(range(first, reference.num_joints), joints.tolist()))
    body = [
        pair
        for ours, theirs in matched
        if ours in trunk_and_legs
        for pair in pairs_of(ours, theirs, pose[ours])
    ]
    whole = best_rotation(*(np.array(side) for side in zip(*body))) if len(body) >= 2 else np.eye(3)
    forward = whole @ pose[reference.pelvis] @ pelvis_forward_local(reference)  # (3,) the body's, in the clip
    turns: dict[int, FloatArray] = {}  # per reference joint, its turn from the pose, its parent's included
    for ours, theirs in matched:
        # turned as its parent first (a forearm on an arm raised to a T), then as its own bones ask
        posed = turns.get(int(reference.parents[ours]), np.eye(3)) @ whole @ pose[ours]
        pairs = pairs_of(ours, theirs, posed)
        own = _own_turn(pairs, forward) if pairs else np.eye(3)
        rest[theirs] = own @ posed
        turns[ours] = rest[theirs] @ (whole @ pose[ours]).T
        degrees[theirs] = rest_degrees(own[None])[0]
    for joint in folded_joints(clip, joints):
        rest[joint] = rest[clip.parents[joint]]
    return rest, degrees


# a bone whose direction across the body's forward axis is at least this share of its length, and which turns
# about that axis by at least `SWING_DEGREES` from the typical pose, turns about that axis first (an arm raised
# sideways: the turn a T-pose makes), its least turn after that; otherwise at once
ACROSS_SHARE = 0.3
SWING_DEGREES = 20.0


def _own_turn(pairs: list[tuple[FloatArray, FloatArray]], forward: FloatArray) -> FloatArray:
    """The turn (3, 3) that best takes the bones of a joint in a typical pose (each pair's first) onto the
    clip's (its second): for one bone that lies across the body's `forward` axis (3,) in both and turns far
    about it, the turn about that axis that brings it into the clip's bone's plane first (the way an arm is
    raised to a T, with no twist about itself), then the least turn; else the least turn, or the best fit for
    several bones."""
    if len(pairs) == 1:
        ours, theirs = pairs[0]
        axis = forward / np.linalg.norm(forward)
        across = [bone - (bone @ axis) * axis for bone in (ours, theirs)]
        sizes = [float(np.linalg.norm(bone)) for bone in (ours, theirs)]
        if all(np.linalg.norm(a) >= ACROSS_SHARE * size for a, size in zip(across, sizes)):
            angle = np.arctan2(float(np.cross(across[0], across[1]) @ axis), float(across[0] @ across[1]))
            if abs(np.degrees(angle)) >= SWING_DEGREES:
                swing = to_matrix(axis * angle)
                return best_rotation((swing @ ours)[None], theirs[None]) @ swing
    return best_rotation(*(np.array(side) for side in zip(*pairs)))


def _bone_pairs(
    clip: Skeleton,
    reference: Skeleton,
    joints: IntArray,
    first: int,
    ours: int,
    theirs: int,
    turn: FloatArray,
) -> list[tuple[FloatArray, FloatArray]]:
    """The bones below the reference joint `ours`, turned by `turn` (3, 3), each with the clip's below its
    match `theirs` (3,) and (3,) (the pelvis's and above's children aside: placed, not bones); its End Sites
    where it has no children; bones of no length left out."""
    kids = [k for k in reference.children(ours) if k > max(first, reference.pelvis)]
    found = [(turn @ reference.offsets[k], clip.offset_from(theirs, joints[k - first])) for k in kids]
    if not kids and not (np.isnan(reference.end_sites[ours, 0]) or np.isnan(clip.end_sites[theirs, 0])):
        found = [(turn @ reference.end_sites[ours], clip.end_sites[theirs])]
    return [(a, b) for a, b in found if np.linalg.norm(a) > 1e-9 and np.linalg.norm(b) > 1e-9]


def best_rotation(sources: FloatArray, targets: FloatArray) -> FloatArray:
    """The rotation (3, 3) that best takes the directions of sources (K, 3) to those of targets (K, 3): the
    least turn for one, the least squares fit (Kabsch) for several."""
    a = sources / np.linalg.norm(sources, axis=1, keepdims=True)
    b = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    if len(a) == 1:
        return to_matrix(least_turn(a[0], b[0]))
    u, _, vt = np.linalg.svd(b.T @ a)
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    return u @ fix @ vt


def rest_degrees(rest: FloatArray) -> FloatArray:
    """(J,) how far each rotation (J, 3, 3) turns, degrees."""
    cosine = (np.trace(rest, axis1=1, axis2=2) - 1) / 2
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def frames_reposed(motion: Motion, rest: FloatArray, inverse: bool = False) -> Motion:
    """The same world motion (T frames, J joints) on another rest pose, each joint's frame turned by its
    `rest` (J, 3, 3) rotation D (`rest_rotations`): local rotations R become D_parent^T R D (the root's R D),
    local translations and bone offsets D_parent^T t, End Sites D^T e. inverse: back (R -> D_parent R D^T)."""
    skeleton = motion.skeleton
    parent_rest = np.where(
        (skeleton.parents >= 0)[:, None, None], rest[np.maximum(skeleton.parents, 0)], np.eye(3)
    )  # (J, 3, 3) each joint's parent's, the identity for the root
    before, after = (
        (parent_rest, rest) if inverse else (np.swapaxes(parent_rest, 1, 2), np.swapaxes(rest, 1, 2))
    )
    # forward: D_p^T R D, written as before @ R @ after^T with after = D^T; inverse: D_p R D^T
    matrices = before @ to_matrix(motion.rotations) @ np.swapaxes(after, 1, 2)
    offsets = np.einsum("jab,jb->ja", before, skeleton.offsets)
    ends = np.einsum("jab,jb->ja", after, skeleton.end_sites)
    translations = np.einsum("jab,tjb->tja", before, motion.translations)
    root = skeleton.parents < 0
    translations[:, root] = motion.translations[:, root]  # placed in the world
    offsets[root] = skeleton.offsets[root]
    turned = Skeleton(skeleton.names, skeleton.parents, offsets, ends, skeleton.unit_cm)
    return Motion(turned, from_matrix(matrices), translations, motion.fps)
