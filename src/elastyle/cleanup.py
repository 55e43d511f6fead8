"""Foot contact cleanup: find planted feet, pin them with two-joint leg IK, and let the root follow the stride.

Axes +Y up; lengths stay in the file's unit. Every threshold is a fraction of the leg length (hip to ankle
at rest) or leg lengths per second, and heights are measured from the clip's own ground level (a low
percentile of each foot joint's height), so metres, centimetres and inches behave alike.
Only rotations of the leg chain (upper leg, knee, ankle) change, plus the pelvis translation where a leg
cannot reach: bone lengths stay exact.
"""

from __future__ import annotations

import numpy as np

from elastyle.eval.metrics import Limbs, find_limbs, leg_length
from elastyle.motion import Motion
from elastyle.rotations import from_matrix, to_matrix
from elastyle.types import BoolArray, FloatArray, IntArray

GROUND_PERCENTILE = 5.0  # a foot joint's ground level: this percentile of its heights over the clip
ENTER_HEIGHT_OF_LEG = 0.03  # a toe or ankle this close to its ground level (2.4 cm on an 80 cm leg) ...
ENTER_SPEED_LEGS_S = 0.5  # ... and slower than this (40 cm/s) starts a contact
EXIT_HEIGHT_OF_LEG = 0.06  # the contact lasts until both joints are higher than this ...
EXIT_SPEED_LEGS_S = 1.0  # ... or faster than this (80 cm/s)
MIN_CONTACT_S = 0.05  # shorter contacts are dropped and shorter gaps between contacts are filled
BRIDGE_GAP_S = 0.6  # a foot's gaps between contacts up to this long (a step's swing) are bridged directly
SOFT_REACH = 0.995  # IK straightens a knee up to this fraction of the leg's reach before lowering the pelvis
HORIZONTAL = np.array([0, 2])


def ground_level(motion: Motion, positions: FloatArray | None = None) -> float:
    """Height (file units) of the toes' ground level: the 5th percentile of toe heights over all feet."""
    positions = motion.positions() if positions is None else positions
    toes = find_limbs(motion.skeleton).toes
    return float(np.percentile(positions[:, toes, 1], GROUND_PERCENTILE))


def detect_contacts(motion: Motion) -> BoolArray:
    """(T, F) True where foot f is planted, F = len(find_limbs(skeleton).toes).

    A foot enters contact when its toe or its ankle is both near its ground level and slow horizontally,
    and leaves when neither is (looser thresholds: hysteresis). Contacts and gaps shorter than
    `MIN_CONTACT_S` are removed.
    """
    limbs = find_limbs(motion.skeleton)
    positions = motion.positions()  # (T, J, 3)
    leg = leg_length(motion.skeleton, limbs)
    joints = np.stack([limbs.toes, limbs.ankles])  # (2, F) toe and ankle of each foot
    heights = positions[:, joints, 1]  # (T, 2, F)
    heights = heights - np.percentile(heights, GROUND_PERCENTILE, axis=(0, 2), keepdims=True)
    if motion.num_frames > 1:
        velocity = np.gradient(positions[:, joints][..., HORIZONTAL], axis=0) * motion.fps  # (T, 2, F, 2)
    else:
        velocity = np.zeros((*heights.shape, 2))
    speed_legs_s = np.linalg.norm(velocity, axis=-1) / leg  # (T, 2, F)
    enter = np.any((heights < ENTER_HEIGHT_OF_LEG * leg) & (speed_legs_s < ENTER_SPEED_LEGS_S), axis=1)
    stay = np.any((heights < EXIT_HEIGHT_OF_LEG * leg) & (speed_legs_s < EXIT_SPEED_LEGS_S), axis=1)
    contacts = np.zeros(enter.shape, dtype=bool)  # (T, F)
    contacts[0] = enter[0]
    for frame in range(1, motion.num_frames):
        contacts[frame] = enter[frame] | (contacts[frame - 1] & stay[frame])
    min_frames = max(1, int(np.ceil(MIN_CONTACT_S * motion.fps)))
    for foot in range(contacts.shape[1]):
        for start, stop in _runs(~contacts[:, foot]):  # fill short gaps between two contacts
            if 0 < start and stop < motion.num_frames and stop - start < min_frames:
                contacts[start:stop, foot] = True
        for start, stop in _runs(contacts[:, foot]):
            if stop - start < min_frames:
                contacts[start:stop, foot] = False
    return contacts


