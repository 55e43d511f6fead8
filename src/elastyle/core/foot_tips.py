"""Feet without a toe joint: the foot's End Site read as a toe where the clean-up and the metrics read feet.

On a rig whose leg ends at the ankle (its foot an End Site: `core.body.find_limbs` takes the ankle for the
toe too), contacts, pins and the floor read the heel alone, and the ball of the foot turned about it slid
(10 cm/s on a trained rig's walk where the dataset's rig, with toe joints, slid 0.3). Here each such foot's
End Site becomes a joint of its own, a child of the ankle appended after the skeleton's joints, with no
rotation of its own: it moves rigidly with the foot, and the legs' IK, which turns hips, knees and ankles,
carries it. Work done on the extended clip is read back on the clip's own joints (`on_own_joints`).
"""

from __future__ import annotations

import weakref

import numpy as np

from elastyle.core.body import find_limbs
from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.types import FloatArray

TIP_SUFFIX = "_foot_tip"  # the added joints' names: the ankle's name and this

_EXTENDED: weakref.WeakKeyDictionary[Skeleton, Skeleton] = weakref.WeakKeyDictionary()


def _toeless_ankles(skeleton: Skeleton) -> list[int]:
    """The ankles (file order) of feet with no toe joint whose End Site gives the foot a length."""
    limbs = find_limbs(skeleton)
    tips = skeleton.end_sites
    return [
        int(ankle)
        for toe, ankle in zip(limbs.toes.tolist(), limbs.ankles.tolist())
        if toe == ankle and np.all(np.isfinite(tips[ankle])) and np.linalg.norm(tips[ankle]) > 0
    ]


def extended_skeleton(skeleton: Skeleton) -> Skeleton:
    """The skeleton with each toe-less foot's End Site as a joint (the skeleton itself where none is
    toe-less); computed once per skeleton."""
    if skeleton not in _EXTENDED:
        ankles = _toeless_ankles(skeleton)
        if not ankles:
            _EXTENDED[skeleton] = skeleton
        else:
            end_sites = skeleton.end_sites.copy()
            end_sites[ankles] = np.nan  # the End Site is now the tip joint's
            _EXTENDED[skeleton] = Skeleton(
                (*skeleton.names, *(skeleton.names[a] + TIP_SUFFIX for a in ankles)),
                np.concatenate([skeleton.parents, ankles]),
                np.concatenate([skeleton.offsets, skeleton.end_sites[ankles]]),
                np.concatenate([end_sites, np.full((len(ankles), 3), np.nan)]),
                skeleton.unit_cm,
            )
    return _EXTENDED[skeleton]


def with_foot_tips(motion: Motion) -> Motion:
    """The clip (T frames) on `extended_skeleton`: the tip joints unrotated at their End Site offsets; the
    clip itself where no foot is toe-less."""
    extended = extended_skeleton(motion.skeleton)
    if extended is motion.skeleton:
        return motion
    added = extended.num_joints - motion.skeleton.num_joints
    rotations = np.concatenate([motion.rotations, np.zeros((motion.num_frames, added, 3))], axis=1)
    offsets = np.broadcast_to(extended.offsets[motion.skeleton.num_joints :], (motion.num_frames, added, 3))
    translations = np.concatenate([motion.translations, offsets], axis=1)
    return Motion(extended, rotations, translations, motion.fps)


def on_own_joints(extended: Motion, skeleton: Skeleton) -> Motion:
    """A clip on `extended_skeleton(skeleton)` read back on `skeleton`'s joints (the clip itself where the
    two are one)."""
    if extended.skeleton is skeleton:
        return extended
    joints = skeleton.num_joints
    return Motion(skeleton, extended.rotations[:, :joints], extended.translations[:, :joints], extended.fps)


def with_foot_tip_positions(motion: Motion, positions: FloatArray | None) -> tuple[Motion, FloatArray]:
    """`with_foot_tips` and its world positions (T, J', 3): `positions` (T, J, 3) of the clip's own joints,
    when known, serve where no joint is added."""
    extended = with_foot_tips(motion)
    if positions is None or extended is not motion:
        positions = extended.positions()
    return extended, positions
