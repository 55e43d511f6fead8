"""Mirroring a clip across the body's sagittal plane: left and right swap, the world reflects across X.

For a joint j with partner m(j), the mirrored world rotation is M W_m(j) A_j, where M = diag(-1, 1, 1)
reflects the world and A_j is an improper signed permutation in j's local frame that maps j's child
offsets onto its partner's. Rigs differ in how the right side's local axes relate to the left's, and a
limb's offsets leave a twist about its bone open, so among the A_j that fit the offsets the mean pose of the
clip's most symmetric frames chooses (a one-handed wave's hands-down start and end, not its raised arm),
the parent's A breaking ties. A_m(j) = A_j^T, so mirroring twice is the identity.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from elastyle.core.body import heading_yaw, pelvis_forward_local, yaw_matrices
from elastyle.core.motion import Motion
from elastyle.core.parts import subtree
from elastyle.core.roots import moved_joints
from elastyle.core.rotations import from_matrix
from elastyle.core.skeleton import Skeleton, check_mirrorable
from elastyle.types import FloatArray, IntArray

_REFLECT_X = np.diag([-1.0, 1.0, 1.0])
# the reflections that map a joint's offsets onto its partner's within this (per vector, relative to its length)
# all fit; only among them do the parent's reflection and the mean pose choose
OFFSET_TOLERANCE = 0.2
SHORTEST_VECTOR_OF_SIZE = 0.02  # offsets shorter than this share of the rig's longest do not choose
SYMMETRIC_SHARE = 0.1  # the share of a clip's frames, its most symmetric, whose mean pose chooses among them


def _improper_signed_permutations() -> FloatArray:
    candidates = []
    for permutation in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            matrix = np.zeros((3, 3))
            matrix[np.arange(3), permutation] = signs
            if np.linalg.det(matrix) < 0:
                candidates.append(matrix)
    return np.array(candidates)  # (24, 3, 3)


_CANDIDATES = _improper_signed_permutations()


def _child_vectors(skeleton: Skeleton, joint: int, partner: IntArray) -> tuple[FloatArray, FloatArray]:
    """Offsets (K, 3) of a joint's children and End Site, and of their mirror partners."""
    children = skeleton.children(joint)
    ours = [skeleton.offsets[c] for c in children]
    theirs = [skeleton.offsets[partner[c]] for c in children]
    if not np.any(np.isnan(skeleton.end_sites[joint])):
        ours.append(skeleton.end_sites[joint])
        theirs.append(skeleton.end_sites[partner[joint]])
    return np.array(ours).reshape(-1, 3), np.array(theirs).reshape(-1, 3)


