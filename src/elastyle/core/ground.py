"""The floor a clip stands on: its toes' ground level, and a clip moved up or down onto another floor.

Axes +Y up; heights in the clip's file units. A clip's ground level is a low percentile of its toe joints'
heights (the toe joint stands above the floor by the foot's thickness there, the same for every clip of a
skeleton), so two clips of one skeleton stand on the same floor when their ground levels agree.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from elastyle.core.body import find_limbs, leg_length
from elastyle.core.foot_tips import with_foot_tips
from elastyle.core.motion import Motion
from elastyle.types import FloatArray

GROUND_PERCENTILE = 5.0  # a foot joint's ground level: this percentile of its heights over the clip
# the nearest sample to that percentile: numpy's interpolating method imports numpy.ma (8 to 9 ms, a
# twentieth of a command-line transfer) on its first call in a process
PERCENTILE_METHOD: Final = "nearest"
# floors this close (a share of the leg: 1.6 cm on an 80 cm leg) are taken for the same floor: the toes'
# ground level also differs with how a foot stands, by up to 1.2 cm between the styles of one skeleton's
# takes (a foot on its ball in heeled shoes)
SAME_FLOOR_OF_LEG = 0.02


def ground_level(motion: Motion, positions: FloatArray | None = None) -> float:
    """Height (file units) of the toes' ground level: the 5th percentile of toe heights over all feet, a
    foot without a toe joint read at its End Site (`core.foot_tips`). positions: (T, J, 3) the clip's
    world positions, when known (used where no End Site is added)."""
    extended = with_foot_tips(motion)
    toes = find_limbs(extended.skeleton).toes
    if positions is None or extended is not motion:
        positions = extended.positions(toes)
    return float(np.percentile(positions[:, toes, 1], GROUND_PERCENTILE, method=PERCENTILE_METHOD))


def has_feet(motion: Motion) -> bool:
    """Whether the clip has legs whose feet give a ground level (a toe joint, or the ankle and its End Site)."""
    return len(find_limbs(motion.skeleton).toes) > 0


def floor_gap(motion: Motion, ground: float, positions: FloatArray | None = None) -> float:
    """How far (file units) the clip must be raised to stand on a floor whose toes' ground level is `ground`:
    the difference of the ground levels, or 0 within `SAME_FLOOR_OF_LEG` of the leg either way (a foot's
    own way of standing kept). positions: `ground_level`."""
    difference = ground - ground_level(motion, positions)
    tolerance = SAME_FLOOR_OF_LEG * leg_length(motion.skeleton, find_limbs(motion.skeleton))
    return float(difference) if abs(difference) > tolerance else 0.0


def raised(motion: Motion, height: float) -> Motion:
    """The clip moved up by `height` (file units; down where negative): its root joints' translations."""
    if height == 0.0:
        return motion
    translations = motion.translations.copy()
    translations[:, motion.skeleton.parents < 0, 1] += height
    return Motion(motion.skeleton, motion.rotations, translations, motion.fps)
