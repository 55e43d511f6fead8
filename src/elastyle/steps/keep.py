"""Body parts that keep the content's action: the parts a user keeps, and the parts whose matched style
windows perform another action (docs/method.md, "Per body part").

Per output frame and joint, a share k in [0, 1] of the content's own motion: 1 at the joints of the parts
`--keep-part` names (the output is then exactly the content there), and each part's `StyleTrack.keep`
elsewhere (the legs and the spine, where the legs' travel and steps differ from the matched windows'; the
spine also where the head leans otherwise than theirs; each arm).
Where the spine keeps the content's action it still takes the style's posture: the mean, over the frames
it keeps within about ten seconds (`POSTURE_WINDOW_S`), of the change the style makes to the model's reading of
it, scaled by the strength (so strength 0 stays the content); the arms that keep the content's action
hang under it as they did (their hands where the content's are relative to the pelvis). Where the legs
keep it because the windows perform another action (another gait or none, not another path), they also
take a share (`TransferConfig.kept_statistics`) of the change the style's statistics alone make to the model's reading
(the report's colouring of the content's latents): a walk given a run's style walks with the run's manner
as far as statistics carry it. Parts that `--style-part` gives another library keep the content's action as
that library's track decides.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.body import find_limbs
from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts, joint_set
from elastyle.core.rotations import canonical_log, from_matrix, multiply, quat_multiply, to_matrix, to_quat
from elastyle.core.skeleton import Skeleton, forward_kinematics
from elastyle.core.smoothing import smooth
from elastyle.steps.timeline import on_output_frames
from elastyle.steps.track import StyleTrack
from elastyle.types import FloatArray, IntArray

POSTURE_WINDOW_S = 10.0  # the style's posture is a local mean: Gaussian sigma, seconds
POSTURE_SUPPORT = 0.1  # ... of the change over frames whose weights average at least this (less: scaled down)
HANG_FROM_SHARE = 0.01  # kept arms hang under the trunk's posture where the output takes this much of each


def keep_weights(
    tracks: Sequence[StyleTrack],
    shares: Sequence[FloatArray],
    part_tracks: Sequence[tuple[IntArray, StyleTrack]],
    skeleton: Skeleton,
    grid: FloatArray,
    content_time: FloatArray,
    positions: FloatArray,
    kept: IntArray,
    field: str = "keep",
) -> FloatArray:
    """(N, J) per output frame and joint, 0 to 1: how far the content's own action is kept. 1 at the kept
    joints (K,); elsewhere each part's share from the tracks' `keep` (G,) weighted by their shares (G,), or
    at the joints a part track styles, that track's own; read at the output frames (positions (N,) on the
    model-rate output timeline whose content times, in content frames, are content_time (T_out,)).
    field "posture": the tracks' posture weights instead (`keep_target`), 0 at the kept joints."""
    sources = [(np.arange(skeleton.num_joints), list(tracks), list(shares))]
    sources += [(joints, [track], [np.ones_like(grid)]) for joints, track in part_tracks]
    weights = _per_joint(sources, field, skeleton, grid, content_time, positions)
    weights[:, kept] = 1.0 if field == "keep" else 0.0
    return weights


def statistics_weights(
    tracks: Sequence[StyleTrack],
    shares: Sequence[FloatArray],
    skeleton: Skeleton,
    grid: FloatArray,
    content_time: FloatArray,
    positions: FloatArray,
    unstyled: IntArray,
) -> FloatArray:
    """(N, J) per output frame and joint, 0 to 1: where a part keeps the content's action because the
    matched windows perform another (the tracks' `other_action`, weighted by their shares), read at the
    output frames as `keep_weights` reads; 0 at the joints unstyled (U,): those the user keeps or another
    library styles."""
    sources = [(np.arange(skeleton.num_joints), list(tracks), list(shares))]
    weights = _per_joint(sources, "other_action", skeleton, grid, content_time, positions)
    weights[:, unstyled] = 0.0
    return weights


