"""Foot contact cleanup: find planted feet, pin them with two-joint leg IK, and let the root follow the stride.

Axes +Y up; lengths stay in the file's unit. Thresholds are fractions of the leg length (hip to ankle at
rest, per second for speeds) above the clip's own ground level (a low percentile of each foot joint's
height), so metres, centimetres and inches behave alike.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from elastyle.core.body import Limbs, find_limbs, leg_length
from elastyle.core.motion import Motion
from elastyle.core.rotations import from_matrix, lengths, to_matrix
from elastyle.core.skeleton import Skeleton
from elastyle.types import BoolArray, FloatArray, IntArray

GROUND_PERCENTILE = 5.0  # a foot joint's ground level: this percentile of its heights over the clip
# the nearest sample to that percentile: numpy's interpolating method costs a 30 ms import (numpy.ma) on
# its first call in a process, a tenth of a command-line transfer
PERCENTILE_METHOD: Final = "nearest"
ENTER_HEIGHT_OF_LEG = 0.03  # a toe or ankle this close to its ground level (2.4 cm on an 80 cm leg) ...
ENTER_SPEED_LEGS_S = 0.5  # ... and slower than this (40 cm/s) starts a contact
EXIT_HEIGHT_OF_LEG = 0.06  # the contact lasts until both joints are higher than this ...
EXIT_SPEED_LEGS_S = 1.0  # ... or faster than this (80 cm/s)
MIN_CONTACT_S = 0.05  # shorter contacts are dropped and shorter gaps between contacts are filled
BRIDGE_GAP_S = 0.6  # a foot's gaps between contacts up to this long (a step's swing) are bridged directly
SOFT_REACH = 0.995  # IK straightens a knee up to this fraction of the leg's reach before lowering the pelvis


def ground_level(motion: Motion, positions: FloatArray | None = None) -> float:
    """Height (file units) of the toes' ground level: the 5th percentile of toe heights over all feet."""
    toes = find_limbs(motion.skeleton).toes
    positions = motion.positions(toes) if positions is None else positions
    return float(np.percentile(positions[:, toes, 1], GROUND_PERCENTILE, method=PERCENTILE_METHOD))


