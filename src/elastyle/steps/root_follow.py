"""The root following the stride: the pelvis moved horizontally so that planted feet drift less, before
the feet are pinned (`steps.cleanup`). Axes +Y up; lengths in the file's unit."""

from __future__ import annotations

import numpy as np

from elastyle.core.body import Limbs, find_limbs, leg_length
from elastyle.core.motion import Motion
from elastyle.core.rotations import lengths
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import smooth
from elastyle.steps.contacts import checked_contacts, pivots
from elastyle.steps.leg_ik import is_below
from elastyle.types import BoolArray, FloatArray

ROOT_TOLERANCE_OF_PATH = 0.1  # the adjusted root strays at most this fraction of the path's length from it
SMOOTH_SIGMA_OF_WIDTH = 0.4  # a window's half-width w is smoothed by a Gaussian of sigma 0.4 w


def adjust_root_speed(
    motion: Motion,
    contacts: BoolArray,
    share: float = 1.0,
    smooth_s: float = 0.2,
    tolerance: float = ROOT_TOLERANCE_OF_PATH,
) -> Motion:
    """Move the pelvis horizontally so that planted feet drift less: the root advances with the stride.

    contacts: (T, F) planted feet. Each frame step, the mean horizontal step (file units) of the feet held
    at both frames (weighted as in `clean_feet`), low-passed over about `smooth_s` seconds, times `share`
    (1: all of it, the feet stop drifting; 0.5: half, the legs' IK in `clean_feet` takes the rest), is taken
    off the pelvis path; steps with no foot planted keep theirs. The share is lowered where needed so that
    the root never strays further than `tolerance` of the path's horizontal length from the path it was
    given (its shape and end point kept within 10 % by default). Run it before `clean_feet`.
    """
    limbs = find_limbs(motion.skeleton)
    contacts = checked_contacts(contacts, motion, limbs)
    if motion.num_frames < 2 or contacts.shape[1] == 0:
        return Motion(motion.skeleton, motion.rotations.copy(), motion.translations.copy(), motion.fps)
    world = motion.world(limbs.feet)
    shift = root_shift(motion, contacts, world, share, smooth_s, tolerance)
    return Motion(motion.skeleton, motion.rotations.copy(), shift_pelvis(motion, world[0], shift), motion.fps)


def root_shift(
    motion: Motion,
    contacts: BoolArray,
    world: tuple[FloatArray, FloatArray],
    share: float | FloatArray,
    smooth_s: float = 0.2,
    tolerance: float = ROOT_TOLERANCE_OF_PATH,
) -> FloatArray:
    """(T, 3) world: how `adjust_root_speed` moves the pelvis, from the clip's world rotations and
    positions of the feet and their ancestors (`Motion.world`)."""
    limbs = find_limbs(motion.skeleton)
    positions = world[1]
    points, weights = pivots(positions, limbs, leg_length(motion.skeleton, limbs))  # (T, F, 2, 3), (T, F, 2)
    planted = (contacts[1:] & contacts[:-1])[..., None] * 0.5 * (weights[1:] + weights[:-1])  # (T-1, F, 2)
    steps = np.sum(planted[..., None] * np.diff(points, axis=0), axis=(1, 2))  # (T-1, 3)
    drift = steps / np.maximum(planted.sum(axis=(1, 2)), 1.0)[:, None]  # (T-1, 3) mean planted-foot step
    drift[:, 1] = 0.0
    drift = smooth(drift, SMOOTH_SIGMA_OF_WIDTH * smooth_s * motion.fps)
    per_step = np.broadcast_to(np.asarray(share, dtype=np.float64), (motion.num_frames,))[
        1:, None
    ]  # (T-1, 1)
    shift = -np.concatenate([np.zeros((1, 3)), np.cumsum(per_step * drift, axis=0)])  # (T, 3) world
    path = np.sum(lengths(np.diff(positions[:, motion.skeleton.pelvis, [0, 2]], axis=0)))
    furthest = np.max(lengths(shift), initial=0.0)
    if furthest > tolerance * path:
        shift *= tolerance * path / furthest
    return shift


def carried_by_pelvis(skeleton: Skeleton, limbs: Limbs) -> list[int]:
    """The feet and their ancestors that move with the pelvis (the pelvis and the joints below it)."""
    return [j for j in skeleton.with_ancestors(limbs.feet).tolist() if is_below(skeleton, j, skeleton.pelvis)]


def shift_pelvis(motion: Motion, world_rotations: FloatArray, shift: FloatArray) -> FloatArray:
    """Translations (T, J, 3) with the pelvis moved by `shift` (T, 3), world frame, file units."""
    pelvis, parent = motion.skeleton.pelvis, motion.skeleton.parents[motion.skeleton.pelvis]
    if parent >= 0:  # the pelvis translation is in its parent's frame
        shift = np.einsum("tji,tj->ti", world_rotations[:, parent], shift)
    translations = motion.translations.copy()
    translations[:, pelvis] += shift
    return translations
