"""Clips that lack some of a model's joints: a foot without a toe joint, a spine without a chest or a neck
joint, arms without collarbones. The model reads such a clip with each missing joint added at rest (no
rotation of its own, so every clip joint moves in the world as in the clip); the output is written without
them, each added joint's turn passed on to the joints below it, so they turn in the world as the output's.

Missing joints are found by the model's joint names (any joint whose parent and children the clip has), or,
where the names do not tell, as the toe joints of legs that end at the ankle.

    completion      which joints a clip lacks and where they go (`Completion`), or None
    completed       the clip with them added at rest
    uncompleted     an output on the completed skeleton, back on the clip's own
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastyle.core.body import find_limbs
from elastyle.core.motion import Motion
from elastyle.core.rotations import multiply
from elastyle.core.skeleton import Skeleton, bare_name
from elastyle.types import FloatArray, IntArray

MOST_MISSING = (
    6  # at most this many of the model's joints missing (two toes, a chest, a neck, two collarbones)
)
TOE_SUFFIX = "_toe"  # an added toe's name, found by the legs alone: its ankle's name and this


@dataclass(frozen=True, eq=False)
class Completion:
    """How a clip's skeleton is completed with the model's joints it lacks.

    skeleton: the completed skeleton (J' joints: the clip's and the added ones, parents first).
    source: (J',) each completed joint's clip joint, -1 for an added one.
    added: (A,) the added joints' places in `skeleton`; names: (A,) the model's names for them.
    """

    skeleton: Skeleton
    source: IntArray
    added: IntArray
    names: tuple[str, ...]


@dataclass(frozen=True)
class _Missing:
    """A model joint the clip lacks: its name in the completed skeleton, its parent's clip joint and its
    model children's clip joints (none for an end joint such as a toe), its place from the parent (clip
    units) and its End Site."""

    name: str
    model_name: str
    parent: int
    children: tuple[int, ...]
    offset: FloatArray
    end_site: FloatArray


def completion(model: Skeleton, clip: Skeleton) -> Completion | None:
    """The completion of a clip's skeleton with the model joints it lacks (`_by_name`, else `_toes_by_legs`),
    or None where it lacks none this way."""
    missing = _by_name(model, clip)
    if missing is None:
        missing = _toes_by_legs(model, clip)
    return None if not missing else _completed_skeleton(clip, missing)


def _by_name(model: Skeleton, clip: Skeleton) -> list[_Missing] | None:
    """The model's joints missing from a clip that has the others under their names (exactly, or without
    namespaces), each with its parent and all its children there, directly below the parent; None where
    the names tell no such thing."""
    for key in (str, bare_name):
        where = {key(name): joint for joint, name in enumerate(clip.names)}
        if len(where) < clip.num_joints:
            continue  # two joints of one name
        found = [where.get(key(name)) for name in model.names]
        first = next((at for at, joint in enumerate(found) if joint is not None), len(found))
        if first > model.pelvis:
            continue
        lacking = [joint for joint in range(first, model.num_joints) if found[joint] is None]
        if not lacking or len(lacking) > MOST_MISSING:
            continue
        missing = []
        for joint in lacking:
            parent = int(model.parents[joint])
            children = [found[child] for child in model.children(joint)]
            clip_parent = found[parent]
            if joint == model.pelvis or parent < first or clip_parent is None or None in children:
                break
            clip_children = [int(c) for c in children if c is not None]
            if any(int(clip.parents[child]) != clip_parent for child in clip_children):
                break
            missing.append(_placed(model, clip, joint, clip_parent, clip_children, model.names[joint]))
        else:
            return missing
    return None


def _toes_by_legs(model: Skeleton, clip: Skeleton) -> list[_Missing] | None:
    """Toe joints for a clip whose legs end at the ankle where the model's go on to a toe joint with no
    joints below it (`core.body.find_limbs`); None for any other clip."""
    ours, theirs = find_limbs(model), find_limbs(clip)
    if len(ours.toes) != 2 or len(theirs.toes) != 2 or np.any(theirs.toes != theirs.ankles):
        return None
    if np.any(ours.toes == ours.ankles) or any(model.children(int(toe)) for toe in ours.toes):
        return None
    if any(int(model.parents[toe]) != int(ankle) for toe, ankle in zip(ours.toes, ours.ankles)):
        return None
    taken = set(clip.names)
    names = [clip.names[int(ankle)] + TOE_SUFFIX for ankle in theirs.ankles]
    if taken.intersection(names):
        return None
    return [
        _placed(model, clip, int(toe), int(ankle), [], name)
        for toe, ankle, name in zip(ours.toes, theirs.ankles, names)
    ]


def _placed(
    model: Skeleton, clip: Skeleton, joint: int, parent: int, children: list[int], name: str
) -> _Missing:
    """The model's `joint` placed in the clip below the clip joint `parent`, above `children` (its model
    children's clip joints). Above children: where the model has it along each child's bone (the share of
    the way from the parent's place to the child's), the mean of those places. An end joint: along its
    parent's End Site where the clip has one, else the model's direction, its length the model's in
    proportion to the parents' bones (never beyond the End Site)."""
    model_parent = int(model.parents[joint])
    if children:
        places = []
        for child, model_child in zip(children, model.children(joint)):
            whole = float(np.linalg.norm(model.offsets[joint] + model.offsets[model_child]))
            share = float(np.linalg.norm(model.offsets[joint])) / whole if whole > 0 else 0.5
            places.append(clip.offsets[child] * share)
        return _Missing(name, model.names[joint], parent, tuple(children), np.mean(places, axis=0),
                        np.full(3, np.nan))  # fmt: skip
    scale = _scale(model, clip, model_parent, parent)
    length = float(np.linalg.norm(model.offsets[joint])) * scale
    tip = clip.end_sites[parent]
    model_end = model.end_sites[joint]
    if np.all(np.isfinite(tip)) and np.linalg.norm(tip) > 0:
        reach = float(np.linalg.norm(tip))
        offset = tip * min(length, reach) / reach
        end = tip - offset if reach > length else np.full(3, np.nan)
    else:
        size = float(np.linalg.norm(model.offsets[joint]))
        offset = model.offsets[joint] * (length / size if size > 0 else 0.0)
        end = model_end * scale
    return _Missing(name, model.names[joint], parent, (), offset, end)


