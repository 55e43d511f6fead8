"""Foot clean-up: pin planted feet with two-joint leg IK, and let the root follow the stride.

Contacts come from `steps.contacts`; the IK from `steps.leg_ik`; the root's following from
`steps.root_follow`. Axes +Y up; lengths in the file's unit.
"""

from __future__ import annotations

import numpy as np

from elastyle.core.body import Limbs, find_limbs, leg_length
from elastyle.core.foot_tips import on_own_joints, with_foot_tips
from elastyle.core.ground import ground_level
from elastyle.core.motion import Motion
from elastyle.core.rotations import lengths
from elastyle.core.smoothing import pad_edges, smooth
from elastyle.steps.contacts import checked_contacts, contact_points, detect_contacts, mask_runs, pivots
from elastyle.steps.leg_ik import is_below, leg_ik
from elastyle.steps.root_follow import SMOOTH_SIGMA_OF_WIDTH, carried_by_pelvis, root_shift, shift_pelvis
from elastyle.types import BoolArray, FloatArray, IntArray

BRIDGE_GAP_S = 0.6  # a foot's gaps between contacts up to this long (a step's swing) are bridged directly
# a lift up to a foot floor (`clean_feet`) eases in and out over this long (seconds), a swing's few frames
FLOOR_EASE_S = 0.1
SOFT_REACH = 0.995  # IK straightens a knee up to this fraction of the leg's reach before lowering the pelvis
# ... and lowers it by at most this fraction of the leg: a pin further out is left short (the foot slides a
# little) rather than the body sinking (a walk restarting after a stop, its contact from the content held on
# while the styled foot stepped on, dropped the pelvis from 90 to 13 cm for a second)
MAX_LOWERING_OF_LEG = 0.1


def plant_feet(
    motion: Motion,
    root_share: float | FloatArray,
    also: BoolArray | None = None,
    foot_floor: FloatArray | None = None,
    lowest_ground: float | None = None,
    root_applied: FloatArray | None = None,
    foot_ceiling: FloatArray | None = None,
    lowering_share: FloatArray | None = None,
    needed: BoolArray | None = None,
    in_place: bool = False,
    root_moved: FloatArray | None = None,
) -> Motion:
    """The whole clean-up (see `_plant_feet`), a toe-less foot read at its End Site (`core.foot_tips`).
    in_place: the clip is animated in place (`steps.action.clip_in_place`: its feet slide under a pelvis that
    stays, as a game engine's root motion will carry it): nothing is pinned nor the root moved, the feet
    are only kept above the ground."""
    extended = _plant_feet(
        with_foot_tips(motion), root_share, also, foot_floor, lowest_ground, root_applied, foot_ceiling,
        lowering_share, needed, in_place, root_moved,
    )  # fmt: skip
    return on_own_joints(extended, motion.skeleton)


def _plant_feet(
    motion: Motion,
    root_share: float | FloatArray,
    also: BoolArray | None = None,
    foot_floor: FloatArray | None = None,
    lowest_ground: float | None = None,
    root_applied: FloatArray | None = None,
    foot_ceiling: FloatArray | None = None,
    lowering_share: FloatArray | None = None,
    needed: BoolArray | None = None,
    in_place: bool = False,
    root_moved: FloatArray | None = None,
) -> Motion:
    """The whole clean-up: contacts found, the root moved by `root_share` (or per frame (T,)) of the stance feet's drift
    (`steps.root_follow.adjust_root_speed`, skipped at 0), then the feet pinned (`clean_feet`). One forward kinematics pass
    serves all three: moving the root moves the legs with it and turns nothing. also: (T, F) contacts known
    from elsewhere, added to those found; foot_floor: (T, F, 2) the lowest height of each foot's toe and
    ankle (`clean_feet`): legs that step as another clip does take its contacts and its feet's clearance
    of the ground (`steps.contacts.held_footing`); lowest_ground: `clean_feet`; root_applied: (T,) how far
    each frame takes the root's move (`steps.root_follow.root_shift`), all of it when None; foot_ceiling:
    `clean_feet`; lowering_share: (T,) `clean_feet`; needed: (T,) `_clean_feet`; in_place: `plant_feet`;
    root_moved: (T, 3) world, how far an earlier clean-up moved the pelvis off its path (`root_shift`'s
    `moved`)."""
    skeleton, limbs = motion.skeleton, find_limbs(motion.skeleton)
    if len(limbs.toes) == 0:
        return _clean_feet(motion)
    world_rotations, positions = motion.world(limbs.feet)
    ground = _ground(motion, positions, lowest_ground)
    contacts = detect_contacts(motion, positions, ground)
    if also is not None:
        contacts = contacts | checked_contacts(also, motion, limbs)
    if in_place:
        contacts, root_share = np.zeros_like(contacts), 0.0
    if np.any(np.asarray(root_share) > 0):
        shift = root_shift(
            motion, contacts, (world_rotations, positions), root_share, applied=root_applied, moved=root_moved
        )  # (T, 3) world
        motion = Motion(
            skeleton, motion.rotations.copy(), shift_pelvis(motion, world_rotations, shift), motion.fps
        )
        positions = positions.copy()
        positions[:, carried_by_pelvis(skeleton, limbs)] += shift[:, None]
    return _clean_feet(
        motion,
        contacts,
        world=(world_rotations, positions),
        foot_floor=foot_floor,
        ground=ground,
        foot_ceiling=foot_ceiling,
        lowering_share=lowering_share,
        needed=needed,
    )


