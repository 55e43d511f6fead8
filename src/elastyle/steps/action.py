"""What the body does, frame by frame: the action descriptors the patch search matches besides the latents.

The model's latents carry the pose's manner but little of where the body goes or which hand is up, so a
search on latents alone swaps a content window for a style window that performs another action (a
sideways step for a forward one, the left hand for the right). These channels say what defines the action,
in leg lengths (per second) so any unit, skeleton size and frame rate compare alike. Axes +Y up; the
heading frame turns with the pelvis's yaw (+Z forward).

    travel (3)       pelvis velocity in the heading frame, forward and sideways (legs/s); turning (rad/s).
                     A clip animated in place (its pelvis stays while its feet step: the root motion taken
                     out, as game engines take it) travels as its feet say: the pelvis's velocity less the
                     lower foot's (`clip_in_place`), so it matches a clip that walks as it does
    each hand (4)    position relative to the pelvis in the heading frame (legs), and speed (legs/s)
    each foot (1)    ankle height above its own ground level (legs): lifted, planted
    the pelvis (1)   its height less the clip's carriage (its mean over the clip's highest frames; legs): a
                     crouch, a squat or a jump (with feet only)
    the trunk (3)    the head's place relative to the pelvis in the heading frame less the clip's carriage
                     (its place over the clip's most upright frames; legs): a lean or a bow away from it (a
                     stoop held throughout is a manner, not an action)
    the gaze (3)     where the head faces in the heading frame, as a point `GAZE_LEGS` ahead of it, less the
                     clip's carriage the same way (legs): a nod or a look aside, which turn the head in place

Left and right keep their own channels, so a mirrored style window is close only where the content's
sides agree with it.
"""

from __future__ import annotations

from itertools import count
from typing import NamedTuple

import numpy as np

from elastyle.core.body import find_limbs, heading_yaw, leg_length, pelvis_forward_local, yaw_matrices
from elastyle.core.ground import GROUND_PERCENTILE, PERCENTILE_METHOD
from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts, trunk
from elastyle.core.rotations import lengths
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import frame_steps, smooth
from elastyle.core.stats import median
from elastyle.types import BoolArray, FloatArray, IntArray

# sustained turning: the yaw rate low-passed with this sigma (seconds), so a step's sway does not count
TURNING_SMOOTH_S = 0.5
TURNING_COLUMN = 2  # the turning rate's column in `action_channels` (after forward and sideways travel)
SMOOTH_S = 0.1  # velocities are low-passed over about this long (sigma 0.4 of it), so noise does not count
# the gaze is read as a point this far (leg lengths) ahead of the head: a 30-degree nod moves it 0.39 legs,
# a walk's head bob of a few degrees under 0.1
GAZE_LEGS = 0.75


class ActionLayout(NamedTuple):
    """Which columns of a skeleton's `action_channels` (T, A) say what (the module's table).

    travel: (2,) forward and sideways; turning: the turning rate's; hands: (H, 3) each hand's place;
    hand_speeds: (H,); feet: (F,) each foot's height; pelvis_height: (1,), or (0,) without feet; lean, gaze:
    (3,) each, or (0,) without a trunk; width: A. parts: each body part's columns, what its action mismatch
    compares: the legs' travel, turning and feet; the spine's lean and gaze; each arm's hand place then
    speed; arm_hands: each arm part's hand place columns (3,).
    """

    travel: IntArray
    turning: int
    hands: IntArray
    hand_speeds: IntArray
    feet: IntArray
    pelvis_height: IntArray
    lean: IntArray
    gaze: IntArray
    width: int
    parts: dict[str, IntArray]
    arm_hands: dict[str, IntArray]

    @property
    def legs(self) -> IntArray:
        """The legs' columns: travel, turning, then each foot's height."""
        return self.parts["legs"]

    @property
    def gait(self) -> IntArray:
        """The legs' columns without the turning: travel and steps (another action, not another path)."""
        return np.concatenate([self.travel, self.feet])

    @property
    def place(self) -> IntArray:
        """Where the legs are: each foot's height and the pelvis's, which follows them; none without feet.
        The pelvis's height is no part of the legs' mismatch: a column that agrees in every gait diluted it (a
        walk given a run's style, its legs' mismatch near the threshold, took the run's legs)."""
        return np.concatenate([self.feet, self.pelvis_height])


