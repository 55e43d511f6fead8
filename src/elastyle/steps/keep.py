"""Body parts that keep the content's action: the parts a user keeps, and the parts whose matched style
windows perform another action (docs/method.md, "Per body part").

Per output frame and joint, a share k in [0, 1] of the content's own motion: 1 at the joints of the parts
`--keep-part` names (the output is then exactly the content there), and each part's `StyleTrack.keep`
elsewhere (the legs and the spine, where the legs' travel and steps differ from the matched windows').
Where the spine keeps the content's action it still takes the style's posture: the mean, over the frames
it keeps within about ten seconds (`POSTURE_WINDOW_S`), of the change the style makes to the model's reading of
it, scaled by the strength (so strength 0 stays the content). Parts that `--style-part` gives another
library keep the content's action as that library's track decides.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts
from elastyle.core.rotations import canonical_log, multiply, quat_multiply, to_quat
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import smooth
from elastyle.steps.timeline import on_output_frames
from elastyle.steps.track import StyleTrack
from elastyle.types import FloatArray, IntArray

POSTURE_PARTS = ("spine",)  # parts that keep the content's action with the style's mean posture
POSTURE_WINDOW_S = 10.0  # the style's posture is a local mean: Gaussian sigma, seconds


def keep_weights(
    tracks: Sequence[StyleTrack],
    shares: Sequence[FloatArray],
    part_tracks: Sequence[tuple[IntArray, StyleTrack]],
    skeleton: Skeleton,
    grid: FloatArray,
    content_time: FloatArray,
    positions: FloatArray,
    kept: IntArray,
) -> FloatArray:
    """(N, J) per output frame and joint, 0 to 1: how far the content's own action is kept. 1 at the kept
    joints (K,); elsewhere each part's share from the tracks' `keep` (G,) weighted by their shares (G,), or
    at the joints a part track styles, that track's own; read at the output frames (positions (N,) on the
    model-rate output timeline whose content times, in content frames, are content_time (T_out,))."""
    keep = np.zeros((len(positions), skeleton.num_joints))
    sources = [(np.arange(skeleton.num_joints), list(tracks), list(shares))]
    sources += [(joints, [track], [np.ones_like(grid)]) for joints, track in part_tracks]
    for styled_joints, source_tracks, source_shares in sources:
        for name, joints in body_parts(skeleton).items():
            on_grid = np.zeros_like(grid)
            for track, share in zip(source_tracks, source_shares):
                if name in track.keep:
                    on_grid += share * track.keep[name]
            model_rate = on_output_frames(on_grid, grid, content_time)  # (T_out,)
            joints = np.intersect1d(joints, styled_joints)
            keep[:, joints] = np.interp(positions, np.arange(len(model_rate)), model_rate)[:, None]
    keep[:, kept] = 1.0
    return keep


def keep_target(
    content: Motion, styled: Motion, reference: Motion, keep: FloatArray, kept: IntArray, strength: FloatArray
) -> Motion:
    """What the kept joints become (N frames): the content (read at the output frames), with the style's
    local mean posture, times the strength (N,), on the `POSTURE_PARTS` joints that keep the content's
    action automatically.

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
    sigma = POSTURE_WINDOW_S * content.fps
    mean_change = smooth(weight * change, sigma) / np.maximum(smooth(weight, sigma), 1e-9)  # (N, P, 3)
    rotations = content.rotations.copy()
    acting = strength > 0  # strength 0 stays the content exactly
    scaled = np.clip(strength[acting], 0.0, 1.0)[:, None, None] * mean_change[acting]
    rotations[np.ix_(acting, posture)] = multiply(rotations[np.ix_(acting, posture)], scaled)
    return Motion(content.skeleton, rotations, content.translations, content.fps)
