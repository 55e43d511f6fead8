"""Clips of a model's skeleton with joints the model lacks (fingers, props, tips exported as joints, a third
spine joint, a twist joint mid-arm), or its joints listed in another order. Every model joint is in the clip
under its own name (or the same name after a `namespace:` prefix), or found by the hierarchy, below the
match of its model parent; the clip's other joints hang below model joints (or above the model's top joint,
an exporter's `Armature`: their world transform is taken into it), or lie between a model joint and its
model parent (folded: the model reads the chain between the two as one bone, its rotations and translations
composed, so every model joint moves in the world as in the clip). The transfer reads the model's joints
alone, in the model's order; the output carries the others as the content performs them, at the output's
moments, and lists every joint in the clip's order.

    model_joints_in       (J_model,) each model joint's index in the clip, or None
    folded_joints         a clip's joints between two of the model's
    without_extra_joints  the clip on the model's joints alone
    with_extra_joints     an output on the model's joints, back on the clip's whole skeleton
"""

from __future__ import annotations

import itertools
import weakref

import numpy as np

from elastyle.core.body import find_limbs, standing_height
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
    matched by the hierarchy (`_by_hierarchy`), for the caller to check as the model's skeleton under other
    names (`core.body.same_structure`)."""
    key = (_skeleton_key(model), _skeleton_key(clip))
    if key not in _MATCHES:
        if len(_MATCHES) >= MATCHES_KEPT:
            _MATCHES.clear()
        joints = _model_joints_in(model, clip)
        if joints is not None:
            joints.setflags(write=False)  # shared by every caller
        _MATCHES[key] = joints
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


def folded_joints(clip: Skeleton, joints: IntArray) -> list[int]:
    """The clip joints that lie between a matched joint of `joints` (J',) and its nearest matched ancestor
    (a third spine joint, a twist joint mid-arm), top down along each chain; not those above the first."""
    return [joint for _, chain in _folded_above(clip, joints) for joint in chain]


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


def _by_hierarchy(model: Skeleton, clip: Skeleton) -> IntArray | None:
    """`model_joints_in` under other names: the clip's root taken for the model's joint k (0, or a joint of
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
    joints = _tree(model, clip, fold=False)
    if joints is not None:
        return joints
    joints = _tree(model, clip, fold=True)
    return joints if joints is not None and folded_joints(clip, joints) else None  # else read as before


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


def _chain(clip: Skeleton, child: int, fold: bool) -> list[int]:
    """The clip joints that may match a model joint below the clip child `child`'s parent: the child, and
    with `fold` the joints down its chain of single children (at most `MOST_FOLDED` below it)."""
    chain = [child]
    while fold and len(chain) <= MOST_FOLDED and len(clip.children(chain[-1])) == 1:
        chain.append(clip.children(chain[-1])[0])
    return chain


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
    if key not in memo:
        memo[key] = _choose(model, clip, joint, theirs, bone, fold, memo)
    return memo[key]


def _choose(
    model: Skeleton,
    clip: Skeleton,
    joint: int,
    theirs: int,
    bone: FloatArray,
    fold: bool,
    memo: _Memo,
) -> list[int] | None:
    """`_chosen`, not looked up."""
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
                for folded, c in enumerate(_chain(clip, b, fold))
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


def without_extra_joints(motion: Motion, joints: IntArray) -> Motion:
    """The clip (T, J frames and joints) on its joints `joints` (J',) alone, in that order: their local
    rotations and translations unchanged, as the model reads them, but for the first's where extra joints
    lie above it (an exporter's `Armature` above the hips): their world transform taken into it, and for a
    joint with joints folded above it (`folded_joints`): their transforms composed into its own, its offset
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
    for at, chain in _folded_above(skeleton, joints):
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
    for at, chain in _folded_above(clip_at.skeleton, joints):
        turn, _ = _composed(clip_at, chain)
        joint = joints[at]
        rotations[:, joint] = from_matrix(np.swapaxes(turn, -1, -2) @ to_matrix(motion.rotations[:, at]))
        translations[:, joint] = clip_at.translations[:, joint]
    above = int(clip_at.skeleton.parents[joints[0]])
    if above >= 0:  # from the world's frame into the frame of the joint above
        top = joints[0]
        rotations[:, top], translations[:, top] = below(
            clip_at, above, motion.rotations[:, 0], motion.translations[:, 0]
        )
    return Motion(clip_at.skeleton, rotations, translations, motion.fps)


def _folded_above(skeleton: Skeleton, joints: IntArray) -> list[tuple[int, list[int]]]:
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


def _composed(motion: Motion, chain: list[int]) -> tuple[FloatArray, FloatArray]:
    """The transform of a chain of joints (top down, each the next one's parent) in the frame of the first's
    parent: rotation matrices (T, 3, 3) and the last joint's position (T, 3)."""
    turn = np.broadcast_to(np.eye(3), (motion.num_frames, 3, 3))
    shift = np.zeros((motion.num_frames, 3))
    for joint in chain:
        shift = shift + np.einsum("tij,tj->ti", turn, motion.translations[:, joint])
        turn = turn @ to_matrix(motion.rotations[:, joint])
    return turn, shift
