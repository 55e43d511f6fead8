"""Foot contacts: which feet are planted when, and which point of a foot (toe or ankle) carries it.

Axes +Y up; lengths stay in the file's unit. Thresholds are fractions of the leg length (hip to ankle at
rest, per second for speeds) above the clip's own ground level (a low percentile of each foot joint's
height), so metres, centimetres and inches behave alike.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from elastyle.core.body import Limbs, find_limbs, leg_length
from elastyle.core.motion import Motion
from elastyle.core.rotations import lengths
from elastyle.core.smoothing import frame_steps
from elastyle.types import BoolArray, FloatArray

GROUND_PERCENTILE = 5.0  # a foot joint's ground level: this percentile of its heights over the clip
# the nearest sample to that percentile: numpy's interpolating method costs a 30 ms import (numpy.ma) on
# its first call in a process, a tenth of a command-line transfer
PERCENTILE_METHOD: Final = "nearest"
ENTER_HEIGHT_OF_LEG = 0.03  # a toe or ankle this close to its ground level (2.4 cm on an 80 cm leg) ...
ENTER_SPEED_LEGS_S = 0.5  # ... and slower than this (40 cm/s) starts a contact
EXIT_HEIGHT_OF_LEG = 0.06  # the contact lasts until both joints are higher than this ...
EXIT_SPEED_LEGS_S = 1.0  # ... or faster than this (80 cm/s)
MIN_CONTACT_S = 0.05  # shorter contacts are dropped and shorter gaps between contacts are filled
# a foot that slides while low, drifting back against the direction of travel, still carries the body (a
# stride shorter than the ground the root covers); a swinging foot moves ahead of the pelvis
TRAVEL_SPEED_LEGS_S = 0.5  # the pelvis moves faster than this (40 cm/s): there is a direction of travel
BEHIND_OF_TRAVEL = 0.25  # ... and falls behind the pelvis by this share of its speed (a foot pushing off,
# already accelerating, is not held)
ENTER_VERTICAL_LEGS_S = 0.2  # and a sliding foot enters contact when it rises or sinks slower than this


def ground_level(motion: Motion, positions: FloatArray | None = None) -> float:
    """Height (file units) of the toes' ground level: the 5th percentile of toe heights over all feet."""
    toes = find_limbs(motion.skeleton).toes
    positions = motion.positions(toes) if positions is None else positions
    return float(np.percentile(positions[:, toes, 1], GROUND_PERCENTILE, method=PERCENTILE_METHOD))


