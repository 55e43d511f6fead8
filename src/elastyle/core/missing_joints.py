"""Clips that lack some of a model's joints: a foot without a toe joint, a spine without a chest or a neck
joint, arms without collarbones. The model reads such a clip with each missing joint added at rest (no
rotation of its own, so every clip joint moves in the world as in the clip); the output is written without
them, each added joint's turn passed on to the joints below it, so they turn in the world as the output's.

Missing joints are found by the model's joint names (toes, spine joints below the head, collarbones, each
whose parent and children the clip has), or, where the names do not tell, as the toe joints of legs that
end at the ankle. A rig without a hand, an elbow, a knee or an ankle, or without two joints in a row, is
not read this way.

    completion      which joints a clip lacks and where they go (`Completion`), or None
    completed       the clip with them added at rest
    uncompleted     an output on the completed skeleton, back on the clip's own
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastyle.core.body import find_limbs
from elastyle.core.motion import Motion
from elastyle.core.parts import rest_pose_stands, trunk
from elastyle.core.rest_frames import best_rotation
from elastyle.core.rotations import multiply
from elastyle.core.skeleton import Skeleton, bare_name
from elastyle.types import FloatArray, IntArray

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


def completion(model: Skeleton, clip: Skeleton, pose: FloatArray | None = None) -> Completion | None:
    """The completion of a clip's skeleton with the model joints it lacks (`_by_name`, else `_toes_by_legs`),
    or None where it lacks none this way. pose: the model's typical pose (J_model, 3, 3) world rotations, which
    places a toe on a rig that rests standing (`_placed`)."""
    missing = _by_name(model, clip, pose)
    if missing is None and not _named_mostly(model, clip):  # else the names tell what it lacks
        missing = _toes_by_legs(model, clip, pose)
    return None if not missing else _completed_skeleton(clip, missing)


def _named_mostly(model: Skeleton, clip: Skeleton) -> bool:
    """Whether the clip has at least half the model's joint names (exactly, or without namespaces)."""
    names = {bare_name(name) for name in clip.names}
    return 2 * sum(bare_name(name) in names for name in model.names) >= model.num_joints


def optional_joints(model: Skeleton) -> set[int]:
    """The model joints a rig may lack: toe joints below the ankles (with no joints below them), the trunk's
    joints between the pelvis and its top (a spine, a chest, a neck joint; not the head), and the arms' roots
    above a chain of three (collarbones). Not a hand, an elbow, a knee or an ankle: a rig without one is
    not the model's body."""
    limbs = find_limbs(model)
    toes = {
        int(toe) for toe, ankle in zip(limbs.toes, limbs.ankles) if toe != ankle and not model.children(toe)
    }
    spine = {joint for joint in trunk(model) if model.children(joint)}
    collarbones = {
        int(root)
        for root in limbs.arm_roots
        if len(model.children(root)) == 1 and _depth(model, int(root)) >= 3
    }
    return toes | spine | collarbones


def _depth(skeleton: Skeleton, joint: int) -> int:
    """How many joints the longest chain below `joint` holds."""
    return max((1 + _depth(skeleton, child) for child in skeleton.children(joint)), default=0)


def _by_name(model: Skeleton, clip: Skeleton, pose: FloatArray | None) -> list[_Missing] | None:
    """The model's joints missing from a clip that has the others under their names (exactly, or without
    namespaces): each an `optional_joints` one whose parent and every child the clip has, the children
    directly below the parent; None where the names tell no such thing."""
    optional = optional_joints(model)
    for key in (str, bare_name):
        where = {key(name): joint for joint, name in enumerate(clip.names)}
        if len(where) < clip.num_joints:
            continue  # two joints of one name
        found = [where.get(key(name)) for name in model.names]
        first = next((at for at, joint in enumerate(found) if joint is not None), len(found))
        if first > model.pelvis:
            continue
        lacking = [joint for joint in range(first, model.num_joints) if found[joint] is None]
        if not lacking or not optional.issuperset(lacking):
            continue
        missing = []
        for joint in lacking:
            parent = int(model.parents[joint])
            children = [found[child] for child in model.children(joint)]
            clip_parent = found[parent]
            if parent < first or clip_parent is None or None in children:
                break
            clip_children = [int(c) for c in children if c is not None]
            if any(int(clip.parents[child]) != clip_parent for child in clip_children):
                break
            missing.append(_placed(model, clip, joint, clip_parent, clip_children, model.names[joint], pose))
        else:
            return missing
    return None