def local_reflections(motion: Motion, partner: IntArray) -> FloatArray:
    """The per-joint reflections A (J, 3, 3) described in the module docstring."""
    skeleton = motion.skeleton
    world_rotations, world_positions = motion.world()
    yaw = heading_yaw(world_rotations[:, skeleton.pelvis], pelvis_forward_local(skeleton))
    turns = yaw_matrices(yaw)  # (T, 3, 3)
    relative = np.einsum("tji,tkjl->tkil", turns, world_rotations)  # (T, J, 3, 3) heading frame
    mean_pose = relative[_symmetric_frames(motion, partner, turns, world_positions)].mean(axis=0)  # (J, 3, 3)
    scale = max(float(np.abs(skeleton.offsets).max()), 1e-9)
    reflections = np.zeros((skeleton.num_joints, 3, 3))
    for joint in range(skeleton.num_joints):
        other = int(partner[joint])
        if other < joint:
            reflections[joint] = reflections[other].T
            continue
        candidates = _CANDIDATES
        if other == joint:  # a centre joint's reflection must be its own inverse
            candidates = candidates[np.all(np.abs(candidates @ candidates - np.eye(3)) < 1e-9, axis=(1, 2))]
        ours, theirs = _child_vectors(skeleton, joint, partner)
        # each vector's misfit relative to its own length, so a short bone's offsets decide as a long one's do;
        # vectors too short to point anywhere (an End Site of zeros carrying a file's rounding) have no say
        sizes = np.maximum(np.linalg.norm(ours, axis=-1), np.linalg.norm(theirs, axis=-1))  # (K,)
        pointing = sizes >= SHORTEST_VECTOR_OF_SIZE * scale
        ours, theirs, sizes = ours[pointing], theirs[pointing], sizes[pointing]
        misfit = (
            np.linalg.norm(np.einsum("aij,kj->aki", candidates, ours) - theirs, axis=-1) / sizes
        )  # (24, K)
        offset_error = misfit.sum(axis=1)
        pose_error = np.linalg.norm(
            mean_pose[joint] - _REFLECT_X @ mean_pose[other] @ candidates, axis=(1, 2)
        ) + np.linalg.norm(
            mean_pose[other] - _REFLECT_X @ mean_pose[joint] @ candidates.transpose(0, 2, 1), axis=(1, 2)
        )
        # Offsets decide first: only those that fit them are chosen from (before, a misfit was weighed against
        # the pose, relative to the longest bone, so a short bone's misfit lost to a raised arm's asymmetry);
        # then the pose of the most symmetric frames, and the parent's reflection (leaf joints have no offsets).
        parent = skeleton.parents[joint]
        parent_change = 0.0 if parent < 0 else np.linalg.norm(candidates - reflections[parent], axis=(1, 2))
        fitting = offset_error <= offset_error.min() + OFFSET_TOLERANCE * max(len(ours), 1)
        cost = np.where(fitting, pose_error + parent_change, np.inf)
        reflections[joint] = candidates[np.argmin(cost)]
    return reflections


def _symmetric_frames(
    motion: Motion, partner: IntArray, turns: FloatArray, world_positions: FloatArray
) -> IntArray:
    """The frames (K,) where the body stands most nearly mirror-symmetric, read from joint positions (which
    a mirror maps without any choice of axes): the `SYMMETRIC_SHARE` of frames whose joints lie nearest
    their partners' reflections, relative to the pelvis in the heading frame (turns (T, 3, 3), world
    positions (T, J, 3)). A one-handed wave's most symmetric frames are its hands-down start and end, so
    its raised arm does not choose the axes of both arms' reflections."""
    pelvis = motion.skeleton.pelvis
    local = np.einsum("tji,tkj->tki", turns, world_positions - world_positions[:, pelvis : pelvis + 1])
    asymmetry = np.linalg.norm(local - local[:, partner] @ _REFLECT_X, axis=-1).mean(axis=1)  # (T,)
    count = max(1, int(np.ceil(SYMMETRIC_SHARE * motion.num_frames)))
    return np.argsort(asymmetry, kind="stable")[:count]


def mirror(motion: Motion, reflections: FloatArray | None = None) -> Motion:
    """The clip mirrored left/right (see the module docstring); `SkeletonMismatchError` without L/R pairs."""
    if not isinstance(motion, Motion):
        raise TypeError(f"mirror takes a Motion (elastyle.read_bvh reads one), got {type(motion).__name__}")
    skeleton = motion.skeleton
    partner = check_mirrorable(skeleton)
    if reflections is None:
        reflections = local_reflections(motion, partner)
    world_rotations, world_positions = motion.world()
    mirrored_rotations = _REFLECT_X @ world_rotations[:, partner] @ reflections  # (T, J, 3, 3)
    mirrored_positions = world_positions[:, partner] @ _REFLECT_X  # (T, J, 3)
    local_rotations = mirrored_rotations.copy()
    translations = mirrored_positions.copy()
    parents = skeleton.parents
    children = np.flatnonzero(parents >= 0)
    parent_rotations = mirrored_rotations[:, parents[children]]  # (T, J-1, 3, 3)
    local_rotations[:, children] = np.swapaxes(parent_rotations, -1, -2) @ mirrored_rotations[:, children]
    delta = mirrored_positions[:, children] - mirrored_positions[:, parents[children]]
    translations[:, children] = np.einsum("tkji,tkj->tki", parent_rotations, delta)
    # a joint held at its rest offset (a bone, not a position channel) keeps its own, so the mirror stays on the
    # clip's rig: its partner's offset, a rig's left and right bones a little unlike, gave it position channels
    moving = set(moved_joints(motion, list(range(skeleton.num_joints))))
    held = [
        j for j in children.tolist() if j not in moving and int(partner[j]) not in moving
    ]  # and its partner
    translations[:, held] = skeleton.offsets[held]
    return Motion(skeleton, from_matrix(local_rotations), translations, motion.fps)


