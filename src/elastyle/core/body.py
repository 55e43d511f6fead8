"""Body-level conventions: legs and hands, the length unit, which way a skeleton faces, its heading.

Axes: +Y up. The heading yaw is the rotation about +Y that turns +Z into the body's facing direction.
Legs are found from the skeleton: each left/right pair of the pelvis's children starts a leg (by name;
when no names say left and right, the two chains from the pelvis that mirror each other), its
deepest joint is the toe and the toe's parent the ankle; thresholds elsewhere are relative to the leg length.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.types import FloatArray, IntArray


def pelvis_forward_local(skeleton: Skeleton) -> FloatArray:
    """Facing direction (3,) in the pelvis's local frame, from its left/right and upward children.

    Left-to-right children give the lateral axis, the first centre child (the spine) the up axis, and
    forward = lateral x up (a body facing +Z with +Y up has its left at +X). Falls back to local +Z.
    """
    pelvis = skeleton.pelvis
    partner = skeleton.mirror_pairs()
    children = skeleton.children(pelvis)
    sided = [c for c in children if partner[c] != c and partner[c] in children]
    centre = [c for c in children if partner[c] == c]
    if not sided or not centre:
        return np.array([0.0, 0.0, 1.0])
    left = next((c for c in sided if skeleton.sides()[c] > 0), sided[0])
    lateral = skeleton.offsets[left] - skeleton.offsets[partner[left]]
    up = skeleton.offsets[centre[0]]
    up = up - lateral * (up @ lateral) / max(lateral @ lateral, 1e-12)
    forward = np.cross(lateral, up)
    norm = np.linalg.norm(forward)
    return forward / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])


def heading_yaw(pelvis_world_rotations: FloatArray, forward_local: FloatArray) -> FloatArray:
    """Unwrapped heading yaw (T,) radians from pelvis world rotation matrices (T, 3, 3)."""
    forward = pelvis_world_rotations @ forward_local  # (T, 3)
    return np.unwrap(np.arctan2(forward[:, 0], forward[:, 2]))


def yaw_matrices(yaw: FloatArray) -> FloatArray:
    """Rotation matrices (T, 3, 3) about +Y by yaw (T,) radians."""
    cos, sin = np.cos(yaw), np.sin(yaw)
    matrices = np.zeros((*yaw.shape, 3, 3))
    matrices[..., 0, 0] = cos
    matrices[..., 0, 2] = sin
    matrices[..., 1, 1] = 1.0
    matrices[..., 2, 0] = -sin
    matrices[..., 2, 2] = cos
    return matrices


UNITS = {"cm": 1.0, "m": 100.0, "mm": 0.1, "in": 2.54}  # centimetres per unit, by the names `--units` takes


def centimetres_per_unit(skeleton: Skeleton) -> float:
    """The file's length unit in centimetres: as the user stated it (`Skeleton.unit_cm`), else guessed from
    the body's height (`standing_height`): metres below 5 units tall, inches from 40 to 90, millimetres from
    500 (a body 5 m tall in centimetres), else centimetres."""
    if skeleton.unit_cm is not None:
        return skeleton.unit_cm
    height = standing_height(skeleton)
    if height < 5:
        return UNITS["m"]
    if 40 < height < 90:
        return UNITS["in"]
    if height >= 500:
        return UNITS["mm"]
    return UNITS["cm"]


def standing_height(skeleton: Skeleton) -> float:
    """About how tall the body stands, in the file's unit, from its bone lengths whatever its rest pose: the
    chain from the pelvis down each leg to its toe's end (their mean) plus the longest chain from the pelvis
    up the spine (arms left out), End Sites included; the rest pose's vertical extent where no legs are
    found. (A rest pose need not stand: the dataset's lies along X, 99.8 cm tall, for a body 146 cm to its
    head joint.)"""
    limbs = find_limbs(skeleton)
    if not len(limbs.toes):
        return skeleton.height()
    bones = np.linalg.norm(skeleton.offsets, axis=1)  # (J,) each joint's distance from its parent
    ends = np.nan_to_num(np.linalg.norm(skeleton.end_sites, axis=1))  # (J,) its End Site's, 0 for none
    reach = np.zeros(skeleton.num_joints)  # (J,) chain length from the root
    spine = np.zeros(skeleton.num_joints, dtype=bool)  # joints above the pelvis, not in a leg or an arm
    elsewhere = {skeleton.pelvis, *limbs.hips.tolist(), *limbs.arm_roots.tolist()}
    for joint in range(1, skeleton.num_joints):
        parent = int(skeleton.parents[joint])
        reach[joint] = reach[parent] + bones[joint]
        spine[joint] = joint not in elsewhere and (parent == skeleton.pelvis or spine[parent])
    pelvis = reach[skeleton.pelvis]
    legs = float(np.mean(reach[limbs.toes] + ends[limbs.toes])) - pelvis
    up = float(np.max(reach[spine] + ends[spine])) - pelvis if np.any(spine) else 0.0
    return legs + up


# clips within this share of the reference skeleton's standing height keep their own size: the training
# performers' own spread (the dataset's three hierarchies all stand 146.22 cm from their bone lengths)
SIZE_TOLERANCE = 0.02


def size_factor(clip: Skeleton, reference: Skeleton) -> float:
    """The scale that brings a clip's skeleton to the reference's length unit (`centimetres_per_unit`: as
    stated with `--units`, else guessed from the body's height) and, where its size then lies more than
    `SIZE_TOLERANCE` from the reference's, to the reference's size (1 for a flat skeleton). The size is the
    legs' (`leg_chain_length`) where both have legs, else the `standing_height`, both from bone lengths: the
    rest pose's extent also counted the pelvis's offset from the root, which a pelvis with position channels
    does not use (a file whose Hips OFFSET reads 0 0 0, as most exporters write it, was read 7.6 times too
    large and came out collapsed).

    A model reads clips at its own skeleton's size and trains on clips brought to its first clip's: some
    features are lengths (the pelvis's height and sway), so read raw, held-out takes 10 % shorter or taller
    reconstructed with 4.4 and 2.2 cm median joint error instead of 0.49 (the previous model), and a clip in
    metres is unreadable. They are the legs' lengths: a body whose legs are 15 % longer than the model's for
    its height, brought to the model's height, stood on legs 7 % too long for the pelvis's height the style
    gave them, and walked crouched, its feet scraping the floor (70 cm/s of skate by `elastyle eval`
    against 0.8).
    """
    unit = centimetres_per_unit(clip) / centimetres_per_unit(reference)
    size, reference_size = leg_chain_length(clip), leg_chain_length(reference)
    if size <= 0 or reference_size <= 0:
        size, reference_size = standing_height(clip), standing_height(reference)
    size *= unit
    if size <= 0 or reference_size <= 0 or abs(size / reference_size - 1) <= SIZE_TOLERANCE:
        return unit
    return unit * reference_size / size


def leg_chain_length(skeleton: Skeleton) -> float:
    """The legs' mean length from hip to ankle along their bones, in the file's unit, whatever the rest pose
    (bent knees count straight); 0 without legs."""
    limbs = find_limbs(skeleton)
    if not len(limbs.ankles) or len(limbs.hips) != len(limbs.ankles):
        return 0.0
    bones = np.linalg.norm(skeleton.offsets, axis=1)  # (J,) each joint's distance from its parent
    chains = []
    for hip, ankle in zip(limbs.hips.tolist(), limbs.ankles.tolist()):
        length, joint = 0.0, ankle
        while joint not in (hip, -1):
            length += float(bones[joint])
            joint = int(skeleton.parents[joint])
        chains.append(length if joint == hip else 0.0)
    return float(np.mean(chains))


def at_size_of(motion: Motion, reference: Skeleton) -> tuple[Motion, float]:
    """The clip scaled by `size_factor` to the reference skeleton's unit and size, that unit then being
    the reference's (so figures of it, such as a reconstruction error in cm, are at the reference's size
    whether the clip's unit was stated or guessed); and the factor."""
    factor = size_factor(motion.skeleton, reference)
    if factor == 1.0:
        return motion, factor
    scaled = motion.scaled(factor)
    skeleton = replace(scaled.skeleton, unit_cm=reference.unit_cm)
    return Motion(skeleton, scaled.rotations, scaled.translations, scaled.fps), factor


def in_units(motion: Motion, unit: str | None) -> Motion:
    """The clip with its length unit stated (a key of `UNITS`), or as it is for None or where its file
    format fixes the unit already (glTF: metres, where no node scales it), so one --units for clips of both
    formats reads each right."""
    if unit is None or motion.skeleton.unit_cm is not None:
        return motion
    skeleton = replace(motion.skeleton, unit_cm=UNITS[unit])
    return Motion(skeleton, motion.rotations, motion.translations, motion.fps)


@dataclass(frozen=True)
class Limbs:
    """Joint indices: toes (F,), ankles (F,), hips (F,), hands (H,) (end joints of arm chains) and the
    arms' roots (H,) (the first sided joint of each arm: a clavicle or shoulder)."""

    toes: IntArray
    ankles: IntArray
    hips: IntArray
    hands: IntArray
    arm_roots: IntArray

    @cached_property
    def feet(self) -> IntArray:
        """Toes and ankles (2F,): with their ancestors, every joint a foot's position depends on."""
        return np.concatenate([self.toes, self.ankles])


def _subtree_depths(skeleton: Skeleton, joint: int) -> dict[int, int]:
    """Every joint of `joint`'s subtree (itself included) and its depth below `joint`."""
    depth = {joint: 0}
    for j in range(joint + 1, skeleton.num_joints):  # parents come before their children
        if skeleton.parents[j] in depth:
            depth[j] = depth[int(skeleton.parents[j])] + 1
    return depth


def _deepest_descendant(skeleton: Skeleton, joint: int) -> int:
    depth = _subtree_depths(skeleton, joint)
    return max(depth, key=lambda j: (depth[j], -j))


# a leg chain's last bone at least this share of the bones above it (below the hip) is a shin, not a foot
TOELESS_LAST_BONE = 0.25


def _ankle(skeleton: Skeleton, hip: int, toe: int) -> int:
    """The ankle on the chain from a hip down to its deepest joint (`toe`): the toe's parent, unless the
    chain's last bone is as long as a shin (at least `TOELESS_LAST_BONE` of the bones above it: a foot is
    about 0.15 of a thigh and shin, whole or split by twist joints), in which case the leg has no toe joint,
    its foot an End Site, and the deepest joint is the ankle too; a leg of one bone is its own ankle."""
    chain = [toe]
    while chain[-1] != hip:
        chain.append(int(skeleton.parents[chain[-1]]))
    chain = chain[::-1][1:]  # the joints below the hip, down to the toe: each one's offset is a bone
    if len(chain) < 2:
        return toe if skeleton.parents[toe] == hip else int(skeleton.parents[toe])
    bones = np.linalg.norm(skeleton.offsets[chain], axis=1)
    return toe if bones[-1] >= TOELESS_LAST_BONE * bones[:-1].sum() else chain[-2]


BONE_DIRECTION_DEGREES = 20.0  # a renamed skeleton's bones point the same way at rest, within this


def same_structure(reference: Skeleton, other: Skeleton, rest_pose: bool = True) -> bool:
    """Whether `other` is `reference` under other joint names: the same hierarchy, its legs and arms found at
    the same joints on the same sides (whatever the naming scheme), and (unless `rest_pose` is False) every
    bone below the pelvis pointing the same way at rest within `BONE_DIRECTION_DEGREES` (local rotations mean
    the same pose only about the same rest pose; sizes may differ)."""
    if reference.num_joints != other.num_joints or not np.array_equal(reference.parents, other.parents):
        return False
    ours, theirs = find_limbs(reference), find_limbs(other)
    if not len(ours.toes) or not len(ours.hands):
        return False  # no limbs to check the joints' roles by
    for name in ("toes", "ankles", "hips", "hands", "arm_roots"):
        if not np.array_equal(getattr(ours, name), getattr(theirs, name)):
            return False
    both_sided = (reference.sides() != 0) & (other.sides() != 0)
    if np.any(reference.sides()[both_sided] != other.sides()[both_sided]):
        return False
    return same_rest_pose(reference, other) if rest_pose else True


def same_rest_pose(reference: Skeleton, other: Skeleton) -> bool:
    """Whether two skeletons of one hierarchy have every bone below the pelvis pointing the same way at rest,
    within `BONE_DIRECTION_DEGREES` (bones of zero length in either are not compared)."""
    lengths = np.linalg.norm(reference.offsets, axis=1), np.linalg.norm(other.offsets, axis=1)
    bones = (lengths[0] > 1e-9 * lengths[0].max()) & (lengths[1] > 1e-9 * lengths[1].max())
    bones[: reference.pelvis + 1] = False  # the pelvis and above: placed by their position channels
    cosines = (
        np.sum(reference.offsets[bones] * other.offsets[bones], axis=1) / (lengths[0] * lengths[1])[bones]
    )
    return bool(np.all(cosines >= np.cos(np.radians(BONE_DIRECTION_DEGREES))))


_LIMBS: weakref.WeakKeyDictionary[Skeleton, Limbs] = weakref.WeakKeyDictionary()


def find_limbs(skeleton: Skeleton) -> Limbs:
    """The skeleton's legs and hands (found once per skeleton)."""
    if skeleton not in _LIMBS:
        _LIMBS[skeleton] = _limbs_of(skeleton)
    return _LIMBS[skeleton]


def _alike_pair(skeleton: Skeleton, joints: list[int]) -> list[int]:
    """Two of `joints` whose subtrees look like mirror images (the same joint count and depth, bone lengths
    within 5 %), the longest such pair; empty if none. How limbs are found when no names say left/right."""
    bone = np.linalg.norm(skeleton.offsets, axis=1)

    def shape(joint: int) -> tuple[int, int, float]:
        depth = _subtree_depths(skeleton, joint)
        return len(depth), max(depth.values()), float(bone[list(depth)].sum())

    shapes = {j: shape(j) for j in joints}
    pairs = [
        (shapes[a][2] + shapes[b][2], a, b)
        for i, a in enumerate(joints)
        for b in joints[i + 1 :]
        if shapes[a][:2] == shapes[b][:2]
        and abs(shapes[a][2] - shapes[b][2]) <= 0.05 * max(shapes[a][2], 1e-9)
    ]
    return list(max(pairs)[1:]) if pairs else []


ARM_DEPTH = 2  # an arm found by its name alone holds at least this many joints below its root (elbow, hand)


def _limbs_of(skeleton: Skeleton) -> Limbs:
    partner = skeleton.mirror_pairs()
    pelvis = skeleton.pelvis
    legs = [c for c in skeleton.children(pelvis) if partner[c] != c]
    if not legs:  # no names say left and right: the mirror-image chains
        legs = _alike_pair(skeleton, list(skeleton.children(pelvis)))
    toes = [_deepest_descendant(skeleton, leg) for leg in legs]
    ankles = [_ankle(skeleton, leg, toe) for leg, toe in zip(legs, toes)]
    spine = [c for c in skeleton.children(pelvis) if partner[c] == c and c not in legs]
    hands: list[int] = []
    roots: list[int] = []
    if spine:
        below_spine = set(_subtree_depths(skeleton, spine[0]))
        # arm roots: sided joints below the spine whose parent is a centre joint, the topmost of each chain (a
        # joint renamed on one side only is a centre joint: the sided ones below it start no arm of their own)
        sided_below_centre = {
            j for j in below_spine if partner[j] != j and partner[skeleton.parents[j]] == skeleton.parents[j]
        }
        roots = [
            j
            for j in sorted(sided_below_centre)
            if not any(a in sided_below_centre for a in skeleton.with_ancestors([j]) if a != j)
        ]
        # the first branching below the spine with mirror-image chains, where those hold every root the names
        # found: unnamed arms, and arms whose top joint is renamed on one side (its partner then reads as a
        # centre joint, and the arms as starting below both); a named one-armed character's fingers hold none
        # of its named roots, so they are not taken for arms
        for j in sorted(below_spine):
            alike = _alike_pair(skeleton, list(skeleton.children(j)))
            if alike:
                held = set(_subtree_depths(skeleton, alike[0])) | set(_subtree_depths(skeleton, alike[1]))
                roots = alike if set(roots) <= held else roots
                break
        if not roots:  # one arm (a one-armed character): a chain named for a side, off a joint that is not
            roots = [
                j
                for j in sorted(below_spine)
                if skeleton.named_side(j) != 0
                and skeleton.named_side(int(skeleton.parents[j])) == 0
                and max(_subtree_depths(skeleton, j).values()) >= ARM_DEPTH
            ]
        hands = [_deepest_descendant(skeleton, r) for r in roots]
    arrays = [np.array(joints, dtype=np.int64) for joints in (toes, ankles, legs, hands, roots)]
    for array in arrays:
        array.flags.writeable = False  # shared by every caller
    return Limbs(*arrays)


def leg_length(skeleton: Skeleton, limbs: Limbs) -> float:
    rest = skeleton.rest_positions()
    if len(limbs.toes) == 0:
        return skeleton.height() / 2
    return float(np.mean(np.linalg.norm(rest[limbs.hips] - rest[limbs.ankles], axis=-1)))


PLAUSIBLE_HEIGHT_CM = (30.0, 400.0)  # a stated unit that makes a body stand outside this is questioned


def guessed_unit_note(skeleton: Skeleton, name: str) -> str | None:
    """A one-line note when the length unit is guessed (not stated) as other than centimetres, or a warning
    when a stated one makes the body stand implausibly tall or short (`PLAUSIBLE_HEIGHT_CM`)."""
    if skeleton.unit_cm is not None:
        unit = next((unit for unit, cm in UNITS.items() if cm == skeleton.unit_cm), None)
        height_cm = standing_height(skeleton) * skeleton.unit_cm
        low, high = PLAUSIBLE_HEIGHT_CM
        if unit is None or low <= height_cm <= high:
            return None
        return (
            f"warning: {name}: read in {unit}, the body stands {height_cm / 100:.3g} m tall: is that its unit? "
            "(--units states a BVH clip's)"
        )
    unit_cm = centimetres_per_unit(skeleton)
    if unit_cm == UNITS["cm"]:
        return None
    unit = next(unit for unit, cm in UNITS.items() if cm == unit_cm)
    return (
        f"note: {name}: length unit guessed as {unit} (the body stands about {standing_height(skeleton):.3g} "
        "units tall); --units states it"
    )


def no_legs_note(skeleton: Skeleton, name: str) -> str | None:
    """A one-line note when the skeleton's legs cannot be found (feet then go unplanted and unmeasured)."""
    if len(find_limbs(skeleton).toes):
        return None
    return (
        f"note: {name}: no legs found (no left/right joint names such as LeftUpLeg, Thigh_L, l_hip or 'L Thigh', "
        "and no mirror-image chains from the pelvis): feet are not planted and foot figures are not measured"
    )
