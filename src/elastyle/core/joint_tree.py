"""Reading a clip's skeleton as a model's where the joint names do not tell: by the hierarchy, each model
joint matched to a clip joint below its parent's match whose bone points and reaches most alike, the clip's
other joints hanging below model joints (extra) or lying between a model joint's match and its parent's
(folded: read as part of one bone, `core.extra_joints`).

    by_hierarchy    (J',) each model joint's clip joint, or None
    folded_joints   the clip joints between two matched ones
    folded_chains   per matched joint, the clip joints between it and its parent's match
"""

from __future__ import annotations

import itertools
import weakref

import numpy as np

from elastyle.core.body import find_limbs, standing_height
from elastyle.core.skeleton import Skeleton
from elastyle.types import FloatArray, IntArray


def by_hierarchy(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """`core.extra_joints.model_joints_in` under other names: the clip's root taken for the model's joint k (0, or a joint of
    the static chain above the model's pelvis that some exporters drop), each model joint with children
    matched to a clip joint with at least as many children, and a model joint without children to a clip
    joint with any (fingers below a hand, a tip below the head); None where the tree differs. A joint's
    children are paired by the way their bones point at rest (`_paired`), so a clip that lists them in another
    order (the legs before the spine) under other names is read too. A clip joint with more children than the
    model's has extra joints hanging below it (a twist bone beside the forearm, a prop on the chest, IK
    targets under the root): of its children, those whose subtrees can hold the model's are paired (`_chosen`)
    and the rest are extra. Where that reads no tree, it is read again with up to `MOST_FOLDED` clip joints
    between a model joint's match and its parent's (a third spine joint, a hip joint above the thigh, a neck
    joint below the head): each model joint is matched down its branch's chain (`_chain`)."""
    readings = [_tree(model, clip, fold=False)]
    folded = _tree(model, clip, fold=True)
    if folded is not None and folded_joints(clip, folded):  # else no other reading than without folds
        readings.append(folded)
    found = [joints for joints in readings if joints is not None]
    # both: the one whose bones point and reach most alike the model's (a chain read one joint short, the legs'
    # first bones at the hip joints CMU inserts, matched without folds and left the rig refused)
    return min(found, key=lambda joints: _rest_gap(model, clip, joints)) if found else None


MOST_LENGTH_GAP = 1.0  # what a bone's length costs `_rest_gap` at most: a length e times off, or more


def _rest_gap(model: Skeleton, clip: Skeleton, joints: IntArray) -> float:
    """How far the clip's bones at rest lie from the model's under the reading `joints` (J',) (each model
    joint's clip joint from the model's joint J - J' on): the sum, over the model's bones, of one less the
    cosine of the angle between them (1 where one of the two has no length) and of how far their lengths'
    ratio departs from the clip's size against the model's (the absolute log of the ratio over the median
    ratio, at most `MOST_LENGTH_GAP`: a bone of almost no length costs what one of none does). Bones in a
    line tell two readings apart by their lengths alone: a neck joint read as the model's neck, the neck as
    its head and the head as a tip below it, points as the model's neck and head do, at half and a third
    more than their lengths."""
    first = model.num_joints - len(joints)
    bones = [
        (model.offsets[joint], clip.offset_from(int(joints[parent - first]), int(joints[joint - first])))
        for joint, parent in (
            (joint, int(model.parents[joint])) for joint in range(first + 1, model.num_joints)
        )
        if parent >= first
    ]
    sizes = [(float(np.linalg.norm(ours)), float(np.linalg.norm(theirs))) for ours, theirs in bones]
    ratios = [theirs / ours for ours, theirs in sizes if ours > 0 and theirs > 0]
    scale = float(np.median(ratios)) if ratios else 1.0
    gap = 0.0
    for (ours, theirs), (our_size, their_size) in zip(bones, sizes):
        if our_size > 0 and their_size > 0:
            gap += 1.0 - float(ours @ theirs) / (our_size * their_size)
            gap += min(abs(float(np.log(their_size / our_size / scale))), MOST_LENGTH_GAP)
        else:
            gap += 1.0
    return gap


def _tree(model: Skeleton, clip: Skeleton, fold: bool) -> IntArray | None:
    """`_by_hierarchy` with clip joints folded between two matched ones or not."""
    for top in range(model.pelvis + 1):
        if top and model.parents[top] != top - 1:
            break  # the joints above the root are no chain
        if fold and clip.num_joints <= model.num_joints - top:
            continue  # no joint to spare for a fold
        found = {top: 0}
        bones = {top: clip.offsets[0]}
        memo: _Memo = {}  # each match's bone from its parent's match, clip units
        pending = [top]
        while pending:
            joint = pending.pop()
            ours, theirs = model.children(joint), clip.children(found[joint])
            if not ours:
                if theirs and _cut_short(model, clip, joint, bones[joint]):
                    break  # a joint inserted above the model's end joint, not extras below it
                continue  # the clip's joints below a model end joint are extra
            if len(theirs) < len(ours):
                break
            chosen = (
                _paired(model, clip, ours, theirs)
                if len(theirs) == len(ours) and not fold
                else _chosen(model, clip, joint, found[joint], bones[joint], fold, memo)
            )
            if chosen is None:
                break
            found.update(zip(ours, chosen))
            bones.update((a, clip.offset_from(found[joint], b)) for a, b in zip(ours, chosen))
            pending.extend(ours)
        else:
            if len(found) == model.num_joints - top:
                return np.array([found[joint] for joint in range(top, model.num_joints)], dtype=np.int64)
    return None


# at most this many clip joints lie between a model joint's match and its parent's (Unreal's five spine joints
# against the model's two take 3; none where the clip reads without)
MOST_FOLDED = 5
# what each joint folded costs a match's likeness (a cosine less the log of the lengths' ratio): a chain is read
# as it is unless a joint further down it has a bone clearly more alike the model's (a zero-length hip joint's
# child, a neck joint's head)
FOLD_COST = 0.1


def _chain(clip: Skeleton, child: int, fold: bool) -> list[tuple[int, int]]:
    """The clip joints that may match a model joint below the clip child `child`'s parent, each with how many
    joints above it would be folded: the child, and with `fold` the joints down its chain of single children
    (at most `MOST_FOLDED` below it)."""
    chain = [child]
    while fold and len(chain) <= MOST_FOLDED and len(clip.children(chain[-1])) == 1:
        chain.append(clip.children(chain[-1])[0])
    # of joints at one place along the chain (a bone of no length between them), the last: its bone is the one
    # that turns (a tip at its joint's place is no joint of the chain)
    return [
        (folded, joint)
        for folded, (joint, below) in enumerate(zip(chain, [*chain[1:], -1]))
        if below < 0 or float(np.linalg.norm(clip.offsets[below])) > 0 or not clip.children(below)
    ]


# `_chosen`'s answers within one reading, by model joint, clip joint and bone
_Memo = dict[tuple[int, int, bytes], list[int] | None]


def _holds(
    model: Skeleton, clip: Skeleton, joint: int, theirs: int, bone: FloatArray, fold: bool, memo: _Memo
) -> bool:
    """Whether the clip joint `theirs`, its bone from its parent's match `bone`, can be the model's `joint`:
    each model child below it held by a child of its own (extra children aside), down to the model's end
    joints (`_cut_short` ones excepted)."""
    if not model.children(joint):
        return not (clip.children(theirs) and _cut_short(model, clip, joint, bone))
    return _chosen(model, clip, joint, theirs, bone, fold, memo) is not None


MAX_CHOSEN_CHILDREN = 8  # a joint with more children than this is read only with as many as the model's


def _chosen(
    model: Skeleton,
    clip: Skeleton,
    joint: int,
    theirs: int,
    bone: FloatArray,
    fold: bool,
    memo: _Memo,
) -> list[int] | None:
    """The clip joints below the clip joint `theirs` (its bone from its parent's match `bone`) matched to
    the children of the model's `joint`, one in each of as many of its children's branches (the child itself,
    or with `fold` a joint down its chain, `_chain`): among the pairings where each can hold its model child's
    subtree (`_holds`), the one whose bones are most alike at rest (direction, and length relative to the
    parents' bones: a body's height counts joints the model lacks); None where none can. memo: answers
    already found in this reading."""
    key = (joint, theirs, bone.tobytes())
    if key in memo:
        return memo[key]
    memo[key] = None  # until a pairing is found
    ours, below = model.children(joint), clip.children(theirs)
    if len(below) < len(ours) or len(below) > MAX_CHOSEN_CHILDREN:
        return None
    parent_bones = float(np.linalg.norm(model.offsets[joint])), float(np.linalg.norm(bone))
    # clip lengths per model length: the parents' bones, or else the bodies' heights; folding, at the pelvis,
    # whose offset places the body rather than makes a bone, the heights of the body below its match (a root
    # kept above the hips placed them 516 units away against the model's 427, and the spine's chain was read
    # one joint short; a root with IK targets below it is no pelvis)
    body = _height_below(clip, theirs) if fold and joint == model.pelvis else 0.0
    scale = (
        body / _height(model)
        if body > 0
        else parent_bones[1] / parent_bones[0]
        if min(parent_bones) > 0
        else _height(clip) / _height(model)
    )

    def alike(a: int, theirs_bone: FloatArray) -> float:
        ours_bone = model.offsets[a] * scale
        sizes = float(np.linalg.norm(ours_bone)), float(np.linalg.norm(theirs_bone))
        if min(sizes) <= 0:
            return 0.0 if sizes[0] == sizes[1] else -2.0
        return float(ours_bone @ theirs_bone) / (sizes[0] * sizes[1]) - abs(
            float(np.log(sizes[1] / sizes[0]))
        )

    best_in: dict[tuple[int, int], tuple[float, int] | None] = {}  # per model child and branch
    for a in ours:
        for b in below:
            held = [
                (alike(a, clip.offset_from(theirs, c)) - FOLD_COST * folded, c)
                for folded, c in _chain(clip, b, fold)
                if _holds(model, clip, a, c, clip.offset_from(theirs, c), fold, memo)
            ]
            best_in[a, b] = max(held, key=lambda pair: pair[0]) if held else None
    best, best_score = None, -np.inf
    for order in itertools.permutations(below, len(ours)):
        pairs = [best_in[a, b] for a, b in zip(ours, order)]
        if all(pair is not None for pair in pairs):
            score = sum(pair[0] for pair in pairs if pair is not None)
            if score > best_score + 1e-9:
                best, best_score = [pair[1] for pair in pairs if pair is not None], score
    memo[key] = best
    return best


# a model end joint's bone read at a clip joint with joints below it is at least this share of the model's (each
# relative to its skeleton's size): shorter, the clip has a joint between (Neck, Neck1, Head under CMU names read
# Neck1 as the head, its bone 0 or half the model's, and carried the real head as an extra, 10 degrees off)
SHORTEST_END_BONE = 0.6


def _cut_short(model: Skeleton, clip: Skeleton, joint: int, bone: FloatArray) -> bool:
    """Whether a clip joint with bone `bone` from its parent's match, matched to the model's end joint
    `joint`, has a bone shorter than `SHORTEST_END_BONE` of the model's, each relative to its skeleton's
    standing height."""
    model_bone = float(np.linalg.norm(model.offsets[joint])) / _height(model)
    clip_bone = float(np.linalg.norm(bone)) / _height(clip)
    return model_bone > 0 and clip_bone < SHORTEST_END_BONE * model_bone


_HEIGHTS: weakref.WeakKeyDictionary[Skeleton, float] = weakref.WeakKeyDictionary()


def _height(skeleton: Skeleton) -> float:
    """The skeleton's `standing_height` (1 where it has none), found once per skeleton."""
    if skeleton not in _HEIGHTS:
        _HEIGHTS[skeleton] = standing_height(skeleton) or 1.0
    return _HEIGHTS[skeleton]


def _height_below(skeleton: Skeleton, top: int) -> float:
    """The `standing_height` of the skeleton's joints from `top` down, as a skeleton of their own; 0 where
    its legs are not found there."""

    def under(joint: int) -> bool:
        while joint >= 0 and joint != top:
            joint = int(skeleton.parents[joint])
        return joint == top

    joints = [top, *(joint for joint in range(skeleton.num_joints) if joint != top and under(joint))]
    index = {joint: at for at, joint in enumerate(joints)}
    below = Skeleton(
        tuple(skeleton.names[joint] for joint in joints),
        np.array([index.get(int(skeleton.parents[joint]), -1) for joint in joints]),
        skeleton.offsets[joints],
        skeleton.end_sites[joints],
    )
    return standing_height(below) if len(find_limbs(below).toes) else 0.0


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


def folded_joints(clip: Skeleton, joints: IntArray) -> list[int]:
    """The clip joints that lie between a matched joint of `joints` (J',) and its nearest matched ancestor
    (a third spine joint, a twist joint mid-arm), top down along each chain; not those above the first."""
    chains = folded_chains(clip, joints)  # a joint above several matched ones is in each of their chains
    return list(dict.fromkeys(joint for _, chain in chains for joint in chain))


def folded_chains(skeleton: Skeleton, joints: IntArray) -> list[tuple[int, list[int]]]:
    """For each matched joint (its place in `joints`) with folded joints above it: those joints, top down."""
    index = {int(joint): at for at, joint in enumerate(joints)}
    found = []
    for at, joint in enumerate(joints.tolist()[1:], start=1):
        chain, above = [], int(skeleton.parents[joint])
        while above >= 0 and above not in index:
            chain.append(above)
            above = int(skeleton.parents[above])
        if chain and above >= 0:
            found.append((at, chain[::-1]))
    return found
