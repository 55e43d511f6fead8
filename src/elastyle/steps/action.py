"""What the body does, frame by frame: the action descriptors the patch search matches besides the latents.

The model's latents carry the pose's manner but little of where the body goes or which hand is up, so a
search on latents alone swaps a content window for a style window that performs another action (a
sideways step for a forward one, the left hand for the right). These channels say what defines the action,
in leg lengths (per second) so any unit, skeleton size and frame rate compare alike. Axes +Y up; the
heading frame turns with the pelvis's yaw (+Z forward).

    travel (3)       pelvis velocity in the heading frame, forward and sideways (legs/s); turning (rad/s)
    each hand (4)    position relative to the pelvis in the heading frame (legs), and speed (legs/s)
    each foot (1)    ankle height above its own ground level (legs): lifted, planted
    the pelvis (1)   its height less the clip's carriage (its mean over the clip's highest frames; legs): a
                     crouch, a squat or a jump (with feet only)
    the trunk (3)    the head's place relative to the pelvis in the heading frame less the clip's carriage
                     (its place over the clip's most upright frames; legs): a lean or a bow away from it (a
                     stoop held throughout is a manner, not an action)

Left and right keep their own channels, so a mirrored style window is close only where the content's
sides agree with it.
"""

from __future__ import annotations

import numpy as np

from elastyle.core.body import find_limbs, heading_yaw, leg_length, pelvis_forward_local, yaw_matrices
from elastyle.core.ground import GROUND_PERCENTILE, PERCENTILE_METHOD
from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts, trunk
from elastyle.core.rotations import lengths
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import frame_steps, smooth
from elastyle.types import BoolArray, FloatArray, IntArray

# sustained turning: the yaw rate low-passed with this sigma (seconds), so a step's sway does not count
TURNING_SMOOTH_S = 0.5
TURNING_COLUMN = 2  # the turning rate's column in `action_channels` (after forward and sideways travel)
SMOOTH_S = 0.1  # velocities are low-passed over about this long (sigma 0.4 of it), so noise does not count


def action_width(skeleton: Skeleton) -> int:
    """A, the number of `action_channels` a clip of this skeleton has."""
    limbs = find_limbs(skeleton)
    feet = len(limbs.ankles) + (1 if len(limbs.ankles) else 0)  # each foot's height, the pelvis's
    return 3 + 4 * len(limbs.hands) + feet + (3 if trunk_top(skeleton) is not None else 0)


def trunk_top(skeleton: Skeleton) -> int | None:
    """The trunk's joint farthest from the pelvis at rest (the head, on most rigs), whose place says how the
    upper body leans; None for a skeleton without a trunk (`core.parts.trunk`)."""
    joints = trunk(skeleton)
    if not joints:
        return None
    rest = skeleton.rest_positions()
    return int(joints[int(np.argmax(lengths(rest[joints] - rest[skeleton.pelvis])))])


def action_channels(motion: Motion, world: tuple[FloatArray, FloatArray] | None = None) -> FloatArray:
    """(T, A) action descriptors of a clip (`action_width`; see the module's table). world: the
    clip's world rotations and positions (`Motion.world`) of at least the pelvis, hands and ankles, when
    already known."""
    skeleton, limbs, top = motion.skeleton, find_limbs(motion.skeleton), trunk_top(motion.skeleton)
    leg = leg_length(skeleton, limbs)  # half the body's height without legs
    tops = [] if top is None else [top]
    world_rotations, positions = (
        motion.world([skeleton.pelvis, *limbs.hands, *limbs.ankles, *tops]) if world is None else world
    )
    pelvis = positions[:, skeleton.pelvis]  # (T, 3)
    yaw = heading_yaw(world_rotations[:, skeleton.pelvis], pelvis_forward_local(skeleton))  # (T,)
    to_heading = np.swapaxes(yaw_matrices(yaw), -1, -2)  # (T, 3, 3) world -> heading frame
    per_second = motion.fps / leg
    sigma = 0.4 * SMOOTH_S * motion.fps
    travel = np.einsum("tij,tj->ti", to_heading, frame_steps(pelvis)) * per_second  # (T, 3) legs/s
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
        channels.append(lean - carriage(lean, lean[:, 1]))
    return smooth(np.concatenate(channels, axis=1), sigma)


UPRIGHT_SHARE = 0.1  # a clip's carriage: its mean over its most upright tenth of frames