def action_layout(skeleton: Skeleton) -> ActionLayout:
    """The `ActionLayout` of a skeleton's `action_channels`."""
    limbs = find_limbs(skeleton)
    num_hands, num_feet = len(limbs.hands), len(limbs.ankles)
    columns = count()

    def take(width: int) -> IntArray:
        return np.array([next(columns) for _ in range(width)], dtype=np.int64)

    travel, turning = take(2), int(take(1)[0])
    assert turning == TURNING_COLUMN  # the turning rate's column is the same on every skeleton
    hands, hand_speeds = take(3 * num_hands).reshape(num_hands, 3), take(num_hands)
    feet, pelvis_height = take(num_feet), take(1 if num_feet else 0)
    parts_of = body_parts(skeleton)
    has_trunk = trunk_top(skeleton) is not None
    lean, gaze = take(3 if has_trunk else 0), take(3 if has_trunk else 0)
    width = next(columns)
    parts = {"legs": np.concatenate([travel, [turning], feet])}
    if has_trunk and "spine" in parts_of:
        parts["spine"] = np.concatenate([lean, gaze])
    arm_hands = {}
    for name, joints in parts_of.items():
        for h, hand in enumerate(limbs.hands.tolist()):
            if hand in joints:
                parts[name] = np.append(hands[h], hand_speeds[h])
                arm_hands[name] = hands[h]
    return ActionLayout(
        travel, turning, hands, hand_speeds, feet, pelvis_height, lean, gaze, width, parts, arm_hands
    )


def trunk_top(skeleton: Skeleton) -> int | None:
    """The trunk's joint farthest from the pelvis at rest (the head, on most rigs), whose place says how the
    upper body leans; None for a skeleton without a trunk (`core.parts.trunk`)."""
    joints = trunk(skeleton)
    if not joints:
        return None
    rest = skeleton.rest_positions()
    return int(joints[int(np.argmax(lengths(rest[joints] - rest[skeleton.pelvis])))])


def action_channels(motion: Motion, world: tuple[FloatArray, FloatArray] | None = None) -> FloatArray:
    """(T, A) action descriptors of a clip (`action_layout`; see the module's table). world: the
    clip's world rotations and positions (`Motion.world`) of at least the pelvis, hands, ankles and toes,
    when already known."""
    skeleton, limbs, top = motion.skeleton, find_limbs(motion.skeleton), trunk_top(motion.skeleton)
    leg = leg_length(skeleton, limbs)  # half the body's height without legs
    tops = [] if top is None else [top]
    world_rotations, positions = (
        motion.world([skeleton.pelvis, *limbs.hands, *limbs.ankles, *limbs.toes, *tops])
        if world is None
        else world
    )
    pelvis = positions[:, skeleton.pelvis]  # (T, 3)
    yaw = heading_yaw(world_rotations[:, skeleton.pelvis], pelvis_forward_local(skeleton))  # (T,)
    to_heading = np.swapaxes(yaw_matrices(yaw), -1, -2)  # (T, 3, 3) world -> heading frame
    per_second = motion.fps / leg
    sigma = 0.4 * SMOOTH_S * motion.fps
    steps = frame_steps(pelvis)  # (T, 3)
    feet = positions[:, [*limbs.ankles, *limbs.toes]]  # (T, 2F, 3) the points a foot stands on
    if len(limbs.ankles) and _stays_in_place(pelvis, feet, leg, motion.fps):
        steps = steps - _lower_foot_steps(feet, leg, motion.fps)
    travel = np.einsum("tij,tj->ti", to_heading, steps) * per_second  # (T, 3) legs/s
    turning = frame_steps(yaw) * motion.fps  # (T,) rad/s
    channels = [travel[:, [2, 0]], turning[:, None]]
    if len(limbs.hands):
        hands = np.einsum("tij,thj->thi", to_heading, positions[:, limbs.hands] - pelvis[:, None]) / leg
        hand_speed = lengths(frame_steps(hands)) * motion.fps  # (T, H) legs/s, relative to the pelvis
        channels += [hands.reshape(motion.num_frames, -1), hand_speed]
    if len(limbs.ankles):
        heights = positions[:, limbs.ankles, 1]
        ground = np.percentile(heights, GROUND_PERCENTILE, axis=0, method=PERCENTILE_METHOD)
        channels.append((heights - ground) / leg)
        height = pelvis[:, 1:2] / leg  # (T, 1)
        channels.append(height - carriage(height, height[:, 0]))
    if top is not None:
        lean = np.einsum("tij,tj->ti", to_heading, positions[:, top] - pelvis) / leg  # (T, 3) legs
        head = to_heading @ world_rotations[:, top]  # (T, 3, 3) the head's frame in the heading frame
        # the head's own axis that points forward in its usual carriage (a rig's frames face any way)
        facing = carriage(head[:, 2, :], lean[:, 1])  # (3,) in the head's frame
        gaze = GAZE_LEGS * head @ (facing / max(float(lengths(facing)), 1e-9))  # (T, 3) legs
        channels += [lean - carriage(lean, lean[:, 1]), gaze - carriage(gaze, lean[:, 1])]
    return smooth(np.concatenate(channels, axis=1), sigma)