def clean_feet(motion: Motion, contacts: BoolArray | None = None, blend_s: float = 0.15) -> Motion:
    """Pin each planted foot in place with two-joint IK; a new Motion (same skeleton, fps and frames).

    contacts: (T, F) from `detect_contacts` (detected here when None). During a contact the foot's contact
    point (toe/ankle blend, the lower one weighing more) is held at its mean horizontal position over the
    contact; its height is left as it was. The horizontal correction is eased in and out with cubic
    Hermite ramps over `blend_s` seconds (matching position and velocity at the contact's ends). Anywhere,
    a toe or ankle below `ground_level` is lifted to it. The feet keep their world orientation; hips and
    knees turn in the original knee plane; the pelvis is lowered, smoothly, only where a leg cannot reach.
    """
    skeleton, limbs = motion.skeleton, find_limbs(motion.skeleton)
    contacts = detect_contacts(motion) if contacts is None else contacts
    if contacts.shape != (motion.num_frames, len(limbs.toes)):
        raise ValueError(f"contacts must be ({motion.num_frames}, {len(limbs.toes)}), got {contacts.shape}")
    world_rotations, positions = motion.world()
    ground = ground_level(motion, positions)
    ramp_frames = blend_s * motion.fps
    bridge_frames = max(BRIDGE_GAP_S * motion.fps, 2 * ramp_frames)
    # 1. ankle targets: the pinned contact point's correction moves the whole foot, then lift to the ground
    points, weights = _pivots(positions, limbs, leg_length(skeleton, limbs))  # (T, F, 2, 3), (T, F, 2)
    targets = positions[:, limbs.ankles].copy()  # (T, F, 3)
    for foot in range(len(limbs.toes)):
        targets[:, foot] += _pin_corrections(
            points[:, foot], weights[:, foot], contacts[:, foot], ramp_frames, bridge_frames
        )
    toe_heights = positions[:, limbs.toes, 1] + targets[..., 1] - positions[:, limbs.ankles, 1]  # (T, F)
    targets[..., 1] += np.maximum(0.0, ground - np.minimum(toe_heights, targets[..., 1]))
    # 2. lower the pelvis where a target is out of reach, then redo forward kinematics
    knees = skeleton.parents[limbs.ankles]
    uppers = skeleton.parents[knees]
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    lowering = _pelvis_lowering(positions, uppers, knees, limbs.ankles, targets, ramp_frames)  # (T,)
    if np.any(lowering > 0):
        pelvis, parent = skeleton.pelvis, skeleton.parents[skeleton.pelvis]
        shift = np.zeros((motion.num_frames, 3))
        shift[:, 1] = -lowering
        if parent >= 0:  # the pelvis translation is in its parent's frame
            shift = np.einsum("tji,tj->ti", world_rotations[:, parent], shift)
        translations[:, pelvis] += shift
        world_rotations, positions = Motion(skeleton, rotations, translations, motion.fps).world()
    # 3. two-joint IK per leg on the frames whose ankle has to move
    tolerance = 1e-9 * leg_length(skeleton, limbs)
    for foot, (upper, knee, ankle) in enumerate(zip(uppers, knees, limbs.ankles)):
        frames = np.flatnonzero(np.linalg.norm(targets[:, foot] - positions[:, ankle], axis=-1) > tolerance)
        if frames.size == 0:
            continue
        axes = _knee_axes(world_rotations, positions, int(upper), int(knee), int(ankle))  # (T, 3)
        upper_world, knee_world = _two_joint_ik(
            positions[frames][:, [upper, knee, ankle]], targets[frames, foot], axes[frames],
            world_rotations[frames, upper], world_rotations[frames, knee],
        )  # fmt: skip
        parent = skeleton.parents[upper]
        parent_world = world_rotations[frames, parent] if parent >= 0 else np.eye(3)
        local = np.stack([
            np.swapaxes(parent_world, -1, -2) @ upper_world,
            np.swapaxes(upper_world, -1, -2) @ knee_world,
            np.swapaxes(knee_world, -1, -2) @ world_rotations[frames, ankle],
        ], axis=1)  # (N, 3, 3, 3) new local rotations of upper leg, knee and ankle  # fmt: skip
        rotations[frames[:, None], np.array([upper, knee, ankle])] = from_matrix(local)
    return Motion(skeleton, rotations, translations, motion.fps)