def clean_feet(
    motion: Motion,
    contacts: BoolArray | None = None,
    blend_s: float = 0.15,
    foot_floor: FloatArray | None = None,
    lowest_ground: float | None = None,
    needed: BoolArray | None = None,
) -> Motion:
    """Feet pinned (see `_clean_feet`), a toe-less foot read at its End Site (`core.foot_tips`), on the toes'
    ground level: the clip's own `ground_level`, but not below `lowest_ground` (file units; a transfer gives
    its content's floor less a centimetre, so toes the style's statistics swing through that floor are
    lifted to it, and a foot standing on it is read as standing: `steps.contacts.point_grounds`). needed:
    `_clean_feet`."""
    extended = with_foot_tips(motion)
    limbs = find_limbs(extended.skeleton)
    world = extended.world(limbs.feet) if len(limbs.toes) else None
    ground = _ground(extended, world[1], lowest_ground) if world is not None else None
    pinned = _clean_feet(extended, contacts, blend_s, world, foot_floor, ground, needed=needed)
    return on_own_joints(pinned, motion.skeleton)


def _ground(motion: Motion, positions: FloatArray, lowest: float | None) -> float:
    """The toes' ground level (file units) of a clip (positions (T, J, 3)): its own, not below `lowest`."""
    own = ground_level(motion, positions)
    return own if lowest is None else max(own, lowest)


