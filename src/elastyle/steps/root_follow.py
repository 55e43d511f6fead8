"""The root following the stride: the pelvis moved horizontally so that planted feet drift less, before
the feet are pinned (`steps.cleanup`). Axes +Y up; lengths in the file's unit."""

from __future__ import annotations

import numpy as np

from elastyle.core.body import Limbs, find_limbs, leg_length
from elastyle.core.motion import Motion
from elastyle.core.rotations import lengths
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import frame_steps, smooth, smoothstep
from elastyle.steps.contacts import checked_contacts, pivots
from elastyle.steps.leg_ik import is_below
from elastyle.types import BoolArray, FloatArray

# the adjusted root strays at most this many leg lengths from the path it was given, and this share of the
# path's length (where it would stray further, it follows a smaller share of the drift throughout: bounded
# frame by frame, the root of a run stopped following, and the legs taking all of the drift looked less real):
# a clip of any length ends within it of its own end (with the share alone, a 60 s walk ended 6.7 m short)
ROOT_STRAY_LEGS = 1.5
ROOT_STRAY_OF_PATH = 0.1
SMOOTH_SIGMA_OF_WIDTH = 0.4  # a window's half-width w is smoothed by a Gaussian of sigma 0.4 w
# the root follows the feet where the pelvis's path travels: from none below the first speed to all above the
# second (leg lengths per second, the path's speed smoothed over `TRAVEL_SMOOTH_S`): in a stand the feet's
# sway is left to the legs' IK and the pelvis stays where the path puts it (following it, the pelvis of a
# walk that stopped for 2 s glided 14 cm forward and back over its planted feet)
TRAVEL_LEGS_S = (0.15, 0.35)
TRAVEL_SMOOTH_S = 0.25


def adjust_root_speed(
    motion: Motion,
    contacts: BoolArray,
    share: float = 1.0,
    smooth_s: float = 0.2,
    tolerance: float = ROOT_STRAY_OF_PATH,
    stray_legs: float = ROOT_STRAY_LEGS,
) -> Motion:
    """Move the pelvis horizontally so that planted feet drift less: the root advances with the stride.

    contacts: (T, F) planted feet. Each frame step where the pelvis travels, the mean horizontal step (file
    units) of the feet held at both frames (weighted as in `clean_feet`), low-passed over about `smooth_s`
    seconds, times `share` (1: all of it, the feet stop drifting; 0.5: half, the legs' IK in `clean_feet`
    takes the rest), is taken off the pelvis path; steps with no foot planted keep theirs. The pelvis strays
    at most `tolerance` of the path's length and `stray_legs` leg lengths from the path it was given
    (`root_shift`). Run it before
    `clean_feet`.
    """
    limbs = find_limbs(motion.skeleton)
    contacts = checked_contacts(contacts, motion, limbs)
    if motion.num_frames < 2 or contacts.shape[1] == 0:
        return Motion(motion.skeleton, motion.rotations.copy(), motion.translations.copy(), motion.fps)
    world = motion.world(limbs.feet)
    shift = root_shift(motion, contacts, world, share, smooth_s, tolerance, stray_legs)
    return Motion(motion.skeleton, motion.rotations.copy(), shift_pelvis(motion, world[0], shift), motion.fps)


def root_shift(
    motion: Motion,
    contacts: BoolArray,
    world: tuple[FloatArray, FloatArray],
    share: float | FloatArray,
    smooth_s: float = 0.2,
    tolerance: float = ROOT_STRAY_OF_PATH,
    stray_legs: float = ROOT_STRAY_LEGS,
    applied: FloatArray | None = None,
    moved: FloatArray | None = None,
) -> FloatArray:
    """(T, 3) world: how `adjust_root_speed` moves the pelvis, from the clip's world rotations and
    positions of the feet and their ancestors (`Motion.world`). share: a number or (T,) per frame.

    The running sum of the planted feet's drift times `share` where the pelvis travels (`TRAVEL_LEGS_S`),
    bounded to `tolerance` of the path's length and `stray_legs` leg lengths, then times
    `applied` (T,) per frame where given: how far the clip takes it (a transfer's strength: fading out, the
    pelvis comes back to its path step by step over planted feet instead of sliding them back at the end).
    moved: (T, 3) world, where given, how far the pelvis has already been moved off its path (an earlier
    clean-up's move): the two together keep within the bound, the new move scaled as a whole."""
    limbs = find_limbs(motion.skeleton)
    leg = leg_length(motion.skeleton, limbs)
    positions = world[1]
    points, weights = pivots(positions, limbs, leg)  # (T, F, 2, 3), (T, F, 2)
    planted = (contacts[1:] & contacts[:-1])[..., None] * 0.5 * (weights[1:] + weights[:-1])  # (T-1, F, 2)
    steps = np.sum(planted[..., None] * np.diff(points, axis=0), axis=(1, 2))  # (T-1, 3)
    drift = steps / np.maximum(planted.sum(axis=(1, 2)), 1.0)[:, None]  # (T-1, 3) mean planted-foot step
    drift[:, 1] = 0.0
    drift = smooth(drift, SMOOTH_SIGMA_OF_WIDTH * smooth_s * motion.fps)
    travel = _travelling(positions[:, motion.skeleton.pelvis], leg, motion.fps)  # (T,) 0 to 1
    per_frame = np.broadcast_to(np.asarray(share, dtype=np.float64), (motion.num_frames,)) * travel
    per_step = (0.5 * (per_frame[1:] + per_frame[:-1]))[:, None]  # (T-1, 1)
    shift = -np.concatenate([np.zeros((1, 3)), np.cumsum(per_step * drift, axis=0)])  # (T, 3) world
    path = np.sum(lengths(np.diff(positions[:, motion.skeleton.pelvis, [0, 2]], axis=0)))
    furthest, bound = np.max(lengths(shift), initial=0.0), min(stray_legs * leg, tolerance * path)
    if furthest > bound:  # scaled as a whole: the root follows a smaller share of the drift throughout
        shift *= bound / furthest
    if applied is not None:
        shift = shift * np.asarray(applied, dtype=np.float64)[:, None]
    return shift if moved is None else shift * _within(moved, shift, bound)


