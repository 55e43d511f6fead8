"""Body parts: the skeleton split into legs (with the root), spine (with the head) and each arm.

Found from the limbs `core.body` finds on any naming scheme (names first, mirror-image chains when names
say nothing), so per-part options work on any skeleton whose arms and legs can be found. Every joint
belongs to exactly one part:

    legs        the root, the pelvis and every joint that is neither in the spine's nor an arm's subtree
    spine       the spine's subtree without the arms: spine, chest, neck, head
    left-arm    the subtree of the left arm's root (clavicle or shoulder) down to the fingers
    right-arm   the same on the right

`arms` names both arms at once. On a skeleton with no side names, which arm is the left one comes from
the rest pose (up from the pelvis to the spine, forward from ankle to toe) where it stands; where it does
not (`rest_pose_stands`), it is a guess, which `sides_guessed` says.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from elastyle.core.body import find_limbs
from elastyle.core.skeleton import Skeleton
from elastyle.errors import ConfigError
from elastyle.types import FloatArray, IntArray

PARTS = ("legs", "spine", "left-arm", "right-arm")
GROUPS = {"arms": ("left-arm", "right-arm")}
PART_NAMES = (*PARTS, *GROUPS)


def subtree(skeleton: Skeleton, joint: int) -> list[int]:
    """`joint` and every joint below it (parents come before their children in a skeleton)."""
    inside = {joint}
    for j in range(joint + 1, skeleton.num_joints):
        if int(skeleton.parents[j]) in inside:
            inside.add(j)
    return sorted(inside)


def spine_root(skeleton: Skeleton) -> int | None:
    """The spine's first joint: the pelvis's first child that starts no leg (None where there is none)."""
    legs = set(find_limbs(skeleton).hips.tolist())
    return next((c for c in skeleton.children(skeleton.pelvis) if c not in legs), None)


def trunk(skeleton: Skeleton) -> list[int]:
    """The spine's subtree without the arms (spine, chest, neck, head), sorted; empty without a spine."""
    spine = spine_root(skeleton)
    if spine is None:
        return []
    arms = {j for root in find_limbs(skeleton).arm_roots.tolist() for j in subtree(skeleton, root)}
    return [j for j in subtree(skeleton, spine) if j not in arms]


def body_parts(skeleton: Skeleton) -> dict[str, IntArray]:
    """The joints (sorted) of each part the skeleton has; parts it lacks (no arms found) are left out."""
    limbs = find_limbs(skeleton)
    part = np.full(skeleton.num_joints, "legs", dtype=object)
    spine = spine_root(skeleton)
    if len(limbs.hips) and spine is not None:
        part[subtree(skeleton, spine)] = "spine"
    roots = limbs.arm_roots.tolist()
    sides = [
        int(skeleton.sides()[root]) or skeleton.named_side(root) for root in roots
    ]  # a lone arm: its name
    if len(roots) == 2 and 0 in sides and spine is not None and len(limbs.toes):  # unnamed: the rest pose
        across = skeleton.rest_positions()[roots] @ _left_axis(skeleton, spine)
        sides = [1, -1] if across[0] > across[1] else [-1, 1]
        if not rest_pose_stands(skeleton):  # no way to tell: the finding order, said by `sides_guessed`
            sides = [1, -1]
    for root, side in zip(roots, sides):
        part[subtree(skeleton, root)] = "left-arm" if side > 0 else "right-arm"
    found = {name: np.flatnonzero(part == name) for name in PARTS}
    return {name: joints for name, joints in found.items() if len(joints)}


# a rest pose stands where both legs point within this many degrees of straight down from the spine
STANDING_DEGREES = 45.0


def rest_pose_stands(skeleton: Skeleton) -> bool:
    """Whether the rest pose stands: both legs (hip to ankle) point within `STANDING_DEGREES` of the
    direction from the trunk's mean joint (`trunk`) down to the pelvis. Some rigs keep every bone along its
    joint's own X axis at rest (left legs along +X, right legs along -X): no side can be read from those."""
    limbs, rest = find_limbs(skeleton), skeleton.rest_positions()
    upper = trunk(skeleton)
    if not upper or len(limbs.ankles) == 0:
        return False
    down = rest[skeleton.pelvis] - np.mean(rest[upper], axis=0)  # away from the upper body
    legs = rest[limbs.ankles] - rest[limbs.hips]  # (F, 3)
    cosines = legs @ down / np.maximum(np.linalg.norm(legs, axis=1) * np.linalg.norm(down), 1e-12)
    return bool(np.all(cosines >= np.cos(np.radians(STANDING_DEGREES))))


def sides_guessed(skeleton: Skeleton) -> bool:
    """Whether `body_parts` can only guess which arm is the left one: no joint names say left or right, and
    the rest pose does not stand (`rest_pose_stands`)."""
    roots = find_limbs(skeleton).arm_roots.tolist()
    named = all(int(skeleton.sides()[root]) != 0 for root in roots)
    return len(roots) == 2 and not named and not rest_pose_stands(skeleton)


def _left_axis(skeleton: Skeleton, spine: int) -> FloatArray:
    """(3,) the body's left in the rest pose: up (pelvis to spine) x forward (the feet point forward, ankle
    to toe); a body facing +Z with +Y up has its left at +X."""
    limbs, rest = find_limbs(skeleton), skeleton.rest_positions()
    up = rest[spine] - rest[skeleton.pelvis]
    forward = np.mean(rest[limbs.toes] - rest[limbs.ankles], axis=0)
    return np.cross(up, forward)


def parse_parts(text: str, flag: str) -> tuple[str, ...]:
    """Part names from a comma-separated list (`legs,left-arm`), groups expanded; `ConfigError` naming
    `flag` for an unknown name."""
    names: list[str] = []
    for word in (w.strip() for w in text.split(",")):
        if not word:
            continue
        if word not in PART_NAMES:
            raise ConfigError(
                f"{flag}: unknown body part {word!r}; choose from {', '.join(PART_NAMES)}", flag
            )
        names += [n for n in GROUPS.get(word, (word,)) if n not in names]
    if text.strip() and not names:
        raise ConfigError(f"{flag}: {text!r} names no body part; choose from {', '.join(PART_NAMES)}", flag)
    return tuple(names)


def part_joints(skeleton: Skeleton, names: tuple[str, ...], clip: str) -> IntArray:
    """The joints (sorted) of the named parts; `ConfigError` naming the clip when its skeleton lacks one."""
    parts = body_parts(skeleton)
    missing = [n for n in names if n not in parts]
    if missing:
        raise ConfigError(
            f"{clip}: no {missing[0]} found on this skeleton (parts found: {', '.join(parts) or 'none'})"
        )
    return joint_set(j for n in names for j in parts[n])


def joint_set(joints: Iterable[int]) -> IntArray:
    """Joint indices sorted, each once (K,). Joint lists are a few dozen indices, so Python's sets do the
    set operations: numpy's (`unique`, `setdiff1d` ...) import numpy.ma on their first call in a process,
    about 9 ms of a command-line transfer's 210."""
    return np.array(sorted({int(j) for j in joints}), dtype=np.int64)


def joint_weights(
    num_joints: int, parts: list[tuple[IntArray, FloatArray]], default: FloatArray
) -> FloatArray:
    """(T, J) per-frame, per-joint weights: `default` (T,) everywhere, each part's joints (K,) taking its
    own weights (T,) (later parts win where parts share joints)."""
    weights = np.repeat(default[:, None], num_joints, axis=1)
    for joints, values in parts:
        weights[:, joints] = values[:, None]
    return weights