def _clean_feet(
    motion: Motion,
    contacts: BoolArray | None = None,
    blend_s: float = 0.15,
    world: tuple[FloatArray, FloatArray] | None = None,
    foot_floor: FloatArray | None = None,
    ground: float | None = None,
    foot_ceiling: FloatArray | None = None,
    lowering_share: FloatArray | None = None,
    needed: BoolArray | None = None,
) -> Motion:
    """Pin each planted foot in place with two-joint IK; a new Motion (same skeleton, fps and frames).

    contacts: (T, F) from `detect_contacts` (detected here when None). During a contact the foot is held
    horizontally around its mean position (the toe, or the ankle at heel strike, stops moving; the hold
    fades as the foot lifts off); heights stay. The correction eases in and out over `blend_s` seconds
    (cubic Hermite, matching position and velocity at the contact's ends) and is carried straight across
    a step's swing. Anywhere, a toe or ankle below `ground_level` is lifted to it. Feet keep their world
    orientation; hip and knee turn in the original knee plane; the pelvis is lowered (smoothly) only
    where a leg cannot reach, by at most `MAX_LOWERING_OF_LEG` of the leg (a target still out of reach is
    left short). Only leg rotations and the pelvis height change: bone lengths stay exact.
    world: the clip's world rotations and positions (`Motion.world`) of the feet and their ancestors, when
    already known. foot_floor: (T, F, 2) the lowest height (file units) of each foot's toe and ankle
    (`contact_points` order), -inf where free: the foot is lifted where either is below it, by the lift
    eased over `FLOOR_EASE_S` (never below what it needs, so a swinging foot clears that floor instead of
    skimming along it) and, nearer a contact of its own, by less of the easing, down to each planted
    frame's own need (no easing raises a foot that stands). ground: the toes' ground level (file units),
    the clip's own `ground_level` when None (`clean_feet`: not below the floor the output walks on); above
    the clip's own, contacts and pivots are read from it too (`steps.contacts.point_grounds`).
    foot_ceiling: (T, F, 2) the highest each foot's toe and ankle may stand (file units), +inf where free
    (`steps.contacts.held_footing`: a held contact's own heights): where both are above it the foot is
    lowered by the smaller excess, eased over `FLOOR_EASE_S`, before its hold is read.
    lowering_share: (T,) 0 to 1, how much of `MAX_LOWERING_OF_LEG` each frame allows (all of it when None):
    legs that keep the content's action keep its pelvis height too.
    needed: (T,) the frames whose legs the caller reads (a blend's others take another clip's): the IK runs
    on these only, the others keep the input's leg rotations (None: every frame).
    """
    skeleton, limbs = motion.skeleton, find_limbs(motion.skeleton)
    if len(limbs.toes) == 0:
        return Motion(skeleton, motion.rotations.copy(), motion.translations.copy(), motion.fps)
    world_rotations, positions = motion.world(limbs.feet) if world is None else world  # legs and their roots
    contacts = (
        detect_contacts(motion, positions, ground)
        if contacts is None
        else checked_contacts(contacts, motion, limbs)
    )
    leg = leg_length(skeleton, limbs)
    ground = ground_level(motion, positions) if ground is None else ground
    ramp_frames = blend_s * motion.fps
    bridge_frames = max(BRIDGE_GAP_S * motion.fps, 2 * ramp_frames)
    # 0. a foot over its ceiling (a held stance risen under the style's statistics) lowered, so it is held
    lowered = np.zeros((motion.num_frames, len(limbs.toes)))  # (T, F)
    held_at = positions
    if foot_ceiling is not None:
        joints = contact_points(limbs)  # (F, 2)
        over = positions[:, joints, 1] - _checked_floor(foot_ceiling, motion, limbs)  # (T, F, 2)
        lowered = smooth(np.maximum(0.0, np.min(over, axis=-1)), FLOOR_EASE_S * motion.fps)
        held_at = positions.copy()
        held_at[:, joints, 1] -= lowered[..., None]
    # 1. ankle targets: the pinned contact point's correction moves the whole foot, then lift to the ground
    points, weights = pivots(held_at, limbs, leg, ground)  # (T, F, 2, 3), (T, F, 2)
    targets = positions[:, limbs.ankles].copy()  # (T, F, 3)
    targets[..., 1] -= lowered
    for foot in range(len(limbs.toes)):
        targets[:, foot] += _pin_corrections(
            points[:, foot], weights[:, foot], contacts[:, foot], ramp_frames, bridge_frames
        )
    toe_heights = positions[:, limbs.toes, 1] + targets[..., 1] - positions[:, limbs.ankles, 1]  # (T, F)
    lift = np.maximum(0.0, ground - np.minimum(toe_heights, targets[..., 1]))  # (T, F)
    if foot_floor is not None:
        heights = np.stack([toe_heights, targets[..., 1]], axis=-1)  # (T, F, 2) toe, ankle
        need = np.maximum(0.0, np.max(_checked_floor(foot_floor, motion, limbs) - heights, axis=-1))
        lift = np.maximum(lift, _eased_off_contact(need, contacts, FLOOR_EASE_S * motion.fps))
    targets[..., 1] += lift
    # 2. lower the pelvis where a target is out of reach: the pelvis and every joint below it move with it
    knees = skeleton.parents[limbs.ankles]
    chains = np.stack([skeleton.parents[knees], knees, limbs.ankles], axis=1)  # (F, 3) upper leg, knee, ankle
    # the upper leg must hang below the leg's root: a two-bone leg off the pelvis has no knee to bend
    legs = np.array([is_below(skeleton, int(chain[0]), int(hip)) for chain, hip in zip(chains, limbs.hips)])
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    allowed = MAX_LOWERING_OF_LEG * leg * (1.0 if lowering_share is None else np.clip(lowering_share, 0, 1))
    lowering = np.minimum(
        _pelvis_lowering(positions, chains[legs], targets[:, legs], ramp_frames), allowed
    )  # (T,)
    if np.any(lowering > 0):
        shift = np.zeros((motion.num_frames, 3))
        shift[:, 1] = -lowering
        translations = shift_pelvis(motion, world_rotations, shift)
        positions = positions.copy()
        positions[:, carried_by_pelvis(skeleton, limbs)] += shift[:, None]
    # 3. two-joint IK, every leg at once; only frames whose ankle has to move change (elsewhere the input stays exact)
    chains = chains[legs]
    moved = lengths(targets[:, legs] - positions[:, chains[:, 2]]) > 1e-9 * leg  # (T, F_legs)
    if needed is not None:
        moved &= needed[:, None]
    rows = np.flatnonzero(np.any(moved, axis=1))  # (n,) frames whose legs turn
    if len(rows):
        parents = skeleton.parents[chains[:, 0]]
        local = leg_ik(
            world_rotations, positions, parents, chains, targets[:, legs], rows
        )  # (n, F_legs, 3, 3)
        frames, feet = np.nonzero(moved[rows])
        rotations[rows[frames][:, None], chains[feet]] = local[frames, feet]
    return Motion(skeleton, rotations, translations, motion.fps)