def detect_contacts(motion: Motion, positions: FloatArray | None = None) -> BoolArray:
    """(T, F) True where foot f is planted, F = len(find_limbs(skeleton).toes).

    positions: (T, J, 3) the clip's world positions when already known (at least the pelvis, toes and
    ankles). A foot enters contact when its toe or its ankle is near its ground level and either slow
    horizontally or, while the pelvis travels, level and not moving ahead of the pelvis along the direction
    of travel (a stance foot whose stride is shorter than the ground the root covers slides back, a swing
    foot overtakes the pelvis). It leaves when neither joint is near the ground and held (looser thresholds:
    hysteresis). Contacts and gaps shorter than `MIN_CONTACT_S` are removed. Walking forwards, backwards or
    sideways, running and turning on the spot alike: nothing assumes which way the body faces.
    """
    limbs = find_limbs(motion.skeleton)
    if len(limbs.toes) == 0:
        return np.zeros((motion.num_frames, 0), dtype=bool)
    if positions is None:
        positions = motion.positions(limbs.feet)  # (T, J, 3), the legs only
    leg = leg_length(motion.skeleton, limbs)
    joints = np.stack([limbs.toes, limbs.ankles])  # (2, F) toe and ankle of each foot
    heights = positions[:, joints, 1]  # (T, 2, F)
    heights = heights - np.percentile(
        heights, GROUND_PERCENTILE, axis=(0, 2), keepdims=True, method=PERCENTILE_METHOD
    )
    per_second = motion.fps / leg  # a frame step in file units, as leg lengths per second
    velocity = frame_steps(positions[:, joints]) * per_second  # (T, 2, F, 3) legs/s
    speed = lengths(velocity[..., [0, 2]])  # (T, 2, F)
    pelvis = frame_steps(positions[:, motion.skeleton.pelvis])[:, [0, 2]] * per_second  # (T, 2)
    pelvis_speed = lengths(pelvis)  # (T,)
    travel = pelvis / np.maximum(pelvis_speed, 1e-12)[:, None]  # (T, 2) unit direction of travel
    ahead = np.einsum("tjfc,tc->tjf", velocity[..., [0, 2]], travel) - pelvis_speed[:, None, None]
    travelling = (pelvis_speed > TRAVEL_SPEED_LEGS_S)[:, None, None]
    behind = (ahead < -BEHIND_OF_TRAVEL * pelvis_speed[:, None, None]) & travelling  # (T, 2, F)
    level = np.abs(velocity[..., 1]) < ENTER_VERTICAL_LEGS_S
    enter = (heights < ENTER_HEIGHT_OF_LEG * leg) & ((speed < ENTER_SPEED_LEGS_S) | (behind & level))
    stay = (heights < EXIT_HEIGHT_OF_LEG * leg) & ((speed < EXIT_SPEED_LEGS_S) | behind)
    contacts = _hysteresis(np.any(enter, axis=1), np.any(stay, axis=1))  # (T, F)
    min_frames = max(1, int(np.ceil(MIN_CONTACT_S * motion.fps)))
    for foot in range(contacts.shape[1]):
        for start, stop in mask_runs(~contacts[:, foot]):  # fill short gaps between two contacts
            if 0 < start and stop < motion.num_frames and stop - start < min_frames:
                contacts[start:stop, foot] = True
        for start, stop in mask_runs(contacts[:, foot]):
            if stop - start < min_frames:
                contacts[start:stop, foot] = False
    return contacts


def _hysteresis(enter: BoolArray, stay: BoolArray) -> BoolArray:
    """(T, F) on from a frame where `enter` holds for as long as `stay` holds after it:
    on[t] = enter[t] or (on[t-1] and stay[t]), i.e. the last enter frame is no earlier than the last
    frame where stay fails."""
    frames = np.arange(enter.shape[0])[:, None]  # (T, 1)
    last_enter = np.maximum.accumulate(np.where(enter, frames, -1), axis=0)
    last_break = np.maximum.accumulate(np.where(stay, -1, frames), axis=0)
    return (last_enter >= 0) & (last_enter >= last_break)


def mask_runs(mask: BoolArray) -> list[tuple[int, int]]:
    """[start, stop) frame ranges where a (T,) mask is True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def pivots(positions: FloatArray, limbs: Limbs, leg: float) -> tuple[FloatArray, FloatArray]:
    """Toe and ankle positions (T, F, 2, 3) of each foot and how firmly (T, F, 2) each is held in place.

    The toe is what skating metrics watch and it stays put from foot-flat to toe-off; only at heel strike
    (toe still coming down, higher than the ankle above their ground levels) does the ankle carry the
    weight. The hold fades from 1 to 0 as that pivot rises from half the entry height to the exit height,
    so a foot lifting off leaves gently instead of being pinned until the contact ends.
    """
    points = np.stack([positions[:, limbs.toes], positions[:, limbs.ankles]], axis=2)  # (T, F, 2, 3)
    heights = points[..., 1] - np.percentile(
        points[..., 1], GROUND_PERCENTILE, axis=(0, 1), method=PERCENTILE_METHOD
    )  # (T, F, 2)
    toe_weight = _smoothstep(1.0 + (heights[..., 1] - heights[..., 0]) / (ENTER_HEIGHT_OF_LEG * leg))
    weights = np.stack([toe_weight, 1 - toe_weight], axis=-1)  # (T, F, 2), sums to 1
    pivot_height = np.sum(weights * heights, axis=-1)  # (T, F)
    low, high = 0.5 * ENTER_HEIGHT_OF_LEG * leg, EXIT_HEIGHT_OF_LEG * leg
    return points, weights * _smoothstep((high - pivot_height) / (high - low))[..., None]


def _smoothstep(x: FloatArray) -> FloatArray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)
