"""Body parts that keep the content's action: the parts a user keeps, and the parts whose matched style
windows perform another action (docs/method.md, "Per body part").

Per output frame and joint, a share k in [0, 1] of the content's own motion: 1 at the joints of the parts
`--keep-part` names (the output is then exactly the content there), and each part's `StyleTrack.keep`
elsewhere (the legs and the spine, where the legs' travel and steps differ from the matched windows'; the
spine also where the head leans otherwise than theirs; each arm).
Where the spine keeps the content's action it still takes the style's posture: the mean, over the frames
it keeps within about ten seconds (`POSTURE_WINDOW_S`), of the change the style makes to the model's reading of
it, scaled by the strength (so strength 0 stays the content). Arms that keep the content's action keep
their hands where the content's are relative to the pelvis (`arms_hanging`), whatever trunk and pelvis
the output takes. Where the legs keep it because the windows perform another action (another gait or
none, not another path), they also take a share (`TransferConfig.kept_statistics`) of the change the
style's statistics alone make to the model's reading (the report's colouring of the content's latents):
a walk given a run's style walks with the run's manner as far as statistics carry it. Parts that
`--style-part` gives another library keep the content's action as that library's track decides.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.body import find_limbs, heading_yaw, pelvis_forward_local, yaw_matrices
from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts, joint_set, subtree
from elastyle.core.rotations import (
    canonical_log,
    from_matrix,
    least_turn,
    multiply,
    quat_multiply,
    to_matrix,
    to_quat,
)
from elastyle.core.skeleton import Skeleton
from elastyle.core.smoothing import smooth
from elastyle.steps.decode import blend_by_strength
from elastyle.steps.timeline import on_output_frames
from elastyle.steps.track import StyleTrack
from elastyle.types import FloatArray, IntArray

POSTURE_WINDOW_S = 10.0  # the style's posture is a local mean: Gaussian sigma, seconds
POSTURE_SUPPORT = 0.1  # ... of the change over frames whose weights average at least this (less: scaled down)
HANG_FROM_SHARE = 0.01  # an arm keeping at least this share of the content's action hangs as it did


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
) -> Motion:
    """What the kept joints become (N frames): the content (read at the output frames), with the style's
    local mean posture, times the strength (N,), on the joints whose parts weigh one (the spine where it
    keeps the content's action for the legs' sake), and the style's statistics where `colour` asks.

    styled, reference: the decoded styled clip and the model's reading of the content (or the content
    itself) at the same N frames; posture (N, J): each frame's weight in each joint's mean posture
    (`keep_weights` of the tracks' posture field; 0 at the joints the user keeps as they are); coloured:
    the decoded clip of the content's latents coloured with the style's statistics (the report's whitening
    and colouring), at the same frames; colour (N, J), 0 to 1: the share of its
    change to the model's reading (`statistics_weights` times `TransferConfig.kept_statistics`).
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
        rotations[np.ix_(acting, joints)] = multiply(
            rotations[np.ix_(acting, joints)], scale * mean_change[acting]
        )
    return Motion(content.skeleton, rotations, content.translations, content.fps)


def arms_hanging(target: Motion, styled: Motion, content: Motion, keep: FloatArray, kept: IntArray) -> Motion:
    """`target` (`keep_target`, N frames) with each arm's shoulder turned so that, on the trunk and pelvis the
    output takes (`styled`, the output so far, blended with the target by `keep` (N, J)), the arm as the content
    performs it puts its hand where the content's (`content`, the same N frames) lies relative to the pelvis
    in the body's heading frame, where `steps.arms` reads an arm's action, as far as it reaches; at the
    frames where the arm keeps at least `HANG_FROM_SHARE` of the content's action. With its local rotations
    kept, a kept arm followed whatever trunk and pelvis the output took from the style: an elderly style's
    trunk bent forward swung a walk's hands up to 14 cm behind the body. The arms the user keeps (kept (K,)
    joints) stay the content's exactly."""
    skeleton = target.skeleton
    limbs = find_limbs(skeleton)
    arms = [
        (int(hand), _shoulder(skeleton, int(root), int(hand)))
        for root, hand in zip(limbs.arm_roots, limbs.hands)
        if int(root) not in set(kept.tolist())
    ]
    if not arms:
        return target
    hands, shoulders = (np.array(joints, dtype=np.int64) for joints in zip(*arms))
    frames = np.flatnonzero(np.max(keep[:, shoulders], axis=1) >= HANG_FROM_SHARE)
    if not len(frames):
        return target
    # the output's trunk and pelvis with the arms from the shoulders down as the target has them
    arm_joints = np.array([j for shoulder in shoulders.tolist() for j in subtree(skeleton, shoulder)])
    before, after = (
        Motion(skeleton, m.rotations[frames], m.translations[frames], m.fps) for m in (styled, target)
    )
    body = blend_by_strength(before, after, keep[frames])
    posed = body.rotations.copy()
    posed[:, arm_joints] = target.rotations[np.ix_(frames, arm_joints)]
    turns, places = Motion(skeleton, posed, body.translations, body.fps).world(hands)
    content_turns, content_places = Motion(
        skeleton, content.rotations[frames], content.translations[frames], content.fps
    ).world(np.append(hands, skeleton.pelvis))
    # the content's hand places relative to its pelvis, turned from its heading to the output's
    pelvis, forward = skeleton.pelvis, pelvis_forward_local(skeleton)
    yaw = heading_yaw(turns[:, pelvis], forward) - heading_yaw(content_turns[:, pelvis], forward)
    relative = content_places[:, hands] - content_places[:, [pelvis]]  # (F, H, 3)
    wanted = places[:, [pelvis]] + np.einsum("fij,fhj->fhi", yaw_matrices(yaw), relative)
    reach, aim = places[:, hands] - places[:, shoulders], wanted - places[:, shoulders]  # (F, H, 3)
    swing = to_matrix(least_turn(reach, aim))  # (F, H, 3, 3) in the world
    own = turns[:, shoulders]  # (F, H, 3, 3) the shoulders' world rotations
    turned = from_matrix(np.swapaxes(own, -1, -2) @ swing @ own)  # (F, H, 3) each shoulder's local turn
    rotations = target.rotations.copy()
    rotations[np.ix_(frames, shoulders)] = multiply(rotations[np.ix_(frames, shoulders)], turned)
    return Motion(skeleton, rotations, target.translations, target.fps)


def _shoulder(skeleton: Skeleton, root: int, hand: int) -> int:
    """The joint an arm swings about: the upper arm below a clavicle (an arm root with one child that is not
    its hand), else the arm's root. Turning the clavicle by as much read as a shrug."""
    children = skeleton.children(root)
    return int(children[0]) if len(children) == 1 and int(children[0]) != hand else root


def _change(reference: Motion, changed: Motion, joints: IntArray) -> FloatArray:
    """(N, C, 3) exp maps: each joint's (C,) local rotation from `reference` to `changed`."""
    return canonical_log(
        quat_multiply(to_quat(-reference.rotations[:, joints]), to_quat(changed.rotations[:, joints]))
    )