def adjust_root_speed(motion: Motion, contacts: BoolArray, smooth_s: float = 0.2) -> Motion:
    """Move the pelvis horizontally so that planted feet stop drifting: the root advances with the stride.

    contacts: (T, F) planted feet. For each frame step, the mean horizontal displacement (file units) of the
    feet planted at both frames is subtracted from the pelvis path, after a Hann smoothing over `smooth_s`
    seconds; steps without a planted foot keep their original displacement. Run it before `clean_feet`.
    """
    limbs = find_limbs(motion.skeleton)
    if contacts.shape != (motion.num_frames, len(limbs.toes)):
        raise ValueError(f"contacts must be ({motion.num_frames}, {len(limbs.toes)}), got {contacts.shape}")
    if motion.num_frames < 2:
        return motion
    world_rotations, positions = motion.world()
    points, weights = _pivots(positions, limbs, leg_length(motion.skeleton, limbs))  # (T, F, 2, 3), (T, F, 2)
    planted = (contacts[1:] & contacts[:-1]).astype(np.float64)  # (T-1, F)
    steps = (
        np.sum(np.diff(points, axis=0) * weights[:-1, ..., None], axis=2) * planted[..., None]
    )  # (T-1, F, 3)
    count = planted.sum(axis=1, keepdims=True)  # (T-1, 1)
    drift = steps.sum(axis=1) / np.maximum(count, 1.0)  # (T-1, 3)
    drift[:, 1] = 0.0
    drift = _smooth(drift, smooth_s * motion.fps)
    shift = -np.concatenate([np.zeros((1, 3)), np.cumsum(drift, axis=0)])  # (T, 3) world
    pelvis, parent = motion.skeleton.pelvis, motion.skeleton.parents[motion.skeleton.pelvis]
    if parent >= 0:
        shift = np.einsum("tji,tj->ti", world_rotations[:, parent], shift)
    translations = motion.translations.copy()
    translations[:, pelvis] += shift
    return Motion(motion.skeleton, motion.rotations.copy(), translations, motion.fps)