def _scale(model: Skeleton, clip: Skeleton, model_joint: int, clip_joint: int) -> float:
    """Clip units per model unit, from the two joints' bones from their parents (1 where one has none)."""
    ours = float(np.linalg.norm(model.offsets[model_joint]))
    theirs = float(np.linalg.norm(clip.offsets[clip_joint]))
    return theirs / ours if ours > 0 and theirs > 0 else 1.0


def _completed_skeleton(clip: Skeleton, missing: list[_Missing]) -> Completion:
    """The clip's skeleton with the missing joints added: each before the first of its children (an end
    joint after its parent's last descendant), its children's offsets made from it."""
    before: dict[int, list[_Missing]] = {}  # clip joint -> the added joints placed just before it
    after: dict[int, list[_Missing]] = {}  # clip joint -> the added end joints placed just after it
    for lacking in missing:
        if lacking.children:
            before.setdefault(min(lacking.children), []).append(lacking)
        else:
            after.setdefault(_last_below(clip, lacking.parent), []).append(lacking)
    source: list[int] = []
    entries: list[_Missing | None] = []
    for joint in range(clip.num_joints):
        for new in before.get(joint, []):
            source.append(-1)
            entries.append(new)
        source.append(joint)
        entries.append(None)
        for new in after.get(joint, []):
            source.append(-1)
            entries.append(new)
    place = {clip_joint: at for at, clip_joint in enumerate(source) if clip_joint >= 0}
    added_place = {id(entry): at for at, entry in enumerate(entries) if entry is not None}
    new_parent = {child: added_place[id(m)] for m in missing for child in m.children}
    above = {child: m.offset for m in missing for child in m.children}
    parents, offsets, ends, names = [], [], [], []
    for clip_joint, entry in zip(source, entries):
        if entry is not None:
            parents.append(place[entry.parent])
            offsets.append(entry.offset)
            ends.append(entry.end_site)
            names.append(entry.name)
            continue
        parent = int(clip.parents[clip_joint])
        parents.append(new_parent.get(clip_joint, place[parent] if parent >= 0 else -1))
        offsets.append(clip.offsets[clip_joint] - above.get(clip_joint, 0.0))
        ends.append(clip.end_sites[clip_joint])
        names.append(clip.names[clip_joint])
    ends_array = np.array(ends, dtype=np.float64)
    for m in missing:
        if not m.children:  # an end joint added: its parent's End Site is now its own
            ends_array[place[m.parent]] = np.nan
    skeleton = Skeleton(
        tuple(names), np.array(parents, dtype=np.int64), np.array(offsets, dtype=np.float64), ends_array,
        clip.unit_cm,
    )  # fmt: skip
    added = np.array([added_place[id(m)] for m in missing], dtype=np.int64)
    return Completion(skeleton, np.array(source, dtype=np.int64), added, tuple(m.model_name for m in missing))


def _last_below(skeleton: Skeleton, joint: int) -> int:
    """The last joint (file order) of the joint's subtree."""
    last = joint
    for other in range(joint + 1, skeleton.num_joints):
        above = other
        while above > joint:
            above = int(skeleton.parents[above])
        if above == joint:
            last = other
    return last


def completed(motion: Motion, completion: Completion) -> Motion:
    """The clip (T frames) on the completed skeleton: the added joints unrotated at their places, the
    joints below them moved into their frames (so nothing moves in the world)."""
    skeleton = completion.skeleton
    clip = np.maximum(completion.source, 0)
    rotations = motion.rotations[:, clip].copy()  # (T, J', 3)
    translations = motion.translations[:, clip].copy()
    rotations[:, completion.added] = 0.0
    translations[:, completion.added] = skeleton.offsets[completion.added]
    for added in completion.added.tolist():
        for child in skeleton.children(added):
            translations[:, child] -= skeleton.offsets[added]
    return Motion(skeleton, rotations, translations, motion.fps)


def uncompleted(motion: Motion, clip: Skeleton, completion: Completion) -> Motion:
    """An output on the completed skeleton (N frames) on the clip's own: each added joint's rotation passed
    on to the joints below it (they turn in the world as the output's; their places keep the clip's bones),
    the added joints left out."""
    skeleton = completion.skeleton
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    for added in completion.added.tolist():
        for child in skeleton.children(added):
            rotations[:, child] = multiply(rotations[:, added], rotations[:, child])
            translations[:, child] += skeleton.offsets[added]
    kept = np.flatnonzero(completion.source >= 0)
    order = np.argsort(completion.source[kept])  # back in the clip's order
    return Motion(clip, rotations[:, kept[order]], translations[:, kept[order]], motion.fps)
