"""Figures of a clip or a pair of clips, in physical units (cm, s) whatever the file's unit."""

from __future__ import annotations

import numpy as np

from elastyle.core.body import centimetres_per_unit, find_limbs
from elastyle.core.foot_tips import with_foot_tip_positions
from elastyle.core.motion import Motion
from elastyle.core.rhythm import dominant_frequency_hz
from elastyle.core.smoothing import frame_steps
from elastyle.types import BoolArray, FloatArray


def foot_contacts(motion: Motion, positions: FloatArray | None = None) -> BoolArray:
    """(T, F) True where a foot is planted: low and slow, with hysteresis (`cleanup.detect_contacts`)."""
    from elastyle.steps.contacts import detect_contacts

    del positions
    return detect_contacts(motion)


def foot_skating_cm_s(motion: Motion, positions: FloatArray | None = None) -> float:
    """Mean horizontal toe speed (cm/s) over the frames where the clean-up's own contact detector finds that
    foot planted: how well the clean-up pins what it detects (`floor_skating_cm_s` is the honest figure).
    A foot without a toe joint is read at its End Site (`core.foot_tips`)."""
    motion, positions = with_foot_tip_positions(motion, positions)
    limbs = find_limbs(motion.skeleton)
    contacts = foot_contacts(motion, positions)[1:] & foot_contacts(motion, positions)[:-1]  # (T-1, F)
    velocity = np.diff(positions[:, limbs.toes][:, :, [0, 2]], axis=0) * motion.fps  # (T-1, F, 2)
    speed = np.linalg.norm(velocity, axis=-1) * centimetres_per_unit(motion.skeleton)
    return float(speed[contacts].mean()) if contacts.any() else 0.0


FLOOR_BAND_CM = 2.0  # a toe this close to its own floor may be in contact
FLOOR_VERTICAL_CM_S = 15.0  # ... if it moves up or down slower than this


def floor_skating_cm_s(motion: Motion, positions: FloatArray | None = None) -> float:
    """Mean horizontal toe speed (cm/s) while touching the clip's own floor, found without any contact
    detector (so a clean-up cannot grade itself): a toe (an ankle on a skeleton without toes) touches in a
    frame when it is within 2 cm of its own 5th-percentile height and moves vertically slower than 15 cm/s,
    and the frame counts with weight 2 - 2^(height / 2 cm) (1 on the floor, 0 at 2 cm). NaN without legs.
    A foot without a toe joint is read at its End Site (`core.foot_tips`)."""
    motion, positions = with_foot_tip_positions(motion, positions)
    limbs = find_limbs(motion.skeleton)
    joints = limbs.toes if len(limbs.toes) else limbs.ankles
    if len(joints) == 0 or motion.num_frames < 2:
        return float("nan")
    feet = positions[:, joints] * centimetres_per_unit(motion.skeleton)  # (T, F, 3) cm
    height = feet[..., 1] - np.percentile(feet[..., 1], 5, axis=0)  # (T, F) above each toe's own floor
    step = frame_steps(feet) * motion.fps  # (T, F, 3) cm/s, central differences
    touching = (height < FLOOR_BAND_CM) & (np.abs(step[..., 1]) < FLOOR_VERTICAL_CM_S)
    weight = np.clip(2 - 2 ** (height / FLOOR_BAND_CM), 0.0, 1.0) * touching
    if weight.sum() <= 0:
        return 0.0
    speed = np.linalg.norm(step[..., [0, 2]], axis=-1)
    return float((weight * speed).sum() / weight.sum())


def jerk(positions: FloatArray, fps: float) -> float:
    """Mean magnitude of the third time derivative of joint positions (units/s^3)."""
    if positions.shape[0] < 4:
        return 0.0
    third = np.diff(positions, n=3, axis=0) * fps**3
    return float(np.linalg.norm(third, axis=-1).mean())