def unpaired_note(skeleton: Skeleton, name: str) -> str | None:
    """A warning naming the joints a mirror of a clip `name` on `skeleton` reflects in place though their
    names say a side (no partner of the other side's name), or None where every such joint has one."""
    unpaired = skeleton.unpaired_sides()
    if not unpaired:
        return None
    return (
        f"warning: {name}: joint(s) {', '.join(unpaired)} name a side but have no partner of the other "
        "side's name, so its mirror reflects them in place instead of swapping them: give both sides "
        "matching names"
    )


# a clip whose manner is held to one side: a joint below the pelvis points, on average over the clip, this
# many degrees otherwise than in the clip's mirror. Of the dataset's two-sided takes (a quarter of them), 1 of
# 44 walks passes it (their 90th percentile 25, at most 48), no turn (at most 41), 2 of 161 both-handed
# gestures, 4 of 79 runs (their 90th percentile 34); a hand held in a pocket reads 58, a head tilted 25
# degrees 50, the dataset's one-handed gestures 89 and more
ONE_SIDED_DEGREES = 45.0


class Asymmetry(NamedTuple):
    """How far a clip's mean pose is from its mirror's: the largest angle (degrees) between a joint's mean
    direction in each, and that joint."""

    degrees: float
    joint: int


def asymmetry(motion: Motion, mirrored: Motion) -> Asymmetry:
    """The `Asymmetry` of a clip and its mirror (`mirror`), over the joints below the pelvis: each joint's
    direction is its bone (towards its first child with a bone of some length, else its end site, else from
    its parent; a joint with none of some length is left out) turned by its world rotation, in the body's
    heading frame, averaged over the clip's frames."""
    skeleton = motion.skeleton
    bones = np.zeros((skeleton.num_joints, 3))  # (J, 3) unit bones; zero where a joint has none of length
    for joint in range(skeleton.num_joints):
        candidates = [skeleton.offsets[c] for c in skeleton.children(joint)]
        candidates += [np.nan_to_num(skeleton.end_sites[joint]), skeleton.offsets[joint]]
        bone = next((b for b in candidates if np.linalg.norm(b) > 1e-9), np.zeros(3))
        bones[joint] = bone / max(float(np.linalg.norm(bone)), 1e-12)
    forward = pelvis_forward_local(skeleton)

    def mean_directions(clip: Motion) -> FloatArray:
        rotations = clip.world()[0]  # (T, J, 3, 3)
        unturn = np.swapaxes(yaw_matrices(heading_yaw(rotations[:, skeleton.pelvis], forward)), -1, -2)
        directions = np.einsum("tab,tjbc,jc->ja", unturn, rotations, bones)  # (J, 3) summed over frames
        return directions / np.maximum(np.linalg.norm(directions, axis=-1, keepdims=True), 1e-12)

    cosine = np.sum(mean_directions(motion) * mean_directions(mirrored), axis=-1)  # (J,)
    below = np.zeros(skeleton.num_joints, dtype=bool)
    below[subtree(skeleton, skeleton.pelvis)] = True
    below[skeleton.pelvis] = False
    below &= np.any(bones != 0, axis=1)  # a joint without a bone points nowhere
    degrees = np.where(below, np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))), 0.0)
    joint = int(np.argmax(degrees))
    return Asymmetry(float(degrees[joint]), joint)
