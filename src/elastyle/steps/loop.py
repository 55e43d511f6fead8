"""Cycles (`TransferConfig.loop`): a content clip whose last frame runs into its first, as a game's walk or
run cycle loops, transferred so that its output loops too.

A transfer reads a clip from its first frame to its last, so the style's windows matched at the two ends
need not meet: a walk cycle came out with a 36 cm pop where it wraps. Three cycles end to end are
transferred instead (`tiled`), each copy moved on the ground as the cycle moves the body, turn included
(`cycle_move`), and the output is the middle cycle's frames (`middle_cycle`): the frames before and after it
carry on the same motion, so its first frames are cross-faded from those that follow its last, and the
cycle closes. Axes +Y up; translations in the clip's unit.
"""

from __future__ import annotations

import numpy as np

from elastyle.core.body import heading_yaw, pelvis_forward_local, yaw_matrices
from elastyle.core.motion import Motion
from elastyle.core.rotations import from_matrix, to_matrix
from elastyle.steps.decode import blend_by_strength
from elastyle.types import FloatArray

COPIES = 3  # cycles transferred end to end; the output is the middle one's
SEAM_S = 0.2  # the seam is cross-faded over this long (seconds), at most a third of the cycle


def _ground_frames(motion: Motion, frames: list[int]) -> tuple[FloatArray, FloatArray]:
    """The pelvis's heading yaw (n,) radians, unwrapped along the clip, and its place on the ground (n, 3)
    (height 0) at `frames` (n,)."""
    skeleton = motion.skeleton
    world_rotations, world_positions = motion.world([skeleton.pelvis])
    yaw = heading_yaw(world_rotations[:, skeleton.pelvis], pelvis_forward_local(skeleton))
    places = world_positions[frames, skeleton.pelvis] * np.array([1.0, 0.0, 1.0])
    return yaw[frames], places


def _ground_move(yaw: FloatArray, places: FloatArray) -> FloatArray:
    """The rigid move on the ground (4, 4: a turn about +Y, then a shift) that takes a heading yaw[0] and a
    place places[0] (3,) onto yaw[1] and places[1]."""
    move = np.eye(4)
    move[:3, :3] = yaw_matrices(np.array(yaw[1] - yaw[0]))
    move[:3, 3] = places[1] - move[:3, :3] @ places[0]
    return move


def _undone(move: FloatArray) -> FloatArray:
    """The rigid move (4, 4) that undoes `move` (4, 4)."""
    inverse = np.eye(4)
    inverse[:3, :3] = move[:3, :3].T
    inverse[:3, 3] = -move[:3, :3].T @ move[:3, 3]
    return inverse


def cycle_move(motion: Motion) -> FloatArray:
    """The rigid move on the ground (4, 4) from the pelvis's heading and place at the cycle's first frame to
    those at the frame after its last (its next frame is its first), the last frame's carried on by one more
    frame's share: how one cycle moves and turns the body."""
    frames = motion.num_frames
    yaw, places = _ground_frames(motion, [0, frames - 1])
    carry = frames / max(frames - 1, 1)
    return _ground_move(yaw[0] + (yaw - yaw[0]) * carry, places[0] + (places - places[0]) * carry)


def _carrier(motion: Motion) -> int:
    """The joint whose local transform carries the body's place: the topmost of the pelvis and the joints above
    it that moves (a root-motion joint, else the pelvis); those above it stay put."""
    skeleton = motion.skeleton
    for joint in skeleton.with_ancestors([skeleton.pelvis]).tolist():  # parents first
        if (
            np.ptp(motion.rotations[:, joint], axis=0).any()
            or np.ptp(motion.translations[:, joint], axis=0).any()
        ):
            return int(joint)
    return int(skeleton.pelvis)


def moved(motion: Motion, move: FloatArray, carrier: int) -> Motion:
    """The clip with the body under joint `carrier` (`_carrier`) moved in the world by `move` (4, 4), the joints
    above it staying put (their first frame's transform taken for all)."""
    if np.array_equal(move, np.eye(4)):
        return motion
    parent = int(motion.skeleton.parents[carrier])
    above = np.eye(4)  # the carrier's parent in the world
    if parent >= 0:
        world_rotations, world_positions = motion.world([parent])
        above[:3, :3], above[:3, 3] = world_rotations[0, parent], world_positions[0, parent]
    local = _undone(above) @ move @ above  # the move in the parent's frame
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    rotations[:, carrier] = from_matrix(local[:3, :3] @ to_matrix(motion.rotations[:, carrier]))
    translations[:, carrier] = motion.translations[:, carrier] @ local[:3, :3].T + local[:3, 3]
    return Motion(motion.skeleton, rotations, translations, motion.fps)


def tiled(motion: Motion, copies: int = COPIES) -> Motion:
    """The cycle `copies` times end to end (T * copies frames), copy k moved on by `cycle_move` k times: a
    turning cycle goes on turning."""
    move, carrier = cycle_move(motion), _carrier(motion)
    parts = [moved(motion, np.linalg.matrix_power(move, copy), carrier) for copy in range(copies)]
    return Motion(
        motion.skeleton,
        np.concatenate([part.rotations for part in parts]),
        np.concatenate([part.translations for part in parts]),
        motion.fps,
    )


def middle_cycle(output: Motion, content_frames: FloatArray, cycle: Motion) -> tuple[Motion, int, int, int]:
    """The output's frames of the middle cycle, its seam cross-faded: the output (T_out frames) of a transfer
    of `tiled(cycle)`, with `content_frames` (T_out,) the tiled clip's frame each output frame shows.
    Returns the loop, its first and end frames in the output, and the frames cross-faded.

    The loop's first frames blend from those following its last (moved back by how the output moves and
    turns over the cycle) to its own, so the frame after its last is its first; the loop is moved back by
    the content's `cycle_move`, so it starts where the cycle does."""
    length = cycle.num_frames
    start = int(np.searchsorted(content_frames, length - 0.5))
    end = int(np.searchsorted(content_frames, 2 * length - 0.5))
    seam = int(min(round(SEAM_S * output.fps), (end - start) // 3, output.num_frames - end))
    carrier = _carrier(cycle)
    loop = output.slice(start, end)
    if seam > 0:
        back = _undone(_ground_move(*_ground_frames(output, [start, end])))  # the output's cycle undone
        following = moved(output.slice(end, end + seam), back, carrier)
        ease = np.arange(1, seam + 1) / (seam + 1)  # (seam,) towards the loop's own frames
        blended = blend_by_strength(following, loop.slice(0, seam), ease * ease * (3 - 2 * ease))
        rotations, translations = loop.rotations.copy(), loop.translations.copy()
        rotations[:seam], translations[:seam] = blended.rotations, blended.translations
        loop = Motion(loop.skeleton, rotations, translations, loop.fps)
    return moved(loop, _undone(cycle_move(cycle)), carrier), start, end, seam
