"""Clips of a model's skeleton with joints the model lacks (fingers, props, tips exported as joints), or its
joints listed in another order. Every model joint is in the clip under its own name (or the same name after
a `namespace:` prefix) below the same parent, and the clip's other joints hang below model joints (or
above the model's top joint, an exporter's `Armature`: their world transform is taken into it), so the
model's joints rotate as on the model's skeleton. The transfer reads the model's joints alone, in the
model's order; the output carries the others as the content performs them, at the output's moments, and
lists every joint in the clip's order.

    model_joints_in       (J_model,) each model joint's index in the clip, or None
    inserted_joints       a clip's joints between two of the model's (which it cannot read)
    without_extra_joints  the clip on the model's joints alone
    with_extra_joints     an output on the model's joints, back on the clip's whole skeleton
"""

from __future__ import annotations

import itertools

import numpy as np

from elastyle.core.body import standing_height
from elastyle.core.motion import Motion
from elastyle.core.roots import below, in_world
from elastyle.core.skeleton import Skeleton, bare_name
from elastyle.types import IntArray


def model_joints_in(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """(J',) the clip index of each model joint the clip has, in the model's order, where the clip is the
    model's skeleton (less the static joints above its root that some exporters drop: `core.roots`) with
    joints added below model joints, or its joints listed in another order; None for any other clip, and
    for one that lists just the model's joints in the model's order.

    Names match exactly, or else without namespaces. Each matched joint's parent in the clip must be the
    match of its model parent (no joint inserted between two of the model's), and the model's joints the
    clip lacks must be a chain above its root. Where no names match, joints under other names are matched
    by the hierarchy (`_by_hierarchy`: extra joints hang below model joints, none between two), for the caller to
    check as the model's skeleton under other names (`core.body.same_structure`)."""
    by_name = _by_name(model, clip)
    if by_name is None and inserted_joints(model, clip):  # the model's names with other joints between them:
        return None  # not the model's skeleton under other names
    joints = by_name if by_name is not None else _by_hierarchy(model, clip)
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
        if all(index.get(int(clip.parents[joint]), -1) == parent for joint, parent in zip(joints, parents)):
            return joints
    return None


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


def inserted_joints(model: Skeleton, clip: Skeleton) -> list[tuple[list[str], str, str]]:
    """Where a clip that has the model's joints under their names (`_named`) holds other joints between a
    model joint and its model parent (a twist joint mid-arm, a third spine joint): for each such place, the
    joints in between (clip names, top down), the parent's and the joint's model names. Empty for a clip
    that lacks a model joint's name, or has none in between."""
    for missing, found in _named(model, clip):
        at = dict(zip(range(missing, model.num_joints), found))  # model joint -> clip joint
        places = []
        for joint in range(missing + 1, model.num_joints):
            parent = int(model.parents[joint])
            if parent < missing:
                continue
            between, above = [], int(clip.parents[at[joint]])
            while above >= 0 and above != at[parent]:
                between.append(clip.names[above])
                above = int(clip.parents[above])
            if above >= 0 and between:
                places.append((between[::-1], model.names[parent], model.names[joint]))
        return places
    return []


def _by_hierarchy(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """`model_joints_in` under other names: the clip's root taken for the model's joint k (0, or a joint of
    the static chain above the model's pelvis that some exporters drop), each model joint with children
    matched to a clip joint with at least as many children, and a model joint without children to a clip
    joint with any (fingers below a hand, a tip below the head); None where the tree differs. A joint's
    children are paired by the way their bones point at rest (`_paired`), so a clip that lists them in another
    order (the legs before the spine) under other names is read too. A clip joint with more children than the
    model's has extra joints hanging below it (a twist bone beside the forearm, a prop on the chest, IK
    targets under the root): of its children, those whose subtrees can hold the model's are paired (`_chosen`)
    and the rest are extra."""
    for top in range(model.pelvis + 1):
        if top and model.parents[top] != top - 1:
            break  # the joints above the root are no chain
        found = {top: 0}
        pending = [top]
        while pending:
            joint = pending.pop()
            ours, theirs = model.children(joint), clip.children(found[joint])
            if not ours:
                if theirs and _cut_short(model, clip, joint, found[joint]):
                    break  # a joint inserted above the model's end joint, not extras below it
                continue  # the clip's joints below a model end joint are extra
            if len(theirs) < len(ours):
                break
            chosen = (
                _paired(model, clip, ours, theirs)
                if len(theirs) == len(ours)
                else _chosen(model, clip, joint, found[joint])
            )
            if chosen is None:
                break
            found.update(zip(ours, chosen))
            pending.extend(ours)
        else:
            if len(found) == model.num_joints - top:
                return np.array([found[joint] for joint in range(top, model.num_joints)], dtype=np.int64)
    return None


def _holds(model: Skeleton, clip: Skeleton, joint: int, theirs: int) -> bool:
    """Whether the clip joint `theirs` can be the model's `joint`: each model child below it held by a child
    of its own (extra children aside), down to the model's end joints (`_cut_short` ones excepted)."""
    if not model.children(joint):
        return not (clip.children(theirs) and _cut_short(model, clip, joint, theirs))
    return _chosen(model, clip, joint, theirs) is not None


MAX_CHOSEN_CHILDREN = 8  # a joint with more children than this is read only with as many as the model's


def _chosen(model: Skeleton, clip: Skeleton, joint: int, theirs: int) -> list[int] | None:
    """The children of the clip joint `theirs` paired with those of the model's `joint` (the clip's at least
    as many): among the pairings where each clip child can hold its model child's subtree (`_holds`), the one
    whose bones are most alike at rest (direction, and length relative to the parents' bones: a body's height
    counts joints the model lacks); None where none can."""
    ours, below = model.children(joint), clip.children(theirs)
    if len(below) < len(ours) or len(below) > MAX_CHOSEN_CHILDREN:
        return None
    holds = {(a, b): _holds(model, clip, a, b) for a in ours for b in below}
    parent_bones = float(np.linalg.norm(model.offsets[joint])), float(np.linalg.norm(clip.offsets[theirs]))
    scale = (  # clip lengths per model length: the parents' bones, or else the bodies' heights
        parent_bones[1] / parent_bones[0]
        if min(parent_bones) > 0
        else (standing_height(clip) or 1.0) / (standing_height(model) or 1.0)
    )

    def alike(a: int, b: int) -> float:
        ours_bone, theirs_bone = model.offsets[a] * scale, clip.offsets[b]
        sizes = float(np.linalg.norm(ours_bone)), float(np.linalg.norm(theirs_bone))
        if min(sizes) <= 0:
            return 0.0 if sizes[0] == sizes[1] else -2.0
        return float(ours_bone @ theirs_bone) / (sizes[0] * sizes[1]) - abs(
            float(np.log(sizes[1] / sizes[0]))
        )

    best, best_score = None, -np.inf
    for order in itertools.permutations(below, len(ours)):
        if all(holds[a, b] for a, b in zip(ours, order)):
            score = sum(alike(a, b) for a, b in zip(ours, order))
            if score > best_score + 1e-9:
                best, best_score = list(order), score
    return best


# a model end joint's bone read at a clip joint with joints below it is at least this share of the model's (each
# relative to its skeleton's size): shorter, the clip has a joint between (Neck, Neck1, Head under CMU names read
# Neck1 as the head, its bone 0 or half the model's, and carried the real head as an extra, 10 degrees off)
SHORTEST_END_BONE = 0.6


def _cut_short(model: Skeleton, clip: Skeleton, joint: int, theirs: int) -> bool:
    """Whether the clip joint `theirs`, matched to the model's end joint `joint`, has a bone shorter than
    `SHORTEST_END_BONE` of the model's, each relative to its skeleton's standing height."""
    model_bone = float(np.linalg.norm(model.offsets[joint])) / (standing_height(model) or 1.0)
    clip_bone = float(np.linalg.norm(clip.offsets[theirs])) / (standing_height(clip) or 1.0)
    return model_bone > 0 and clip_bone < SHORTEST_END_BONE * model_bone


MAX_PAIRED_CHILDREN = 6  # more children than this are paired in their order (720 orders tried at most)


def _paired(model: Skeleton, clip: Skeleton, ours: list[int], theirs: list[int]) -> list[int]:
    """The clip's children `theirs` in the order that pairs them with the model's children `ours` (as many)
    whose bones point most alike at rest (the greatest sum of the cosines of their offsets); their own
    order where that is as alike, or where there are more than `MAX_PAIRED_CHILDREN`."""
    if len(ours) < 2 or len(ours) > MAX_PAIRED_CHILDREN:
        return theirs

    def unit(offsets: np.ndarray) -> np.ndarray:
        size = np.linalg.norm(offsets, axis=1, keepdims=True)
        return np.where(size > 0, offsets / np.maximum(size, 1e-300), 0.0)

    alike = unit(model.offsets[ours]) @ unit(clip.offsets[theirs]).T  # (C, C) cosines
    rows = np.arange(len(ours))
    best = max(
        itertools.permutations(range(len(theirs))),
        key=lambda order: (
            round(float(alike[rows, list(order)].sum()), 9),
            -sum(map(abs, np.subtract(order, rows))),
        ),
    )
    return [theirs[k] for k in best]


def without_extra_joints(motion: Motion, joints: IntArray) -> Motion:
    """The clip (T, J frames and joints) on its joints `joints` (J',) alone, in that order: their local
    rotations and translations unchanged, as the model reads them, but for the first's where extra joints
    lie above it (an exporter's `Armature` above the hips): their world transform taken into it, so no
    joint moves in the world."""
    skeleton = motion.skeleton
    index = {int(joint): at for at, joint in enumerate(joints)}
    parents = np.array([index.get(int(skeleton.parents[joint]), -1) for joint in joints], dtype=np.int64)
    ends = skeleton.end_sites[joints].copy()
    for at, joint in enumerate(joints):  # a joint whose children are all extra: their mean place as its tip
        children = np.flatnonzero(skeleton.parents == joint)
        if np.isnan(ends[at, 0]) and len(children) and not np.any(parents == at):
            ends[at] = skeleton.offsets[children].mean(axis=0)
    subset = Skeleton(
        tuple(skeleton.names[j] for j in joints), parents, skeleton.offsets[joints], ends, skeleton.unit_cm
    )
    rotations, translations = motion.rotations[:, joints], motion.translations[:, joints]
    above = int(skeleton.parents[joints[0]])
    if above >= 0:  # into the world's frame: the extra joints above multiplied in
        rotations[:, 0], translations[:, 0] = in_world(motion, above, rotations[:, 0], translations[:, 0])
    return Motion(subset, rotations, translations, motion.fps)


def with_extra_joints(motion: Motion, clip_at: Motion, joints: IntArray) -> Motion:
    """An output on the clip's joints `joints` (N, J' frames and joints) on the clip's whole skeleton: the
    other joints as `clip_at` (the clip at the output's N moments) has them, and the first joint, placed
    in the world, put back below the extra joints above it (`without_extra_joints`)."""
    rotations, translations = clip_at.rotations.copy(), clip_at.translations.copy()
    rotations[:, joints] = motion.rotations
    translations[:, joints] = motion.translations
    above = int(clip_at.skeleton.parents[joints[0]])
    if above >= 0:  # from the world's frame into the frame of the joint above
        top = joints[0]
        rotations[:, top], translations[:, top] = below(
            clip_at, above, motion.rotations[:, 0], motion.translations[:, 0]
        )
    return Motion(clip_at.skeleton, rotations, translations, motion.fps)
