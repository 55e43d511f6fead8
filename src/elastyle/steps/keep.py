"""Body parts that keep the content's action: the parts a user keeps, and the parts whose matched style
windows perform another action (docs/method.md, "Per body part").

Per output frame and joint, a share k in [0, 1] of the content's own motion: 1 at the joints of the parts
`--keep-part` names (the output is then exactly the content there), and each part's `StyleTrack.keep`
elsewhere (the legs and the spine, where the legs' travel and steps differ from the matched windows').
Where the spine keeps the content's action it still takes the style's posture: the mean, over the frames
it keeps, of the change the style makes to the model's reading of it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts
from elastyle.core.rotations import canonical_log, multiply, quat_multiply, to_quat
from elastyle.core.skeleton import Skeleton
from elastyle.steps.timeline import on_output_frames
from elastyle.steps.track import StyleTrack
from elastyle.types import FloatArray, IntArray

POSTURE_PARTS = ("spine",)  # parts that keep the content's action with the style's mean posture


def keep_weights(
    tracks: Sequence[StyleTrack],
    shares: Sequence[FloatArray],
    skeleton: Skeleton,
    grid: FloatArray,
    content_time: FloatArray,
    positions: FloatArray,
    kept: IntArray,
) -> FloatArray:
    """(N, J) per output frame and joint, 0 to 1: how far the content's own action is kept. 1 at the kept
    joints (K,); elsewhere each part's share from the tracks' `keep` (G,) weighted by their shares (G,),
    read at the output frames (positions (N,) on the model-rate output timeline whose content times, in
    content frames, are content_time (T_out,))."""
    keep = np.zeros((len(positions), skeleton.num_joints))
    for name, joints in body_parts(skeleton).items():
        on_grid = np.zeros_like(grid)
        for track, share in zip(tracks, shares):
            if name in track.keep:
                on_grid += share * track.keep[name]
        if np.any(on_grid > 0):
            model_rate = on_output_frames(on_grid, grid, content_time)  # (T_out,)
            keep[:, joints] = np.interp(positions, np.arange(len(model_rate)), model_rate)[:, None]
    keep[:, kept] = 1.0
    return keep


def keep_target(
    content: Motion, styled: Motion, reference: Motion, keep: FloatArray, kept: IntArray
) -> Motion:
    """What the kept joints become (N frames): the content (read at the output frames), with the style's
    mean posture on the `POSTURE_PARTS` joints that keep the content's action automatically.

    styled, reference: the decoded styled clip and the model's reading of the content (or the content
    itself) at the same N frames; keep (N, J) from `keep_weights`; kept (K,): joints the user keeps as
    they are.
    """
    parts = body_parts(content.skeleton)
    named = [int(j) for name in POSTURE_PARTS for j in parts.get(name, [])]
    posture = np.setdiff1d(np.array(named, dtype=np.int64), kept)
    if not len(posture):
        return content
    weight = keep[:, posture, None]  # (N, P, 1)
    change = canonical_log(
        quat_multiply(to_quat(-reference.rotations[:, posture]), to_quat(styled.rotations[:, posture]))
    )  # (N, P, 3) the style's change to each posture joint
    mean_change = np.sum(weight * change, axis=0) / np.maximum(np.sum(weight, axis=0), 1e-9)  # (P, 3)
    rotations = content.rotations.copy()
    rotations[:, posture] = multiply(rotations[:, posture], mean_change[None])
    return Motion(content.skeleton, rotations, content.translations, content.fps)