def detect_contacts(motion: Motion, positions: FloatArray | None = None) -> BoolArray:
    """(T, F) True where foot f is planted, F = len(find_limbs(skeleton).toes).

    positions: (T, J, 3) the clip's world positions when already known (at least toes and ankles).
    A foot enters contact when its toe or its ankle is both near its ground level and slow horizontally,
    and leaves when neither is (looser thresholds: hysteresis). Contacts and gaps shorter than
    `MIN_CONTACT_S` are removed.
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
    horizontal = positions[:, joints][..., [0, 2]]  # (T, 2, F, 2)
    velocity = np.gradient(horizontal, axis=0) * motion.fps if motion.num_frames > 1 else 0 * horizontal
    speed_legs_s = lengths(velocity) / leg  # (T, 2, F)
    enter = np.any((heights < ENTER_HEIGHT_OF_LEG * leg) & (speed_legs_s < ENTER_SPEED_LEGS_S), axis=1)
    stay = np.any((heights < EXIT_HEIGHT_OF_LEG * leg) & (speed_legs_s < EXIT_SPEED_LEGS_S), axis=1)
    contacts = _hysteresis(enter, stay)  # (T, F)
    min_frames = max(1, int(np.ceil(MIN_CONTACT_S * motion.fps)))
    for foot in range(contacts.shape[1]):
        for start, stop in _runs(~contacts[:, foot]):  # fill short gaps between two contacts
            if 0 < start and stop < motion.num_frames and stop - start < min_frames:
                contacts[start:stop, foot] = True
        for start, stop in _runs(contacts[:, foot]):
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


def clean_feet(motion: Motion, contacts: BoolArray | None = None, blend_s: float = 0.15) -> Motion:
    """Pin each planted foot in place with two-joint IK; a new Motion (same skeleton, fps and frames).

    contacts: (T, F) from `detect_contacts` (detected here when None). During a contact the foot is held
    horizontally around its mean position (the toe, or the ankle at heel strike, stops moving; the hold
    fades as the foot lifts off); heights stay. The correction eases in and out over `blend_s` seconds
    (cubic Hermite, matching position and velocity at the contact's ends) and is carried straight across
    a step's swing. Anywhere, a toe or ankle below `ground_level` is lifted to it. Feet keep their world
    orientation; hip and knee turn in the original knee plane; the pelvis is lowered (smoothly) only
    where a leg cannot reach. Only leg rotations and the pelvis height change: bone lengths stay exact.
    """
    skeleton, limbs = motion.skeleton, find_limbs(motion.skeleton)
    if len(limbs.toes) == 0:
        return Motion(skeleton, motion.rotations.copy(), motion.translations.copy(), motion.fps)
    world_rotations, positions = motion.world(limbs.feet)  # the legs and what they hang from
    contacts = detect_contacts(motion, positions) if contacts is None else _checked(contacts, motion, limbs)
    leg = leg_length(skeleton, limbs)
    ground = ground_level(motion, positions)
    ramp_frames = blend_s * motion.fps
    bridge_frames = max(BRIDGE_GAP_S * motion.fps, 2 * ramp_frames)
    # 1. ankle targets: the pinned contact point's correction moves the whole foot, then lift to the ground
    points, weights = _pivots(positions, limbs, leg)  # (T, F, 2, 3), (T, F, 2)
    targets = positions[:, limbs.ankles].copy()  # (T, F, 3)
    for foot in range(len(limbs.toes)):
        targets[:, foot] += _pin_corrections(
            points[:, foot], weights[:, foot], contacts[:, foot], ramp_frames, bridge_frames
        )
    toe_heights = positions[:, limbs.toes, 1] + targets[..., 1] - positions[:, limbs.ankles, 1]  # (T, F)
    targets[..., 1] += np.maximum(0.0, ground - np.minimum(toe_heights, targets[..., 1]))
    # 2. lower the pelvis where a target is out of reach: the pelvis and every joint below it move with it
    knees = skeleton.parents[limbs.ankles]
    chains = np.stack([skeleton.parents[knees], knees, limbs.ankles], axis=1)  # (F, 3) upper leg, knee, ankle
    # the upper leg must hang below the leg's root: a two-bone leg off the pelvis has no knee to bend
    legs = np.array([_is_below(skeleton, int(chain[0]), int(hip)) for chain, hip in zip(chains, limbs.hips)])
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    lowering = _pelvis_lowering(positions, chains[legs], targets[:, legs], ramp_frames)  # (T,)
    if np.any(lowering > 0):
        shift = np.zeros((motion.num_frames, 3))
        shift[:, 1] = -lowering
        translations = _shift_pelvis(motion, world_rotations, shift)
        carried = [
            j for j in skeleton.with_ancestors(limbs.feet).tolist() if _is_below(skeleton, j, skeleton.pelvis)
        ]
        positions = positions.copy()
        positions[:, carried] += shift[:, None]
    # 3. two-joint IK, every leg at once; only frames whose ankle has to move change (elsewhere the input stays exact)
    chains = chains[legs]
    moved = lengths(targets[:, legs] - positions[:, chains[:, 2]]) > 1e-9 * leg  # (T, F_legs)
    if np.any(moved):
        parents = skeleton.parents[chains[:, 0]]
        local = _leg_ik(world_rotations, positions, parents, chains, targets[:, legs])  # (T, F_legs, 3, 3)
        frames, feet = np.nonzero(moved)
        rotations[frames[:, None], chains[feet]] = local[frames, feet]
    return Motion(skeleton, rotations, translations, motion.fps)


def adjust_root_speed(motion: Motion, contacts: BoolArray, smooth_s: float = 0.2) -> Motion:
    """Move the pelvis horizontally so that planted feet stop drifting: the root advances with the stride.

    contacts: (T, F) planted feet. Each frame step, the mean horizontal step (file units) of the feet held
    at both frames (weighted as in `clean_feet`), Hann-smoothed over `smooth_s` seconds, is taken off the
    pelvis path; steps with no foot planted keep theirs. Run it before `clean_feet`.
    """
    limbs = find_limbs(motion.skeleton)
    contacts = _checked(contacts, motion, limbs)
    if motion.num_frames < 2 or contacts.shape[1] == 0:
        return Motion(motion.skeleton, motion.rotations.copy(), motion.translations.copy(), motion.fps)
    world_rotations, positions = motion.world(limbs.feet)
    points, weights = _pivots(positions, limbs, leg_length(motion.skeleton, limbs))  # (T, F, 2, 3), (T, F, 2)
    planted = (contacts[1:] & contacts[:-1])[..., None] * 0.5 * (weights[1:] + weights[:-1])  # (T-1, F, 2)
    steps = np.sum(planted[..., None] * np.diff(points, axis=0), axis=(1, 2))  # (T-1, 3)
    drift = steps / np.maximum(planted.sum(axis=(1, 2)), 1.0)[:, None]  # (T-1, 3) mean planted-foot step
    drift[:, 1] = 0.0
    drift = _smooth(drift, smooth_s * motion.fps)
    shift = -np.concatenate([np.zeros((1, 3)), np.cumsum(drift, axis=0)])  # (T, 3) world
    return Motion(
        motion.skeleton, motion.rotations.copy(), _shift_pelvis(motion, world_rotations, shift), motion.fps
    )


def _checked(contacts: BoolArray, motion: Motion, limbs: Limbs) -> BoolArray:
    contacts = np.asarray(contacts, dtype=bool)
    if contacts.shape != (motion.num_frames, len(limbs.toes)):
        raise ValueError(f"contacts must be ({motion.num_frames}, {len(limbs.toes)}), got {contacts.shape}")
    return contacts


def _shift_pelvis(motion: Motion, world_rotations: FloatArray, shift: FloatArray) -> FloatArray:
    """Translations (T, J, 3) with the pelvis moved by `shift` (T, 3), world frame, file units."""
    pelvis, parent = motion.skeleton.pelvis, motion.skeleton.parents[motion.skeleton.pelvis]
    if parent >= 0:  # the pelvis translation is in its parent's frame
        shift = np.einsum("tji,tj->ti", world_rotations[:, parent], shift)
    translations = motion.translations.copy()
    translations[:, pelvis] += shift
    return translations


def _is_below(skeleton: Skeleton, joint: int, ancestor: int) -> bool:
    while joint > ancestor:
        joint = int(skeleton.parents[joint])
    return joint == ancestor


def _runs(mask: BoolArray) -> list[tuple[int, int]]:
    """[start, stop) frame ranges where a (T,) mask is True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def _pivots(positions: FloatArray, limbs: Limbs, leg: float) -> tuple[FloatArray, FloatArray]:
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


def _pin_corrections(
    points: FloatArray, weights: FloatArray, contact: BoolArray, ramp_frames: float, bridge_frames: float
) -> FloatArray:
    """Horizontal offsets (T, 3) that hold a foot still during each contact, around its mean position.

    points: (T, 2, 3) toe and ankle; weights: (T, 2) how firmly each is held. Within a contact the offset
    cancels the held pivot's displacement, so heel-to-toe roll is kept; heights are left alone.
    Between contacts the offset eases back to zero over `ramp_frames`, or straight to the next contact's
    offset across gaps up to `bridge_frames` (a swing): cubic Hermite, matching value and slope at the ends.
    """
    num_frames = points.shape[0]
    corrections = np.zeros((num_frames, 3))
    runs = np.array(_runs(contact), dtype=np.int64).reshape(-1, 2)  # (R, 2) [start, stop) of each contact
    if len(runs) == 0:
        return corrections
    starts, stops = runs[:, 0], runs[:, 1]
    # undo the held pivot's steps (the weights blend, so a roll from heel to toe is no step)
    share = 0.5 * (weights[1:] + weights[:-1])  # (T-1, 2)
    steps = np.einsum("tk,tkc->tc", share, np.diff(points, axis=0))  # (T-1, 3)
    steps *= (contact[1:] & contact[:-1])[:, None]  # only steps within a contact
    travelled = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])  # (T, 3)
    held = np.flatnonzero(contact)  # frames in a contact, run after run
    run = np.repeat(np.arange(len(runs)), stops - starts)  # (H,) each held frame's contact
    offsets = travelled[starts[run]] - travelled[held]  # (H, 3) from the contact's first frame
    first_of_run = np.concatenate([[0], np.cumsum(stops - starts)[:-1]])
    offsets -= (np.add.reduceat(offsets, first_of_run, axis=0) / (stops - starts)[:, None])[run]
    offsets[:, 1] = 0.0
    corrections[held] = offsets
    if ramp_frames <= 0:
        return corrections
    long_enough = (stops - starts > 1)[:, None]
    start_slopes = np.where(
        long_enough, corrections[np.minimum(starts + 1, num_frames - 1)] - corrections[starts], 0
    )
    end_slopes = np.where(long_enough, corrections[stops - 1] - corrections[np.maximum(stops - 2, 0)], 0)
    # knots (frame, offset, slope per frame) at the contacts' ends, eased from and to zero at the clip's ends
    zero = np.zeros(3)
    knots: list[tuple[float, FloatArray, FloatArray]] = [(starts[0] - ramp_frames, zero, zero)]
    for i in range(len(runs)):
        knots += [(starts[i], corrections[starts[i]], start_slopes[i]),
                  (stops[i] - 1, corrections[stops[i] - 1], end_slopes[i])]  # fmt: skip
    knots.append((stops[-1] - 1 + ramp_frames, zero, zero))
    spans = []
    for left, right in zip(knots[::2], knots[1::2]):  # the gaps: before, between and after the contacts
        if right[0] - left[0] > bridge_frames:  # longer than a swing: ease out to zero and back in
            spans += [
                (left, (left[0] + ramp_frames, zero, zero)),
                ((right[0] - ramp_frames, zero, zero), right),
            ]
        else:
            spans.append((left, right))
    # every span's frames at once: cubic Hermite between its ends
    first, last = (np.array([span[i][0] for span in spans], dtype=np.float64) for i in (0, 1))  # (S,)
    start_value, start_slope, end_value, end_slope = (
        np.array([span[i][k] for span in spans]) for i, k in ((0, 1), (0, 2), (1, 1), (1, 2))
    )  # (S, 3) each
    low = np.maximum(np.floor(first).astype(np.int64) + 1, 0)
    counts = np.maximum(np.minimum(np.ceil(last).astype(np.int64), num_frames) - low, 0)
    span = np.repeat(np.arange(len(spans)), counts)  # (N,) each eased frame's span
    frames = low[span] + np.arange(len(span)) - np.repeat(np.cumsum(counts) - counts, counts)
    width = (last - first)[span, None]  # (N, 1)
    u = (frames - first[span])[:, None] / width  # (N, 1) in (0, 1)
    corrections[frames] = (
        (2 * u**3 - 3 * u**2 + 1) * start_value[span]
        + (u**3 - 2 * u**2 + u) * width * start_slope[span]
        + (3 * u**2 - 2 * u**3) * end_value[span]
        + (u**3 - u**2) * width * end_slope[span]
    )
    return corrections