# a clip is animated in place where its feet step on (the lower one's median ground speed above this, legs/s)
# while its pelvis moves on less than `IN_PLACE_SHARE` of that: a walk in place 0.0 against 1.2 legs/s, a walk
# 1.3 against 0.03, a run 3.9 against 1.9 (its lower foot in flight swings), a stand 0.02 against 0.0
IN_PLACE_FEET_LEGS_S = 0.3
IN_PLACE_SHARE = 0.25


LOWER_FOOT_LEGS = (
    0.005  # a foot this much higher (leg lengths) than the lowest weighs 1/e as much in its steps
)


def _lower_foot_steps(points: FloatArray, leg: float, fps: float | None = None) -> FloatArray:
    """(T, 3) ground steps per frame of the points the body stands on: each of the feet's ankles and toes
    (T, P, 3) its own steps, weighed by how near it is to the lowest one's height (heights kept 0): the heel
    at a heel strike, the toe as the foot rolls over it. A point's own steps, not the lowest one's place:
    where that changes, its place jumps a stride. With `fps`, frames where even the lowest point is off the
    ground (a run's flight) take their neighbours' steps (over about `SMOOTH_S`)."""
    heights = points[..., 1]  # (T, P)
    lowest = heights.min(axis=1, keepdims=True)  # (T, 1)
    weights = np.exp(-(heights - lowest) / (LOWER_FOOT_LEGS * leg))
    steps = np.einsum("tp,tpc->tc", weights / weights.sum(axis=1, keepdims=True), frame_steps(points))
    steps[:, 1] = 0.0
    if fps is not None:
        ground = np.percentile(lowest, GROUND_PERCENTILE, method=PERCENTILE_METHOD)
        bearing = np.exp(-(lowest - ground) / (4 * LOWER_FOOT_LEGS * leg))  # (T, 1)
        steps = smooth(steps * bearing, SMOOTH_S * fps) / np.maximum(smooth(bearing, SMOOTH_S * fps), 1e-12)
    return steps


def clip_in_place(motion: Motion, world: tuple[FloatArray, FloatArray] | None = None) -> bool:
    """Whether a clip is animated in place (`_stays_in_place`); world: `action_channels`'."""
    limbs = find_limbs(motion.skeleton)
    if not len(limbs.ankles):
        return False
    feet = [*limbs.ankles, *limbs.toes]
    positions = (motion.world([motion.skeleton.pelvis, *feet]) if world is None else world)[1]
    leg = leg_length(motion.skeleton, limbs)
    return _stays_in_place(positions[:, motion.skeleton.pelvis], positions[:, feet], leg, motion.fps)


def _stays_in_place(pelvis: FloatArray, feet: FloatArray, leg: float, fps: float) -> bool:
    """Whether a clip is animated in place: pelvis (T, 3) and the feet's ankles and toes (T, P, 3) world
    positions, leg its length (file units); see `IN_PLACE_FEET_LEGS_S`."""
    stepping = median(lengths(_lower_foot_steps(feet, leg)[:, [0, 2]]), axis=0) * fps / leg  # legs/s
    body = median(lengths(frame_steps(pelvis)[:, [0, 2]]), axis=0) * fps / leg
    return bool(stepping > IN_PLACE_FEET_LEGS_S and body < IN_PLACE_SHARE * stepping)


UPRIGHT_SHARE = 0.1  # a clip's carriage: its mean over its most upright tenth of frames


def carriage(values: FloatArray, height: FloatArray) -> FloatArray:
    """(K,) a clip's usual carriage of per-frame values (T, K) (the pelvis's height; the head's place relative
    to the pelvis): their mean over the `UPRIGHT_SHARE` of frames where `height` (T,) is highest. A stoop or
    bent knees held throughout are in it; a bow or a crouch is not, however long it lasts (a median would
    follow one held for half the clip)."""
    count = max(1, int(round(UPRIGHT_SHARE * len(values))))
    return values[np.argsort(height)[-count:]].mean(axis=0)


def sustained_turning(actions: FloatArray, clip_starts: IntArray, fps: float) -> FloatArray:
    """(T,) the turning rate (rad/s) of `action_channels` (T, A) low-passed over `TURNING_SMOOTH_S`, clip by
    clip for clips end to end from clip_starts (K,): a walk along a curve, not a step's sway."""
    turning = np.zeros(len(actions))
    for start, end in zip(clip_starts, np.append(clip_starts[1:], len(actions))):
        turning[start:end] = smooth(actions[start:end, TURNING_COLUMN], TURNING_SMOOTH_S * fps)
    return turning