def _within(moved: FloatArray, shift: FloatArray, bound: float) -> float:
    """The largest share k in [0, 1] of `shift` (T, 3) that keeps `moved` + k `shift` within `bound` of the path
    at every frame (0 where `moved` alone is beyond it)."""
    squared = np.sum(shift**2, axis=-1)  # (T,) |s|^2
    along = np.sum(moved * shift, axis=-1)  # (T,) m . s
    room = bound**2 - np.sum(moved**2, axis=-1)  # (T,) B^2 - |m|^2
    if np.any(room < 0):
        return 0.0
    moving = squared > 0  # |m + k s| <= B up to the larger root of |s|^2 k^2 + 2 (m . s) k - room
    roots = (-along[moving] + np.sqrt(along[moving] ** 2 + squared[moving] * room[moving])) / squared[moving]
    return float(np.clip(np.min(roots, initial=1.0), 0.0, 1.0))


def _travelling(pelvis: FloatArray, leg: float, fps: float) -> FloatArray:
    """(T,) 0 to 1 where the pelvis's path (T, 3) travels (`TRAVEL_LEGS_S`, eased)."""
    speed = lengths(frame_steps(pelvis[:, [0, 2]])) * fps / leg  # (T,) leg lengths per second
    speed = smooth(speed, TRAVEL_SMOOTH_S * fps)
    low, high = TRAVEL_LEGS_S
    return smoothstep((speed - low) / (high - low))


def carried_by_pelvis(skeleton: Skeleton, limbs: Limbs) -> list[int]:
    """The feet and their ancestors that move with the pelvis (the pelvis and the joints below it)."""
    return [j for j in skeleton.with_ancestors(limbs.feet).tolist() if is_below(skeleton, j, skeleton.pelvis)]


def ground_shift(before: Motion, after: Motion) -> FloatArray:
    """(T, 3) world, file units: how far `after` moves the pelvis of `before` (the same T frames, the joints
    above the pelvis alike) on the ground, heights 0."""
    pelvis, parent = before.skeleton.pelvis, before.skeleton.parents[before.skeleton.pelvis]
    shift = after.translations[:, pelvis] - before.translations[:, pelvis]
    if parent >= 0:  # the pelvis translation is in its parent's frame
        shift = np.einsum("tij,tj->ti", before.world([parent])[0][:, parent], shift)
    shift[:, 1] = 0.0
    return shift


def shifted_pelvis(motion: Motion, shift: FloatArray) -> Motion:
    """The clip with its pelvis moved by `shift` (T, 3), world frame, file units."""
    parent = motion.skeleton.parents[motion.skeleton.pelvis]
    world_rotations = motion.world([parent])[0] if parent >= 0 else np.zeros((0, 0, 3, 3))
    return Motion(motion.skeleton, motion.rotations, shift_pelvis(motion, world_rotations, shift), motion.fps)


def shift_pelvis(motion: Motion, world_rotations: FloatArray, shift: FloatArray) -> FloatArray:
    """Translations (T, J, 3) with the pelvis moved by `shift` (T, 3), world frame, file units."""
    pelvis, parent = motion.skeleton.pelvis, motion.skeleton.parents[motion.skeleton.pelvis]
    if parent >= 0:  # the pelvis translation is in its parent's frame
        shift = np.einsum("tji,tj->ti", world_rotations[:, parent], shift)
    translations = motion.translations.copy()
    translations[:, pelvis] += shift
    return translations