def fallback_weights(
    tracks: Sequence[StyleTrack],
    shares: Sequence[FloatArray],
    grid: FloatArray,
    content_time: FloatArray,
    positions: FloatArray,
) -> FloatArray:
    """(N,) per output frame, 0 to 1: the share of the style's statistics alone (the tracks' `fallback`,
    weighted by their shares; 1 throughout for the statistics methods), read at the output frames as
    `keep_weights` reads. There the content's latents are coloured in place, so its legs step as it does."""
    on_grid = np.sum([share * track.fallback for track, share in zip(tracks, shares)], axis=0)  # (G,)
    return _at_output(on_grid, grid, content_time, positions)


def _at_output(
    on_grid: FloatArray, grid: FloatArray, content_time: FloatArray, positions: FloatArray
) -> FloatArray:
    """(N,) values on the content-time grid (G,) read at the output frames (positions (N,) on the model-rate
    output timeline whose content times are content_time (T_out,))."""
    model_rate = on_output_frames(on_grid, grid, content_time)  # (T_out,)
    return np.interp(positions, np.arange(len(model_rate)), model_rate)


def _per_joint(
    sources: Sequence[tuple[IntArray, list[StyleTrack], list[FloatArray]]],
    field: str,
    skeleton: Skeleton,
    grid: FloatArray,
    content_time: FloatArray,
    positions: FloatArray,
) -> FloatArray:
    """(N, J): a per-part field of the tracks (`keep`, `other_action` or `posture`, (G,) each) on every joint of its
    part, for each source's joints (J_s,) from its tracks weighted by their shares (G,), read at the
    output frames (positions (N,))."""
    weights = np.zeros((len(positions), skeleton.num_joints))
    for styled_joints, source_tracks, source_shares in sources:
        for name, joints in body_parts(skeleton).items():
            on_grid = np.zeros_like(grid)
            for track, share in zip(source_tracks, source_shares):
                values = getattr(track, field)
                if name in values:
                    on_grid += share * values[name]
            joints = joint_set(set(joints.tolist()) & set(styled_joints.tolist()))
            weights[:, joints] = _at_output(on_grid, grid, content_time, positions)[:, None]
    return weights


