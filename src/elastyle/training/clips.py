"""The training clips: read in parallel at one frame rate, checked to share one skeleton (under one naming)
and rest pose, and brought to one size."""

from __future__ import annotations

import logging
import signal
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor

from elastyle.core.body import at_size_of, same_rest_pose, same_structure
from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.core.threads import stop_workers
from elastyle.errors import SkeletonMismatchError
from elastyle.io.dataset import ClipRef, read_up

log = logging.getLogger(__name__)


def _leave_interrupts() -> None:
    """A reading process leaves Ctrl-C to the command that started it (which ends it): the whole process
    group receives it, and each reader printed a traceback of its own."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _read_resampled(task: tuple[ClipRef, float | None, str]) -> Motion:
    clip, fps, up = task
    motion, _ = clip.read(up)
    return motion if fps is None else motion.resample(fps)


def load_motions(
    clips: Sequence[ClipRef], fps: float | None, workers: int = 2, up: str | None = None
) -> list[Motion]:
    """Read clips (in parallel), resampled to `fps`; all must share one skeleton. up: how their up axis
    is read (`ClipRef.read`; None: as `set_read_up` last said), handed to every reading process."""
    tasks = [(clip, fps, up or read_up()) for clip in clips]
    if len(tasks) > 8 and workers > 1:
        with ProcessPoolExecutor(workers, initializer=_leave_interrupts) as pool:
            try:
                motions = list(pool.map(_read_resampled, tasks, chunksize=16))
            except (
                KeyboardInterrupt
            ):  # Ctrl-C while reading: the readers end now, without tracebacks of their own
                stop_workers(pool)
                raise
    else:
        motions = [_read_resampled(t) for t in tasks]
    return on_one_skeleton(motions[0].skeleton, clips[0].name, clips, motions) if motions else motions


def on_one_skeleton(
    skeleton: Skeleton, reference: str, clips: Sequence[ClipRef], motions: Sequence[Motion]
) -> list[Motion]:
    """Every clip on `skeleton`, that of clip `reference`: its joints and its rest pose (a model learns
    rotations from one rest pose); a clip that is that skeleton under other joint names (`mixamorig:Hips`,
    `core.body.same_structure`) is read under its names, said in a note; a one-line
    `SkeletonMismatchError` names the first clip that differs otherwise."""
    result, renamed = [], []
    for clip, motion in zip(clips, motions):
        if not skeleton.same_as(motion.skeleton) and same_structure(skeleton, motion.skeleton):
            renamed.append(clip.name)
            motion = motion.renamed(skeleton.names)
        skeleton.check_same(motion.skeleton, reference, clip.name)
        if not same_rest_pose(skeleton, motion.skeleton):
            raise SkeletonMismatchError(
                f"{clip.name}: the joints of {reference}, but another rest pose (its bones point other ways at "
                "rest, so its rotations mean other poses): export every training clip in one rest pose"
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