def _smooth(values: FloatArray, radius_frames: float) -> FloatArray:
    """Hann-window average along axis 0 of (T, ...) values, edges held constant."""
    radius = int(round(radius_frames))
    if radius < 1 or values.shape[0] < 2:
        return values.copy()
    kernel = np.hanning(2 * radius + 3)[1:-1]  # (2r + 1,) positive weights
    kernel /= kernel.sum()
    padded = np.pad(values.reshape(len(values), -1), [(radius, radius), (0, 0)], mode="edge")  # (T + 2r, C)
    columns = [np.convolve(column, kernel, mode="valid") for column in padded.T]
    return np.stack(columns, axis=1).reshape(values.shape)


def _pelvis_lowering(
    positions: FloatArray, chains: IntArray, targets: FloatArray, ramp_frames: float
) -> FloatArray:
    """How far (T,) to lower the pelvis so each ankle target (T, F, 3) is in reach of its leg, smoothly.

    chains: (F, 3) upper leg, knee and ankle joints. Reach is the original hip-ankle distance or
    `SOFT_REACH` of the straight leg, whichever is longer. The need is dilated then averaged over the same
    window, so the result never falls below it.
    """
    hips, knees, ankles = (positions[:, chains[:, i]] for i in range(3))  # (T, F, 3) each
    thigh = lengths(knees - hips)  # (T, F)
    shin = lengths(ankles - knees)
    reach = np.maximum(lengths(ankles - hips), SOFT_REACH * (thigh + shin))
    reach = np.minimum(reach, (1 - 1e-9) * (thigh + shin))
    offset = targets - hips  # (T, F, 3)
    horizontal_sq = offset[..., 0] ** 2 + offset[..., 2] ** 2
    need = -offset[..., 1] - np.sqrt(np.maximum(reach**2 - horizontal_sq, 0.0))  # (T, F)
    need = np.max(need, axis=1, initial=0.0)  # (T,)
    if not np.any(need > 0):
        return need
    radius = max(1, int(np.ceil(ramp_frames)))
    padded = np.pad(need, radius, mode="edge")
    dilated = np.lib.stride_tricks.sliding_window_view(padded, 2 * radius + 1).max(axis=1)
    return np.maximum(_smooth(dilated, radius), need)