def _lateral_difference(motion: Motion, positions: FloatArray, left: int, right: int) -> FloatArray:
    """Signed distance (T,) of joint `left` ahead of joint `right` along the body's travel direction."""
    from elastyle.core.body import heading_yaw, pelvis_forward_local

    world_rotations, _ = motion.world()
    yaw = heading_yaw(world_rotations[:, motion.skeleton.pelvis], pelvis_forward_local(motion.skeleton))
    forward = np.stack([np.sin(yaw), np.cos(yaw)], axis=1)  # (T, 2) x, z
    delta = positions[:, left][:, [0, 2]] - positions[:, right][:, [0, 2]]
    return np.sum(delta * forward, axis=1)


MIN_STEP_SWING_CM = (
    4.0  # feet whose lead over each other swings less than this (5th to 95th percentile) do not step
)


def _alternation_hz(
    motion: Motion, positions: FloatArray | None, limb: str, min_swing_cm: float = 0.0
) -> float:
    """Dominant frequency (Hz) of one of a pair of limbs ('ankles' or 'hands') leading the other; NaN
    where the lead swings less than `min_swing_cm`."""
    positions = motion.positions() if positions is None else positions
    pair = getattr(find_limbs(motion.skeleton), limb)
    if len(pair) < 2:
        return float("nan")
    lead = _lateral_difference(motion, positions, int(pair[0]), int(pair[1]))
    swing = float(np.subtract(*np.percentile(lead, [95, 5]))) * centimetres_per_unit(motion.skeleton)
    if swing < min_swing_cm:
        return float("nan")
    return dominant_frequency_hz(lead, motion.fps, 0.25, 2.0)


def cadence_steps_s(motion: Motion, positions: FloatArray | None = None) -> float:
    """Steps per second: twice the dominant frequency of one foot's lead over the other; NaN for a clip
    that does not step: the lead swings less than `MIN_STEP_SWING_CM`, or no foot moves that far over the
    ground (a standing wave's feet, still, lead each other by 5 cm more or less as the body turns)."""
    positions = motion.positions() if positions is None else positions
    ankles = find_limbs(motion.skeleton).ankles
    ground = positions[:, ankles][..., [0, 2]]  # (T, F, 2) each foot's place on the ground
    spread = np.linalg.norm(np.subtract(*np.percentile(ground, [95, 5], axis=0)), axis=-1)  # (F,)
    if len(ankles) and np.max(spread) * centimetres_per_unit(motion.skeleton) < MIN_STEP_SWING_CM:
        return float("nan")
    return 2.0 * _alternation_hz(motion, positions, "ankles", MIN_STEP_SWING_CM)


def arm_swing_hz(motion: Motion, positions: FloatArray | None = None) -> float:
    """Dominant frequency of one hand's lead over the other (a full swing cycle per second)."""
    return _alternation_hz(motion, positions, "hands")


def timing_error(output_steps_s: float, content_steps_s: float, style_steps_s: float) -> float:
    """|f_out - f_style| / |f_content - f_style|: 0 = the style's timing, 1 = the content's."""
    return abs(output_steps_s - style_steps_s) / max(abs(content_steps_s - style_steps_s), 1e-9)


def reconstruction_errors(original: Motion, reconstructed: Motion) -> dict[str, float]:
    """Pelvis-aligned mean joint position error and end-effector error (cm), skating and jerk ratios."""
    scale = centimetres_per_unit(original.skeleton)
    limbs = find_limbs(original.skeleton)
    ours, theirs = original.positions(), reconstructed.positions()
    pelvis = original.skeleton.pelvis
    aligned = (theirs - theirs[:, pelvis : pelvis + 1]) - (ours - ours[:, pelvis : pelvis + 1])
    error = np.linalg.norm(aligned, axis=-1) * scale  # (T, J)
    effectors = np.concatenate([limbs.toes, limbs.hands])
    return {
        "joint_error_cm": float(error.mean()),
        "end_effector_error_cm": float(error[:, effectors].mean()),
        "skating_cm_s": foot_skating_cm_s(reconstructed, theirs),
        "original_skating_cm_s": foot_skating_cm_s(original, ours),
        "jerk_ratio": jerk(theirs, original.fps) / max(jerk(ours, original.fps), 1e-9),
    }