def _toes_by_legs(model: Skeleton, clip: Skeleton, pose: FloatArray | None) -> list[_Missing] | None:
    """Toe joints below the ankles of a clip's legs that end there, where the model's legs go on to a toe
    joint (`optional_joints`), each leg paired with the model's whose rest direction from the pelvis is most
    alike (`core.body.find_limbs`); None for any other clip."""
    ours, theirs = find_limbs(model), find_limbs(clip)
    if len(ours.toes) != 2 or len(theirs.toes) != 2:
        return None
    optional = optional_joints(model)

    def alike(model_ankle: int, clip_ankle: int) -> float:
        a = model.offset_from(model.pelvis, model_ankle)
        b = clip.offset_from(clip.pelvis, clip_ankle)
        sizes = float(np.linalg.norm(a) * np.linalg.norm(b))
        return float(a @ b) / sizes if sizes > 0 else 0.0

    order = [0, 1]
    if alike(int(ours.ankles[0]), int(theirs.ankles[1])) + alike(
        int(ours.ankles[1]), int(theirs.ankles[0])
    ) > (
        alike(int(ours.ankles[0]), int(theirs.ankles[0])) + alike(int(ours.ankles[1]), int(theirs.ankles[1]))
    ):
        order = [1, 0]
    missing = []
    for toe, side in zip(ours.toes.tolist(), order):
        ankle = int(theirs.ankles[side])
        if int(theirs.toes[side]) != ankle:
            continue  # this leg has its toe
        name = clip.names[ankle] + TOE_SUFFIX
        if toe not in optional or name in clip.names:
            return None
        missing.append(_placed(model, clip, toe, ankle, [], name, pose))
    return missing or None


def _placed(
    model: Skeleton,
    clip: Skeleton,
    joint: int,
    parent: int,
    children: list[int],
    name: str,
    pose: FloatArray | None = None,
) -> _Missing:
    """The model's `joint` placed in the clip below the clip joint `parent`, above `children` (its model
    children's clip joints). Above children: the model's place for it from its parent, turned by the turn
    that best takes the model's bones from the parent to the children onto the clip's and scaled by their
    lengths. An end joint (a toe): along its parent's End Site where the clip has one, else the model's
    direction turned as the parents' bones are (on a rig that rests standing, `core.parts.rest_pose_stands`,
    the direction in the model's typical pose `pose` so turned: a foot's toe points forward, where the
    model's rest lies along its shin); as long as the model's in proportion to the parents' bones."""
    model_parent = int(model.parents[joint])
    if children:
        model_bones = np.array([model.offsets[joint] + model.offsets[c] for c in model.children(joint)])
        clip_bones = clip.offsets[children]
        usable = (np.linalg.norm(model_bones, axis=1) > 0) & (np.linalg.norm(clip_bones, axis=1) > 0)
        if not np.any(usable):
            return _Missing(
                name, model.names[joint], parent, tuple(children), np.zeros(3), np.full(3, np.nan)
            )
        turn = best_rotation(model_bones[usable], clip_bones[usable])
        scale = float(
            np.mean(np.linalg.norm(clip_bones[usable], axis=1) / np.linalg.norm(model_bones[usable], axis=1))
        )
        return _Missing(name, model.names[joint], parent, tuple(children), scale * turn @ model.offsets[joint],
                        np.full(3, np.nan))  # fmt: skip
    ours, theirs = model.offsets[model_parent], clip.offsets[parent]
    known = float(np.linalg.norm(ours)) > 0 and float(np.linalg.norm(theirs)) > 0
    scale = float(np.linalg.norm(theirs) / np.linalg.norm(ours)) if known else 1.0
    frame = np.eye(3)  # the parent's frame the model's offsets are read in: its rest's, or the typical pose's
    if pose is not None and model_parent > 0 and rest_pose_stands(clip):
        ours, frame = pose[int(model.parents[model_parent])] @ ours, pose[model_parent]
    turn = (best_rotation(ours[None], theirs[None]) if known else np.eye(3)) @ frame
    offset = scale * turn @ model.offsets[joint]
    tip = clip.end_sites[parent]
    if np.all(np.isfinite(tip)) and np.linalg.norm(tip) > 0:
        offset = tip * float(np.linalg.norm(offset) / np.linalg.norm(tip))
    end = scale * turn @ model.end_sites[joint]  # NaN where the model's has none
    return _Missing(name, model.names[joint], parent, (), offset, end)


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