def _angle(u: FloatArray, v: FloatArray) -> FloatArray:
    """Angles (...) in radians between vectors (..., 3)."""
    cosine = np.sum(u * v, -1) / np.maximum(lengths(u) * lengths(v), 1e-300)
    return np.arccos(np.clip(cosine, -1.0, 1.0))


def _leg_ik(
    world_rotations: FloatArray,
    positions: FloatArray,
    parents: IntArray,
    chains: IntArray,
    targets: FloatArray,
) -> FloatArray:
    """Analytic two-joint IK of F legs at once: local exp maps (T, F, 3, 3) of upper leg, knee and ankle
    putting each ankle on its target.

    world_rotations: (T, J, 3, 3); positions: (T, J, 3); parents: (F,) each upper leg's parent (-1: none);
    chains: (F, 3) upper leg, knee, ankle; targets: (T, F, 3).
    The knee bends in its own plane (normal (ankle - hip) x (knee - hip); a straight leg borrows the clip's
    mean normal in the upper leg's frame) to get the hip-target distance by the law of cosines, the leg
    turns back in that plane onto its old hip-ankle line, then swings that line onto the target (minimal
    arc). The ankle keeps its world rotation, so the foot keeps its orientation.
    """
    upper_world, knee_world, ankle_world = (
        world_rotations[:, chains[:, i]] for i in range(3)
    )  # (T, F, 3, 3)
    hip, knee, ankle = (positions[:, chains[:, i]] for i in range(3))  # (T, F, 3)
    normal = np.cross(ankle - hip, knee - hip)  # (T, F, 3)
    size = lengths(normal)
    bent = size > 1e-6 * lengths(ankle - hip) * lengths(knee - hip)  # (T, F)
    normal = normal / np.maximum(size, 1e-300)[..., None]
    local_normal = np.einsum("tfji,tfj->tfi", upper_world, normal)  # (T, F, 3) in the upper leg's frame
    across = np.cross(np.einsum("fj,fji->fi", (knee - hip)[0], upper_world[0]), [1e-3, 1e-2, 1.0])  # (F, 3)
    mean_normal = np.where(
        np.any(bent, axis=0)[:, None], np.sum(local_normal * bent[..., None], axis=0), across
    )
    mean_normal = mean_normal / np.maximum(lengths(mean_normal, keepdims=True), 1e-300)  # (F, 3)
    axes = np.where(bent[..., None], normal, np.einsum("tfij,fj->tfi", upper_world, mean_normal))  # (T, F, 3)

    thigh, shin = lengths(knee - hip), lengths(ankle - knee)  # (T, F)
    eps = 1e-9 * (thigh + shin)
    distance = np.clip(lengths(targets - hip), np.abs(thigh - shin) + eps, thigh + shin - eps)
    hip_angle = np.arccos(np.clip((thigh**2 + distance**2 - shin**2) / (2 * thigh * distance), -1, 1))
    knee_angle = np.arccos(np.clip((thigh**2 + shin**2 - distance**2) / (2 * thigh * shin), -1, 1))
    cross = np.cross(ankle - hip, targets - hip)
    swing_axis = cross / np.maximum(lengths(cross), 1e-300)[..., None]
    # the knee's bend, the hip's turn back onto the hip-ankle line, and the swing onto the target
    bend, turn, swing = to_matrix(
        np.stack(
            [
                axes * (knee_angle - _angle(hip - knee, ankle - knee))[..., None],
                axes * (hip_angle - _angle(ankle - hip, knee - hip))[..., None],
                swing_axis * _angle(ankle - hip, targets - hip)[..., None],
            ]
        )
    )  # (T, F, 3, 3) each
    new_upper = swing @ turn @ upper_world
    new_knee = new_upper @ np.swapaxes(upper_world, -1, -2) @ bend @ knee_world
    parent_world = np.where(
        (parents >= 0)[:, None, None], world_rotations[:, np.maximum(parents, 0)], np.eye(3)
    )  # (T, F, 3, 3)
    local = [np.swapaxes(parent_world, -1, -2) @ new_upper, np.swapaxes(new_upper, -1, -2) @ new_knee]
    local.append(np.swapaxes(new_knee, -1, -2) @ ankle_world)
    return from_matrix(np.stack(local, axis=2))
