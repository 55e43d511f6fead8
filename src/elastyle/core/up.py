"""Which way is up in a clip's file: +Y (BVH's convention, and elastyle's throughout) or +Z (some exporters).

A clip whose body stands along +Z is turned to stand along +Y when it is read (its root joint's rotation and
position turned by a quarter turn about X; every other joint, the rest pose and the bones stay as they are)
and turned back when it is written, so every step works with +Y up and an output lies in its content's
file as the content does.

    standing_axis   the axis a clip's body stands along: "z" where it clearly stands along +Z, else "y"
    detected_axis   "y" or "z" where the body clearly stands along it, None where no extent decides
    turned_up       a clip of the given up axis turned to +Y up
    turned_back     a +Y-up clip turned back to the given up axis
"""

from __future__ import annotations

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.parts import subtree, trunk
from elastyle.core.rotations import from_matrix, to_matrix
from elastyle.core.stats import median
from elastyle.types import FloatArray

UP_AXES = ("y", "z")
# turns +Z up into +Y up: (x, y, z) -> (x, z, -y), a quarter turn about X
_TO_Y_UP = {"y": np.eye(3), "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])}
# a body stands along an axis where its extent along it is at least this many times that along the others
STANDING_RATIO = 1.25
# ... its trunk (`core.parts.trunk`: spine, neck, head) lies above the pelvis along it by at
# least this share of that extent, and its pelvis travels along it by at most this share (a body lying
# along an axis, crawling, travels along it; one standing along it travels across it)
UPPER_BODY_SHARE = 0.1
TRAVEL_SHARE = 0.25
DETECTION_FRAMES = 60  # the frames read to decide (evenly spread over the clip)


def standing_axis(motion: Motion) -> str:
    """ "z" where the clip's body clearly stands along +Z and not along +Y; otherwise "y" (BVH's convention,
    also for a body that lies or crawls, which no extent decides)."""
    return detected_axis(motion) or "y"


def detected_axis(motion: Motion) -> str | None:
    """ "y" or "z" where the clip's body clearly stands along that axis and not along the other; None
    where neither or both (a body that lies, crawls or curls up)."""
    skeleton = motion.skeleton
    pelvis = skeleton.pelvis
    body, upper = subtree(skeleton, pelvis), trunk(skeleton)  # the body below its root; spine and head
    if not upper or len(body) < 3:
        return None
    step = max(1, motion.num_frames // DETECTION_FRAMES)
    sampled = Motion(skeleton, motion.rotations[::step], motion.translations[::step], motion.fps)
    positions = sampled.positions(body)  # (T', J, 3)
    extent = median(np.ptp(positions[:, body], axis=1), axis=0)  # (3,) the body's size along x, y, z
    relative = positions[:, upper] - positions[:, pelvis : pelvis + 1]
    above = np.mean(relative, axis=(0, 1))  # (3,) where the trunk lies from the pelvis
    travel = np.ptp(positions[:, pelvis], axis=0)  # (3,)

    def stands_along(axis: int) -> bool:
        others = [a for a in range(3) if a != axis]
        return bool(
            extent[axis] >= STANDING_RATIO * max(extent[others])
            and above[axis] >= UPPER_BODY_SHARE * extent[axis]
            and travel[axis] <= TRAVEL_SHARE * max(extent[axis], np.max(travel[others]))
        )

    along_y, along_z = stands_along(1), stands_along(2)
    return None if along_y == along_z else ("y" if along_y else "z")


def turned_up(motion: Motion, up: str) -> Motion:
    """The clip of up axis `up` (`UP_AXES`) turned to stand along +Y (the same clip for "y")."""
    return _turned(motion, _TO_Y_UP[up])


def turned_back(motion: Motion, up: str) -> Motion:
    """A +Y-up clip turned back to stand along its file's up axis `up` (`turned_up` undone)."""
    return _turned(motion, _TO_Y_UP[up].T)


def _turned(motion: Motion, turn: FloatArray) -> Motion:
    """The clip with its root joint's rotation and position turned by `turn` (3, 3) in the world."""
    if np.array_equal(turn, np.eye(3)):
        return motion
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    rotations[:, 0] = from_matrix(turn @ to_matrix(motion.rotations[:, 0]))
    translations[:, 0] = motion.translations[:, 0] @ turn.T
    return Motion(motion.skeleton, rotations, translations, motion.fps)