def lift_to_ground(
    motion: Motion, lowest_ground: float | None = None, needed: BoolArray | None = None
) -> Motion:
    """Toes and ankles below the toes' ground level (`clean_feet`) lifted to it by the legs' IK, nothing
    else changed: for legs set after the clean-up (those that keep the content's action). needed:
    `_clean_feet`."""
    limbs = find_limbs(motion.skeleton)
    no_contacts = np.zeros((motion.num_frames, len(limbs.toes)), dtype=bool)
    return clean_feet(motion, no_contacts, lowest_ground=lowest_ground, needed=needed)


def _checked_floor(floor: FloatArray, motion: Motion, limbs: Limbs) -> FloatArray:
    floor = np.asarray(floor, dtype=np.float64)
    if floor.shape != (motion.num_frames, len(limbs.toes), 2):
        raise ValueError(f"foot_floor must be ({motion.num_frames}, {len(limbs.toes)}, 2), got {floor.shape}")
    return floor


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
    runs = np.array(mask_runs(contact), dtype=np.int64).reshape(-1, 2)  # (R, 2) [start, stop) of each contact
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
    return _eased_need(np.max(need, axis=1, initial=0.0), ramp_frames)  # (T,)


def _eased_off_contact(need: FloatArray, contacts: BoolArray, ramp_frames: float) -> FloatArray:
    """A lift needed per frame and foot (T, F) eased as `_eased_need` away from the foot's contacts (T, F)
    and, over `ramp_frames` towards each, back to the frame's own need: a planted foot is lifted only as
    far as it needs, and the lift does not jump where a contact starts or ends."""
    eased = _eased_need(need, ramp_frames)
    frames = np.arange(len(need), dtype=np.float64)[:, None]  # (T, 1)
    last = np.maximum.accumulate(np.where(contacts, frames, -np.inf), axis=0)  # the latest contact so far
    following = np.minimum.accumulate(np.where(contacts, frames, np.inf)[::-1], axis=0)[::-1]
    away = np.clip(np.minimum(frames - last, following - frames) / max(ramp_frames, 1.0), 0.0, 1.0)
    return need + away * away * (3 - 2 * away) * (eased - need)


def _eased_need(need: FloatArray, ramp_frames: float) -> FloatArray:
    """A correction needed per frame (T, ...), >= 0, made smooth in time and never below the need: dilated
    over `ramp_frames` either side, then averaged over a Gaussian of `SMOOTH_SIGMA_OF_WIDTH` of that."""
    if not np.any(need > 0):
        return need
    radius = max(1, int(np.ceil(ramp_frames)))
    padded = pad_edges(need, radius, radius)
    dilated = np.lib.stride_tricks.sliding_window_view(padded, 2 * radius + 1, axis=0).max(axis=-1)
    return np.maximum(smooth(dilated, SMOOTH_SIGMA_OF_WIDTH * radius), need)
