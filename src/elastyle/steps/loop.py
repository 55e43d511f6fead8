"""Cycles (`TransferConfig.loop`): a content clip whose last frame runs into its first, as a game's walk or
run cycle loops, transferred so that its output loops too.

A transfer reads a clip from its first frame to its last, so the style's windows matched at the two ends
need not meet: a walk cycle came out with a 36 cm pop where it wraps. Three cycles end to end are
transferred instead (`tiled`), and the output is the middle cycle's frames (`middle_cycle`): the frames
before and after it carry on the same motion, so its first frames are cross-faded from those that follow
its last, and the cycle closes. Axes +Y up; translations in the clip's unit.
"""

from __future__ import annotations

import numpy as np

from elastyle.core.body import heading_yaw, pelvis_forward_local
from elastyle.core.motion import Motion
from elastyle.steps.decode import blend_by_strength
from elastyle.types import FloatArray

COPIES = 3  # cycles transferred end to end; the output is the middle one's
SEAM_S = 0.2  # the seam is cross-faded over this long (seconds), at most a third of the cycle
# a cycle whose heading turns more than this over it is said to loop with its ends turning sharply: its copies
# are tiled without the turn, so the heading snaps back between them
TURNING_CYCLE_DEGREES = 10.0


def cycle_turn_degrees(motion: Motion) -> float:
    """How far (degrees) the pelvis's heading turns over one cycle, carried on by one more frame's share."""
    skeleton = motion.skeleton
    world_rotations, _ = motion.world([skeleton.pelvis])
    yaw = np.unwrap(heading_yaw(world_rotations[:, skeleton.pelvis], pelvis_forward_local(skeleton)))
    frames = motion.num_frames
    return float(np.degrees(yaw[-1] - yaw[0]) * frames / max(frames - 1, 1))


def cycle_travel(motion: Motion) -> FloatArray:
    """(J, 3) how far each joint's translation travels over one cycle on the ground (heights 0): its last
    frame's less its first, carried on by one more frame's share (the cycle's next frame is its first)."""
    frames = motion.num_frames
    travel = (motion.translations[-1] - motion.translations[0]) * (frames / max(frames - 1, 1))
    travel[:, 1] = 0.0
    return travel


def tiled(motion: Motion, copies: int = COPIES) -> Motion:
    """The cycle `copies` times end to end (T * copies frames), each copy moved on by `cycle_travel`."""
    shifts = np.arange(copies)[:, None, None, None] * cycle_travel(motion)  # (copies, 1, J, 3)
    translations = (motion.translations[None] + shifts).reshape(-1, *motion.translations.shape[1:])
    rotations = np.tile(motion.rotations, (copies, 1, 1))
    return Motion(motion.skeleton, rotations, translations, motion.fps)


def middle_cycle(output: Motion, content_frames: FloatArray, cycle: Motion) -> tuple[Motion, int, int, int]:
    """The output's frames of the middle cycle, its seam cross-faded: the output (T_out frames) of a transfer
    of `tiled(cycle)`, with `content_frames` (T_out,) the tiled clip's frame each output frame shows.
    Returns the loop, its first and end frames in the output, and the frames cross-faded.

    The loop's first frames blend from those following its last (moved back by what the output travels
    over the cycle) to its own, so the frame after its last is its first; the loop is moved back by the
    content's `cycle_travel`, so it starts where the cycle does."""
    length = cycle.num_frames
    start = int(np.searchsorted(content_frames, length - 0.5))
    end = int(np.searchsorted(content_frames, 2 * length - 0.5))
    seam = int(min(round(SEAM_S * output.fps), (end - start) // 3, output.num_frames - end))
    frames = np.arange(start, end)
    loop = Motion(output.skeleton, output.rotations[frames], output.translations[frames].copy(), output.fps)
    if seam > 0:
        travelled = output.translations[end] - output.translations[start]  # (J, 3) the output's cycle
        travelled[:, 1] = 0.0
        after = np.arange(end, end + seam)
        following = Motion(
            output.skeleton, output.rotations[after], output.translations[after] - travelled, output.fps
        )
        ease = np.arange(1, seam + 1) / (seam + 1)  # (seam,) towards the loop's own frames
        blended = blend_by_strength(following, loop.slice(0, seam), ease * ease * (3 - 2 * ease))
        loop.rotations[:seam] = blended.rotations
        loop.translations[:seam] = blended.translations
    loop.translations[:] -= cycle_travel(cycle)
    return loop, start, end, seam