def carriage(values: FloatArray, height: FloatArray) -> FloatArray:
    """(K,) a clip's usual carriage of per-frame values (T, K) (the pelvis's height; the head's place relative
    to the pelvis): their mean over the `UPRIGHT_SHARE` of frames where `height` (T,) is highest. A stoop or
    bent knees held throughout are in it; a bow or a crouch is not, however long it lasts (a median would
    follow one held for half the clip)."""
    count = max(1, int(round(UPRIGHT_SHARE * len(values))))
    return values[np.argsort(height)[-count:]].mean(axis=0)


def part_channels(skeleton: Skeleton) -> dict[str, IntArray]:
    """The columns of `action_channels` that say what each body part does: the legs' travel and turning, then
    each foot's height; each arm's hand (position x, y, z, then speed); the spine's lean (x, y, z)."""
    limbs = find_limbs(skeleton)
    num_hands = len(limbs.hands)
    feet_end = 3 + 4 * num_hands + len(limbs.ankles)
    columns = {"legs": [0, 1, 2, *range(3 + 4 * num_hands, feet_end)]}
    if trunk_top(skeleton) is not None and "spine" in body_parts(skeleton):
        lean = feet_end + (1 if len(limbs.ankles) else 0)  # after the pelvis's height
        columns["spine"] = [lean, lean + 1, lean + 2]
    for name, joints in body_parts(skeleton).items():
        for h, hand in enumerate(limbs.hands.tolist()):
            if hand in joints:
                columns[name] = [3 + 3 * h, 4 + 3 * h, 5 + 3 * h, 3 + 3 * num_hands + h]
    return {name: np.array(cols, dtype=np.int64) for name, cols in columns.items()}


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


def still_frames(actions: FloatArray, skeleton: Skeleton, fps: float) -> BoolArray:
    """(T,) the frames of a clip of `action_channels` (T, A) on `skeleton` at `fps` where the body holds still:
    a stop or an idle, which has no pace of its own to take a style's."""
    num_hands = len(find_limbs(skeleton).hands)
    hand_speeds = actions[:, 3 + 3 * num_hands : 3 + 4 * num_hands]  # (T, H) legs/s
    legs = part_channels(skeleton)["legs"]
    return standing_legs(actions, legs, fps) & ~np.any(hand_speeds > STILL_LEGS_S, axis=1)


def place_columns(leg_columns: IntArray) -> IntArray:
    """The columns of `action_channels` that say where the legs are, from the legs' (`part_channels`): each
    foot's height and the pelvis's, which follows them; none without feet. The pelvis's height is no part
    of the legs' mismatch: a column that agrees in every gait diluted it (a walk given a run's style, its
    legs' mismatch near the threshold, took the run's legs)."""
    feet = leg_columns[3:]
    return np.append(feet, feet[-1] + 1) if len(feet) else feet


# a body travels (walks, runs) where its pelvis moves on faster than this (legs/s), its velocity low-passed over
# TRAVEL_SMOOTH_S (Gaussian sigma, s) so a move that comes back does not count: a slow walk moves about 0.6; a
# bow whose hips go back 20 cm reached 0.48 frame by frame, 0.15 low-passed
TRAVEL_LEGS_S = 0.3
TRAVEL_SMOOTH_S = 0.5


def travelling_legs(
    actions: FloatArray, leg_columns: IntArray, clip_starts: IntArray, fps: float
) -> BoolArray:
    """(T,) the frames of `action_channels` (T, A), clips end to end from clip_starts (K,), where the pelvis
    travels on faster than `TRAVEL_LEGS_S`; leg_columns: the legs' columns (`part_channels`: travel first)."""
    travel = np.zeros((len(actions), 2))
    for start, end in zip(clip_starts, np.append(clip_starts[1:], len(actions))):
        travel[start:end] = smooth(actions[start:end, leg_columns[:2]], TRAVEL_SMOOTH_S * fps)
    return lengths(travel) > TRAVEL_LEGS_S


def standing_legs(actions: FloatArray, leg_columns: IntArray, fps: float) -> BoolArray:
    """(T,) the frames of `action_channels` (T, A) where the legs stand: the pelvis travels, every foot rises
    or falls slower than `STILL_LEGS_S` and the body turns slower than `STILL_TURNING`; leg_columns: the
    legs' columns (`part_channels`: travel, turning, then the feet's heights)."""
    travel, turning, feet = (
        actions[:, leg_columns[:2]],
        actions[:, leg_columns[2]],
        actions[:, leg_columns[3:]],
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
