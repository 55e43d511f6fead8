"""A clip whose joints' axes are all turned alike from a model's: some exporters write a rig in their own
axes (Z up), turning every bone offset and every joint's local frame. The same motion is read in the model's
axes (every frame turned back, so each local rotation means what the model's does) and written back in the
clip's.

    AXIS_TURNS     the 23 quarter and half turns that map the axes onto themselves (the identity left out)
    frames_turned  the same motion with every joint's axes turned
"""

from __future__ import annotations

import itertools

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.rotations import from_matrix, to_matrix
from elastyle.core.skeleton import Skeleton
from elastyle.types import FloatArray


def _axis_turns() -> tuple[FloatArray, ...]:
    """Every rotation (3, 3) that takes each axis to an axis, either way, but the identity (23 of them); the
    quarter turns about X first (+Z up to +Y up and back, the commonest)."""
    turns = [np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])]
    turns.append(turns[0].T)
    for order in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            turn = np.zeros((3, 3))
            turn[range(3), order] = signs
            if np.linalg.det(turn) > 0 and not any(
                np.array_equal(turn, known) for known in [np.eye(3), *turns]
            ):
                turns.append(turn)
    return tuple(turns)


AXIS_TURNS = _axis_turns()


def frames_turned(motion: Motion, turn: FloatArray) -> Motion:
    """The same world motion (T frames, J joints) with every joint's axes turned by `turn` (3, 3): bone
    offsets, End Sites and joints' local translations turned, each joint's local rotation R becoming
    turn R turn^T, the root's R turn^T (its position stays in the world's axes)."""
    skeleton = motion.skeleton
    turned = Skeleton(
        skeleton.names,
        skeleton.parents,
        skeleton.offsets @ turn.T,
        skeleton.end_sites @ turn.T,
        skeleton.unit_cm,
    )
    matrices = to_matrix(motion.rotations)  # (T, J, 3, 3)
    matrices[:, 1:] = turn @ matrices[:, 1:] @ turn.T
    matrices[:, 0] = matrices[:, 0] @ turn.T
    translations = motion.translations.copy()
    translations[:, 1:] = translations[:, 1:] @ turn.T
    return Motion(turned, from_matrix(matrices), translations, motion.fps)