# a frame is still where the pelvis travels, every hand moves and every foot rises or falls slower than
# STILL_LEGS_S (leg lengths per second), and the body turns slower than STILL_TURNING (rad/s)
STILL_LEGS_S = 0.1
STILL_TURNING = 0.2


def still_frames(actions: FloatArray, layout: ActionLayout, fps: float) -> BoolArray:
    """(T,) the frames of a clip of `action_channels` (T, A) (their `ActionLayout`) at `fps` where the body
    holds still: a stop or an idle, which has no pace of its own to take a style's."""
    hand_speeds = actions[:, layout.hand_speeds]  # (T, H) legs/s
    return standing_legs(actions, layout, fps) & ~np.any(hand_speeds > STILL_LEGS_S, axis=1)


# a body travels (walks, runs) where its pelvis moves on faster than this (legs/s), its velocity low-passed over
# TRAVEL_SMOOTH_S (Gaussian sigma, s) so a move that comes back does not count: a slow walk moves about 0.6; a
# bow whose hips go back 20 cm reached 0.48 frame by frame, 0.15 low-passed
TRAVEL_LEGS_S = 0.3
TRAVEL_SMOOTH_S = 0.5


def travelling_legs(
    actions: FloatArray, layout: ActionLayout, clip_starts: IntArray, fps: float
) -> BoolArray:
    """(T,) the frames of `action_channels` (T, A) (their `ActionLayout`), clips end to end from clip_starts
    (K,), where the pelvis travels on faster than `TRAVEL_LEGS_S`."""
    travel = np.zeros((len(actions), 2))
    for start, end in zip(clip_starts, np.append(clip_starts[1:], len(actions))):
        travel[start:end] = smooth(actions[start:end, layout.travel], TRAVEL_SMOOTH_S * fps)
    return lengths(travel) > TRAVEL_LEGS_S


# both feet are off the ground (a run's flight) where the lower ankle is over this high above its ground (leg
# lengths, about 3 cm): dataset runs fly over 0.19 to 0.51 of their frames (an elderly jog none), walks 0 to
# 0.16 (an active walk's heels)
AIRBORNE_LEGS = 0.04


def airborne(actions: FloatArray, layout: ActionLayout) -> BoolArray:
    """(T,) the frames of `action_channels` (T, A) (their `ActionLayout`) where every foot is off the ground
    (`AIRBORNE_LEGS`); none for fewer than two feet."""
    if len(layout.feet) < 2:
        return np.zeros(len(actions), dtype=bool)
    return np.min(actions[:, layout.feet], axis=1) > AIRBORNE_LEGS


def standing_legs(actions: FloatArray, layout: ActionLayout, fps: float) -> BoolArray:
    """(T,) the frames of `action_channels` (T, A) (their `ActionLayout`) where the legs stand: the pelvis
    travels, every foot rises or falls slower than `STILL_LEGS_S` and the body turns slower than
    `STILL_TURNING`."""
    travel, turning, feet = (
        actions[:, layout.travel],
        actions[:, layout.turning],
        actions[:, layout.feet],
    )
    moving = (lengths(travel) > STILL_LEGS_S) | (np.abs(turning) > STILL_TURNING)
    moving |= np.any(np.abs(frame_steps(feet)) * fps > STILL_LEGS_S, axis=1)
    return ~moving


BACKWARDS_LEGS_S = 0.3  # forward travel below minus this (legs/s) is walking backwards ...
BACKWARDS_SHARE = 0.5  # ... and a clip that does so for over this share of its frames walks backwards


def walks_backwards(actions: FloatArray) -> bool:
    """Whether a clip of `action_channels` (T, A) travels backwards, against its heading, most of the time."""
    return bool(np.mean(actions[:, 0] < -BACKWARDS_LEGS_S) > BACKWARDS_SHARE) if len(actions) else False


def walks_sideways(actions: FloatArray) -> bool:
    """Whether a clip of `action_channels` (T, A) travels sideways, across its heading faster than along it
    and faster than `BACKWARDS_LEGS_S`, most (`BACKWARDS_SHARE`) of the time."""
    if not len(actions):
        return False
    across = np.abs(actions[:, 1])
    return bool(np.mean((across > BACKWARDS_LEGS_S) & (across > np.abs(actions[:, 0]))) > BACKWARDS_SHARE)
