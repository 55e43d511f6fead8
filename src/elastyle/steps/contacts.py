"""Foot contacts: which feet are planted when, and which point of a foot (toe or ankle) carries it.

Axes +Y up; lengths stay in the file's unit. Thresholds are fractions of the leg length (hip to ankle at
rest, per second for speeds) above the clip's own ground level (a low percentile of each foot joint's
height), so metres, centimetres and inches behave alike.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from elastyle.core.body import Limbs, find_limbs, leg_length
from elastyle.core.foot_tips import with_foot_tips
from elastyle.core.ground import GROUND_PERCENTILE, PERCENTILE_METHOD
from elastyle.core.motion import Motion
from elastyle.core.rotations import lengths
from elastyle.core.smoothing import frame_steps, smoothstep
from elastyle.types import BoolArray, FloatArray, IntArray

TOE, HEEL = 0, 1  # a foot's two contact points, last axis of point contacts: the toe joint, the ankle joint
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


def point_grounds(heights: FloatArray, ground: float | None = None) -> FloatArray:
    """(1, 1, 2) the ground level of each kind of contact point, toes and ankles apart, over every foot and
    frame of their heights (T, F, 2): the `GROUND_PERCENTILE`. ground: the toes' ground level (file units)
    where it is known from elsewhere (the floor a transfer's content walks on): where the clip's own toe
    level lies below it (toes that swing through the floor), both levels are raised by the difference, so a
    foot standing on that floor is read as standing."""
    grounds = np.percentile(heights, GROUND_PERCENTILE, axis=(0, 1), keepdims=True, method=PERCENTILE_METHOD)
    if ground is None:
        return grounds
    return grounds + max(0.0, ground - float(grounds[0, 0, TOE]))


def contact_points(limbs: Limbs) -> IntArray:
    """(F, 2) each foot's contact joints: its toe (`TOE`) and its heel (`HEEL`, the ankle joint)."""
    return np.stack([limbs.toes, limbs.ankles], axis=1)


def _min_contact_frames(fps: float) -> int:
    """Contacts and gaps shorter than `MIN_CONTACT_S`, in frames at `fps`, are dropped or filled."""
    return max(1, int(np.ceil(MIN_CONTACT_S * fps)))


def detect_contacts(
    motion: Motion, positions: FloatArray | None = None, ground: float | None = None
) -> BoolArray:
    """(T, F) True where foot f is planted (its toe or its heel), F = len(find_limbs(skeleton).toes).

    The union of `detect_point_contacts`' toe and heel tracks, with gaps shorter than `MIN_CONTACT_S`
    filled (a heel lifting a frame before the toe lands is one contact). A foot without a toe joint is read
    at its End Site (`core.foot_tips`) unless `positions` of the clip are given. ground: `point_grounds`.
    """
    if positions is None:
        motion = with_foot_tips(motion)
    contacts: BoolArray = np.any(detect_point_contacts(motion, positions, ground), axis=2)  # (T, F)
    _drop_short_runs(contacts, _min_contact_frames(motion.fps), gaps_only=True)
    return contacts


def detect_point_contacts(
    motion: Motion, positions: FloatArray | None = None, ground: float | None = None
) -> BoolArray:
    """(T, F, 2) True where the toe (`TOE`) or the heel (`HEEL`: the ankle joint) of foot f is planted.

    positions: (T, J, 3) the clip's world positions when already known (at least the pelvis, toes and
    ankles). Each point has its own track: at heel strike the heel is planted before the toe, at toe-off
    the toe stays after the heel has lifted, a run's short contacts may hold the toe only. A point enters
    contact when it is near its ground level and either slow horizontally or, while the pelvis travels,
    level and not moving ahead of the pelvis along the direction of travel (a stance foot whose stride is
    shorter than the ground the root covers slides back, a swing foot overtakes the pelvis). It leaves when
    it is no longer near the ground and held (looser thresholds: hysteresis). Contacts and gaps shorter than
    `MIN_CONTACT_S` are removed. Walking forwards, backwards or sideways, running and turning on the spot
    alike: nothing assumes which way the body faces. ground: the toes' ground level when known from
    elsewhere (`point_grounds`).
    """
    limbs = find_limbs(motion.skeleton)
    if len(limbs.toes) == 0:
        return np.zeros((motion.num_frames, 0, 2), dtype=bool)
    if positions is None:
        positions = motion.positions(limbs.feet)  # (T, J, 3), the legs only
    leg = leg_length(motion.skeleton, limbs)
    joints = contact_points(limbs)  # (F, 2) toe and heel of each foot
    heights = positions[:, joints, 1]  # (T, F, 2)
    heights = heights - point_grounds(heights, ground)
    per_second = motion.fps / leg  # a frame step in file units, as leg lengths per second
    velocity = frame_steps(positions[:, joints]) * per_second  # (T, F, 2, 3) legs/s
    speed = lengths(velocity[..., [0, 2]])  # (T, F, 2)
    pelvis = frame_steps(positions[:, motion.skeleton.pelvis])[:, [0, 2]] * per_second  # (T, 2)
    pelvis_speed = lengths(pelvis)  # (T,)
    travel = pelvis / np.maximum(pelvis_speed, 1e-12)[:, None]  # (T, 2) unit direction of travel
    ahead = np.einsum("tfkc,tc->tfk", velocity[..., [0, 2]], travel) - pelvis_speed[:, None, None]
    travelling = (pelvis_speed > TRAVEL_SPEED_LEGS_S)[:, None, None]
    behind = (ahead < -BEHIND_OF_TRAVEL * pelvis_speed[:, None, None]) & travelling  # (T, F, 2)
    level = np.abs(velocity[..., 1]) < ENTER_VERTICAL_LEGS_S
    enter = (heights < ENTER_HEIGHT_OF_LEG * leg) & ((speed < ENTER_SPEED_LEGS_S) | (behind & level))
    stay = (heights < EXIT_HEIGHT_OF_LEG * leg) & ((speed < EXIT_SPEED_LEGS_S) | behind)
    contacts = _hysteresis(enter, stay)  # (T, F, 2)
    _drop_short_runs(contacts, _min_contact_frames(motion.fps))
    return contacts


def _drop_short_runs(contacts: BoolArray, min_frames: int, gaps_only: bool = False) -> None:
    """In place on (T, ...) tracks: fill gaps shorter than `min_frames` between two contacts, then (unless
    `gaps_only`) remove contacts shorter than that."""
    tracks = contacts.reshape(contacts.shape[0], -1)  # a view: (T, tracks)
    for track in range(tracks.shape[1]):
        for start, stop in mask_runs(~tracks[:, track]):
            if 0 < start and stop < len(tracks) and stop - start < min_frames:
                tracks[start:stop, track] = True
        if not gaps_only:
            for start, stop in mask_runs(tracks[:, track]):
                if stop - start < min_frames:
                    tracks[start:stop, track] = False


def _hysteresis(enter: BoolArray, stay: BoolArray) -> BoolArray:
    """(T, ...) on from a frame where `enter` holds for as long as `stay` holds after it:
    on[t] = enter[t] or (on[t-1] and stay[t]), i.e. the last enter frame is no earlier than the last
    frame where stay fails."""
    frames = np.arange(enter.shape[0]).reshape(-1, *[1] * (enter.ndim - 1))  # (T, 1, ...)
    last_enter = np.maximum.accumulate(np.where(enter, frames, -1), axis=0)
    last_break = np.maximum.accumulate(np.where(stay, -1, frames), axis=0)
    return (last_enter >= 0) & (last_enter >= last_break)


def mask_runs(mask: BoolArray) -> list[tuple[int, int]]:
    """[start, stop) frame ranges where a (T,) mask is True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def pivots(
    positions: FloatArray, limbs: Limbs, leg: float, ground: float | None = None
) -> tuple[FloatArray, FloatArray]:
    """Toe and ankle positions (T, F, 2, 3) of each foot and how firmly (T, F, 2) each is held in place.

    The toe is what skating metrics watch and it stays put from foot-flat to toe-off; only at heel strike
    (toe still coming down, higher than the ankle above their ground levels) does the ankle carry the
    weight. The hold fades from 1 to 0 as that pivot rises from half the entry height to the exit height,
    so a foot lifting off leaves gently instead of being pinned until the contact ends. Heights choose the
    pivot, not `detect_point_contacts`' tracks: on a decoded clip whose feet slide, a sliding toe fails its
    track's speed test while the heel passes, and holding the heel there leaves the toe sliding. ground:
    the toes' ground level when known from elsewhere (`point_grounds`).
    """
    points = positions[:, contact_points(limbs)]  # (T, F, 2, 3)
    heights = points[..., 1] - point_grounds(points[..., 1], ground)  # (T, F, 2)
    toe_weight = smoothstep(1.0 + (heights[..., HEEL] - heights[..., TOE]) / (ENTER_HEIGHT_OF_LEG * leg))
    weights = np.stack([toe_weight, 1 - toe_weight], axis=-1)  # (T, F, 2), sums to 1
    pivot_height = np.sum(weights * heights, axis=-1)  # (T, F)
    low, high = 0.5 * ENTER_HEIGHT_OF_LEG * leg, EXIT_HEIGHT_OF_LEG * leg
    return points, weights * smoothstep((high - pivot_height) / (high - low))[..., None]


def checked_contacts(contacts: BoolArray, motion: Motion, limbs: Limbs) -> BoolArray:
    """Contacts (T, F) for a clip's T frames and F feet, or a ValueError saying the shape they need."""
    contacts = np.asarray(contacts, dtype=bool)
    if contacts.shape != (motion.num_frames, len(limbs.toes)):
        raise ValueError(f"contacts must be ({motion.num_frames}, {len(limbs.toes)}), got {contacts.shape}")
    return contacts


class Footing(NamedTuple):
    """What legs that keep another clip's stepping hold from it (`held_footing`), per frame (T) and foot
    (F): its contacts (T, F); floor (T, F, 2), the lowest height (file units) of each foot's toe and ankle,
    -inf where free; ceiling (T, F, 2), their highest, the reference's own heights during its contacts and
    +inf elsewhere."""

    contacts: BoolArray
    floor: FloatArray
    ceiling: FloatArray


def held_footing(reference: Motion, where: BoolArray) -> Footing:
    """What legs that keep another clip's stepping hold from it, at its frames `where` (T,): its contacts
    (T, F), a floor under each foot (T, F, 2) for `clean_feet`, its toe's and ankle's lowest heights (file
    units), and during its contacts a ceiling over them, their heights there (a stance foot held under the
    style's statistics otherwise rose 3 to 7 cm mid-stance, and its hold, which fades as a foot rises,
    let it slide).

    A foot's clearance is the lower of its toe's and its ankle's heights above their ground levels
    (`point_grounds`, as the contacts and `pivots` read them). The floor lets each foot come no closer to the ground than the
    reference's does at the same moment, up to `EXIT_HEIGHT_OF_LEG` (where a foot leaves contact): each
    point at its ground level plus that clearance. A change laid on such legs (the style's statistics) may
    lower a swinging foot until it skims or sinks through the floor the reference's foot clears; the floor
    keeps the reference's clearance near the ground, leaves every higher part of the swing to the change,
    and does not lift a heel that strikes flatter than the reference's (its clearance is already the
    heel's)."""
    reference = with_foot_tips(reference)  # a toe-less foot's End Site as its toe
    limbs = find_limbs(reference.skeleton)
    if len(limbs.toes) == 0:  # no feet to hold
        empty = np.zeros((reference.num_frames, 0, 2))
        return Footing(np.zeros((reference.num_frames, 0), dtype=bool), empty, empty)
    positions = reference.positions(limbs.feet)
    contacts = detect_contacts(reference, positions) & where[:, None]
    heights = positions[:, contact_points(limbs), 1]  # (T, F, 2) toe, ankle
    grounds = point_grounds(heights)  # (1, 1, 2)
    clearance = np.min(heights - grounds, axis=-1, keepdims=True)  # (T, F, 1)
    floor = grounds + np.minimum(clearance, EXIT_HEIGHT_OF_LEG * leg_length(reference.skeleton, limbs))
    ceiling = np.where(contacts[..., None], heights, np.inf)
    return Footing(contacts, np.where(where[:, None, None], floor, -np.inf), ceiling)