def _runs(mask: BoolArray) -> list[tuple[int, int]]:
    """[start, stop) frame ranges where a (T,) mask is True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def _pivots(positions: FloatArray, limbs: Limbs, leg: float) -> tuple[FloatArray, FloatArray]:
    """Toe and ankle positions (T, F, 2, 3) of each foot and the weight (T, F, 2) each bears.

    The toe is what skating metrics watch and it stays put from foot-flat to toe-off; only at heel strike
    (toe still coming down, higher than the ankle above their ground levels) does the ankle carry it.
    """
    points = np.stack([positions[:, limbs.toes], positions[:, limbs.ankles]], axis=2)  # (T, F, 2, 3)
    heights = points[..., 1] - np.percentile(points[..., 1], GROUND_PERCENTILE, axis=(0, 1))  # (T, F, 2)
    toe_weight = _smoothstep(1.0 + (heights[..., 1] - heights[..., 0]) / (ENTER_HEIGHT_OF_LEG * leg))
    return points, np.stack([toe_weight, 1 - toe_weight], axis=-1)


def _smoothstep(x: FloatArray) -> FloatArray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def _hermite(start: FloatArray, start_slope: FloatArray, end: FloatArray, end_slope: FloatArray,
             u: FloatArray, span: float) -> FloatArray:  # fmt: skip
    """Cubic Hermite curve (N, 3) at u (N,) in [0, 1] between values (3,) with slopes (3,) per frame."""
    u = u[:, None]
    return ((2 * u**3 - 3 * u**2 + 1) * start + (u**3 - 2 * u**2 + u) * span * start_slope
            + (3 * u**2 - 2 * u**3) * end + (u**3 - u**2) * span * end_slope)  # fmt: skip


def _pin_corrections(
    points: FloatArray, weights: FloatArray, contact: BoolArray, ramp_frames: float, bridge_frames: float
) -> FloatArray:
    """Horizontal offsets (T, 3) that hold a foot still during each contact, around its mean position.

    points: (T, 2, 3) toe and ankle; weights: (T, 2) the share each bears. Within a contact the offset
    cancels the weighted pivot's displacement, so heel-to-toe roll is kept; heights are left alone.
    Between contacts the offset eases back to zero over `ramp_frames`, or straight to the next contact's
    offset across gaps up to `bridge_frames` (a swing), matching the offset's slope at each contact's ends.
    """
    num_frames = points.shape[0]
    corrections = np.zeros((num_frames, 3))
    zero = np.zeros(3)
    previous: tuple[int, FloatArray, FloatArray] | None = None  # last contact frame, offset, slope

    def fill(first: float, last: float, start: FloatArray, start_slope: FloatArray,
             end: FloatArray, end_slope: FloatArray) -> None:  # fmt: skip
        frames = np.arange(max(int(np.floor(first)) + 1, 0), min(int(np.ceil(last)), num_frames))
        if frames.size:
            span = last - first
            corrections[frames] = _hermite(start, start_slope, end, end_slope, (frames - first) / span, span)

    for start, stop in _runs(contact):
        # undo the weight-bearing pivot's steps (weights sum to 1, so a roll from heel to toe is no step)
        share = 0.5 * (weights[start + 1 : stop] + weights[start : stop - 1])  # (N-1, 2)
        steps = np.sum(share[..., None] * np.diff(points[start:stop], axis=0), axis=1)  # (N-1, 3)
        offsets = -np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])  # (N, 3)
        offsets -= offsets.mean(axis=0)
        offsets[:, 1] = 0.0
        corrections[start:stop] = offsets
        slope_in = offsets[1] - offsets[0] if stop - start > 1 else zero
        slope_out = offsets[-1] - offsets[-2] if stop - start > 1 else zero
        if ramp_frames > 0:
            if previous is not None and start - previous[0] <= bridge_frames:
                fill(previous[0], start, previous[1], previous[2], offsets[0], slope_in)
            else:
                if previous is not None:
                    fill(previous[0], previous[0] + ramp_frames, previous[1], previous[2], zero, zero)
                fill(start - ramp_frames, start, zero, zero, offsets[0], slope_in)
        previous = (stop - 1, offsets[-1], slope_out)
    if previous is not None and ramp_frames > 0:
        fill(previous[0], previous[0] + ramp_frames, previous[1], previous[2], zero, zero)
    return corrections


def _smooth(values: FloatArray, radius_frames: float) -> FloatArray:
    """Hann-window average along axis 0 of (T, ...) values, edges held constant."""
    radius = int(round(radius_frames))
    if radius < 1 or values.shape[0] < 2:
        return values.copy()
    kernel = np.hanning(2 * radius + 3)[1:-1]  # (2r + 1,) positive weights
    kernel /= kernel.sum()
    padded = np.concatenate([np.repeat(values[:1], radius, 0), values, np.repeat(values[-1:], radius, 0)])
    return np.stack([np.convolve(column, kernel, mode="valid") for column in padded.reshape(len(padded), -1).T],
                    axis=1).reshape(values.shape)  # fmt: skip


def _pelvis_lowering(positions: FloatArray, uppers: IntArray, knees: IntArray, ankles: IntArray,
                     targets: FloatArray, ramp_frames: float) -> FloatArray:  # fmt: skip
    """How far (T,) to lower the pelvis so every ankle target is within its leg's reach, smoothly.

    Reach is the original hip-ankle distance or `SOFT_REACH` of the straight leg, whichever is longer.
    The need is dilated then averaged over the same window, so the result never falls below it.
    """
    hips = positions[:, uppers]  # (T, F, 3)
    thigh = np.linalg.norm(positions[:, knees] - hips, axis=-1)  # (T, F)
    shin = np.linalg.norm(positions[:, ankles] - positions[:, knees], axis=-1)
    reach = np.maximum(np.linalg.norm(positions[:, ankles] - hips, axis=-1), SOFT_REACH * (thigh + shin))
    reach = np.minimum(reach, (1 - 1e-9) * (thigh + shin))
    offset = targets - hips  # (T, F, 3)
    horizontal_sq = offset[..., 0] ** 2 + offset[..., 2] ** 2
    need = np.max(-offset[..., 1] - np.sqrt(np.maximum(reach**2 - horizontal_sq, 0.0)), axis=1)  # (T,)
    need = np.maximum(need, 0.0)
    if not np.any(need > 0):
        return need
    radius = max(1, int(np.ceil(ramp_frames)))
    padded = np.pad(need, radius, mode="edge")
    dilated = np.lib.stride_tricks.sliding_window_view(padded, 2 * radius + 1).max(axis=1)
    return np.maximum(_smooth(dilated, radius), need)


def _knee_axes(
    world_rotations: FloatArray, positions: FloatArray, upper: int, knee: int, ankle: int
) -> FloatArray:
    """(T, 3) unit normal of each frame's knee plane, (ankle - hip) x (knee - hip), world frame.

    A straight leg has no plane of its own: it gets the clip's mean normal in the upper leg's frame.
    """
    hip_to_ankle = positions[:, ankle] - positions[:, upper]
    hip_to_knee = positions[:, knee] - positions[:, upper]
    normal = np.cross(hip_to_ankle, hip_to_knee)  # (T, 3)
    size = np.linalg.norm(normal, axis=-1)
    bent = size > 1e-6 * np.linalg.norm(hip_to_ankle, axis=-1) * np.linalg.norm(hip_to_knee, axis=-1)
    local = np.einsum("tji,tj->ti", world_rotations[:, upper], normal / np.maximum(size, 1e-300)[:, None])
    mean_local = local[bent].sum(axis=0) if np.any(bent) else np.cross(hip_to_knee[0] @ world_rotations[0, upper],
                                                                      [0.0, 0.0, 1.0])  # fmt: skip
    mean_local = mean_local / max(float(np.linalg.norm(mean_local)), 1e-300)
    fallback = world_rotations[:, upper] @ mean_local  # (T, 3)
    return np.where(bent[:, None], normal / np.maximum(size, 1e-300)[:, None], fallback)


def _two_joint_ik(chain: FloatArray, targets: FloatArray, axes: FloatArray, upper_world: FloatArray,
                  knee_world: FloatArray) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Analytic IK: new world rotations (N, 3, 3) of upper leg and knee putting the ankle on its target.

    chain: (N, 3, 3) world positions of hip, knee, ankle; targets: (N, 3); axes: (N, 3) knee plane normals.
    The knee bends about `axes` to get the hip-target distance (law of cosines), the leg turns back in
    that plane to its old hip-ankle line, then swings that line onto the target (minimal arc).
    """
    hip, knee, ankle = chain[:, 0], chain[:, 1], chain[:, 2]
    thigh = np.linalg.norm(knee - hip, axis=-1)  # (N,)
    shin = np.linalg.norm(ankle - knee, axis=-1)
    eps = 1e-9 * (thigh + shin)
    distance = np.clip(np.linalg.norm(targets - hip, axis=-1), np.abs(thigh - shin) + eps, thigh + shin - eps)

    def angle(u: FloatArray, v: FloatArray) -> FloatArray:
        cosine = np.sum(u * v, -1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
        return np.arccos(np.clip(cosine, -1.0, 1.0))

    hip_angle_0 = angle(ankle - hip, knee - hip)
    knee_angle_0 = angle(hip - knee, ankle - knee)
    hip_angle_1 = np.arccos(np.clip((thigh**2 + distance**2 - shin**2) / (2 * thigh * distance), -1, 1))
    knee_angle_1 = np.arccos(np.clip((thigh**2 + shin**2 - distance**2) / (2 * thigh * shin), -1, 1))
    bend = to_matrix(axes * (knee_angle_1 - knee_angle_0)[:, None])  # (N, 3, 3) about the knee
    turn = to_matrix(axes * (hip_angle_1 - hip_angle_0)[:, None])  # about the hip, back onto the old line
    cross = np.cross(ankle - hip, targets - hip)
    swing_axis = cross / np.maximum(np.linalg.norm(cross, axis=-1), 1e-300)[:, None]
    swing = to_matrix(swing_axis * angle(ankle - hip, targets - hip)[:, None])
    new_upper = swing @ turn @ upper_world
    return new_upper, swing @ turn @ bend @ knee_world