def keep_target(
    content: Motion,
    styled: Motion,
    reference: Motion,
    posture: FloatArray,
    strength: FloatArray,
    coloured: Motion | None = None,
    colour: FloatArray | None = None,
    kept: FloatArray | None = None,
) -> Motion:
    """What the kept joints become (N frames): the content (read at the output frames), with the style's
    local mean posture, times the strength (N,), on the joints whose parts weigh one (the spine where it
    keeps the content's action for the legs' sake), and the style's statistics where `colour` asks.

    styled, reference: the decoded styled clip and the model's reading of the content (or the content
    itself) at the same N frames; posture (N, J): each frame's weight in each joint's mean posture
    (`keep_weights` of the tracks' posture field; 0 at the joints the user keeps as they are); coloured:
    the decoded clip of the content's latents coloured with the style's statistics (the report's whitening
    and colouring), at the same frames; colour (N, J), 0 to 1: the share of its
    change to the model's reading (`statistics_weights` times `TransferConfig.kept_statistics`); kept
    (N, J), 0 to 1: how far the output then takes this target at each joint (`keep_weights`; None: fully),
    so the kept arms hang as they did under as much of the trunk's posture as the output takes.
    """
    acting = strength > 0  # strength 0 stays the content exactly
    scale = np.clip(strength[acting], 0.0, 1.0)[:, None, None]  # (A, 1, 1)
    rotations = content.rotations.copy()
    if coloured is not None and colour is not None:
        joints = np.flatnonzero(np.any(colour > 0, axis=0))
        change = _change(reference, coloured, joints)  # (N, C, 3)
        weighted = scale * colour[np.ix_(acting, joints)][:, :, None] * change[acting]
        rotations[np.ix_(acting, joints)] = multiply(rotations[np.ix_(acting, joints)], weighted)
    joints = np.flatnonzero(np.any(posture > 0, axis=0))  # (P,)
    if len(joints):
        weight = posture[:, joints, None]  # (N, P, 1)
        change = _change(reference, styled, joints)  # (N, P, 3) the style's change to each posture joint
        sigma = POSTURE_WINDOW_S * content.fps
        # a local mean backed by at least POSTURE_SUPPORT of weight: a few frames weighed near 0 (a bow's edges)
        # gave the whole change of a mean of their own, undoing the bow they lie beside
        mean_change = smooth(weight * change, sigma) / np.maximum(smooth(weight, sigma), POSTURE_SUPPORT)
        change = np.zeros_like(rotations[:, joints])  # (N, P, 3)
        change[acting] = scale * mean_change[acting]
        bent = rotations.copy()
        bent[np.ix_(acting, joints)] = multiply(bent[np.ix_(acting, joints)], change[acting])
        # the arms keep hanging as they did (their parts take no posture of their own): a trunk bent forward
        # with the arms' local rotations kept swung a walk's hands 9 cm behind the body. Only at the frames
        # where the output takes both a kept arm and the trunk's posture, each at least `HANG_FROM_SHARE`
        roots = find_limbs(content.skeleton).arm_roots
        share = np.ones((len(rotations), len(joints))) if kept is None else kept[:, joints]  # (N, P)
        hung = acting & (share.max(axis=1) >= HANG_FROM_SHARE)
        if kept is not None and len(roots):
            hung &= kept[:, roots].max(axis=1) >= HANG_FROM_SHARE
        if len(roots) and np.any(hung):
            taken = rotations[hung]  # (F, J, 3) the trunk as far as the output takes its posture
            taken[:, joints] = multiply(taken[:, joints], share[hung][:, :, None] * change[hung])
            moved = content.translations[hung]
            hanging = _arms_hanging(content.skeleton, moved, rotations[hung], taken)  # (F, H, 3)
            bent[np.ix_(hung, roots)] = multiply(bent[np.ix_(hung, roots)], hanging)
        rotations = bent
    return Motion(content.skeleton, rotations, content.translations, content.fps)


def _arms_hanging(
    skeleton: Skeleton, translations: FloatArray, before: FloatArray, bent: FloatArray
) -> FloatArray:
    """(F, H, 3) exp maps: each arm root's local turn that swings its arm about it so that its hand keeps
    its place relative to the pelvis in `before` (F, J, 3) local rotations (translations (F, J, 3)), where
    `bent` (F, J, 3) has the trunk's posture changed, as far as the arm reaches: an arm that keeps the
    content's action keeps it where `steps.arms` measures it (its hand relative to the pelvis)."""
    limbs = find_limbs(skeleton)
    roots, hands, pelvis = limbs.arm_roots, limbs.hands, skeleton.pelvis
    was = forward_kinematics(skeleton, before, translations, np.append(hands, pelvis))[1]
    turns, now = forward_kinematics(skeleton, bent, translations, hands)
    # the content's hand place (relative to the pelvis, which the spine's posture leaves), from the bent root
    wanted = was[:, hands] - was[:, [pelvis]] + now[:, [pelvis]] - now[:, roots]  # (N, H, 3)
    reach = now[:, hands] - now[:, roots]  # (N, H, 3)
    axis = np.cross(reach, wanted)
    size = np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = np.arctan2(size, np.sum(reach * wanted, axis=-1, keepdims=True))
    swing = to_matrix(axis / np.maximum(size, 1e-12) * angle)  # (N, H, 3, 3) in the world
    own = turns[:, roots]  # (N, H, 3, 3) the roots' world rotations
    return from_matrix(np.swapaxes(own, -1, -2) @ swing @ own)


def _change(reference: Motion, changed: Motion, joints: IntArray) -> FloatArray:
    """(N, C, 3) exp maps: each joint's (C,) local rotation from `reference` to `changed`."""
    return canonical_log(
        quat_multiply(to_quat(-reference.rotations[:, joints]), to_quat(changed.rotations[:, joints]))
    )
