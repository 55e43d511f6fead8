"""The training clips: read at one frame rate, checked to share one skeleton (under one naming)
and rest pose, and brought to one size."""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Sequence

from elastyle.core.body import at_size_of, same_rest_pose, same_structure
from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.errors import ElastyleError, SkeletonMismatchError
from elastyle.io.dataset import ClipRef, read_up

log = logging.getLogger(__name__)


def load_motions(clips: Sequence[ClipRef], fps: float | None, up: str | None = None) -> list[Motion]:
    """Read clips, resampled to `fps`; all must share one skeleton. up: how their up axis is read
    (`ClipRef.read`; None: as `set_read_up` last said). Read in this process (the whole dataset, 2,902
    clips, in 30 s): a pool of two reading processes saved at most half of that, of a 45-minute training,
    and a Ctrl-C while it ran or shut down could leave the command waiting on it for good (its manager
    thread joined at exit) or ending killed by the signal."""
    up = up or read_up()
    motions, unreadable = [], []
    for clip in clips:
        try:
            motion, _ = clip.read(up)
        except ElastyleError as error:  # every unreadable clip said at once, not one per run
            unreadable.append(str(error))
            continue
        motions.append(motion if fps is None else motion.resample(fps))
    if unreadable:
        raise ElastyleError(
            f"{len(unreadable)} of {len(clips)} clip(s) could not be read: {'; '.join(unreadable)}; fix them or "
            "leave them out (--exclude NAME_GLOB)"
        )
    if not motions:
        return motions
    # the skeleton most clips have is the reference: a stray clip of another rig is the one named
    shapes = [(m.skeleton.names, tuple(m.skeleton.parents.tolist())) for m in motions]
    common = Counter(shapes).most_common(1)[0][0]
    reference = shapes.index(common)
    return on_one_skeleton(motions[reference].skeleton, clips[reference].name, clips, motions)


def on_one_skeleton(
    skeleton: Skeleton, reference: str, clips: Sequence[ClipRef], motions: Sequence[Motion]
) -> list[Motion]:
    """Every clip on `skeleton`, that of clip `reference`: its joints and its rest pose (a model learns
    rotations from one rest pose); a clip that is that skeleton under other joint names (`mixamorig:Hips`,
    `core.body.same_structure`) is read under its names, said in a note; a one-line
    `SkeletonMismatchError` names the first clip that differs otherwise, and how to leave it out."""
    result, renamed = [], []
    leave_out = (
        "; a model learns one skeleton: leave such clips out (--exclude NAME_GLOB) or train on them apart"
    )
    for clip, motion in zip(clips, motions):
        if not skeleton.same_as(motion.skeleton) and same_structure(skeleton, motion.skeleton):
            renamed.append(clip.name)
            motion = motion.renamed(skeleton.names)
        try:
            skeleton.check_same(motion.skeleton, reference, clip.name)
        except SkeletonMismatchError as error:
            raise SkeletonMismatchError(f"{error}{leave_out}") from None
        if not same_rest_pose(skeleton, motion.skeleton):
            raise SkeletonMismatchError(
                f"{clip.name}: the joints of {reference}, but another rest pose (its bones point other ways at "
                f"rest, so its rotations mean other poses): export every training clip in one rest pose{leave_out}"
            )
        result.append(motion)
    if renamed:
        log.warning(
            "note: %d clip(s) (%s%s) name their joints otherwise than %s but are its skeleton: read under its "
            "names", len(renamed), ", ".join(renamed[:3]), ", ..." if len(renamed) > 3 else "", reference,
        )  # fmt: skip
    return result


def at_one_size(motions: list[Motion], reference: Skeleton) -> list[Motion]:
    """Clips brought to the reference skeleton's unit and size (`core.body.size_factor`), as a transfer
    reads them with the trained model."""
    return [at_size_of(m, reference)[0] for m in motions]
