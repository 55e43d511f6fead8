"""The clip's tempo, and the search again about it (docs/method.md, "Transfer": timing).

The sequential search tries stretches of (1 - stretch) to (1 + stretch) about the content's own pace. A
style much faster or slower than the content lies beyond that range, so after a first search the clip's
tempo is read from the patches whose legs step as their windows' do, and the search runs again with the
range centred on it, up to `TEMPO_SEARCHES` times.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from elastyle.core.stats import median
from elastyle.steps.config import TransferConfig
from elastyle.steps.part_action import part_mismatch
from elastyle.steps.search import Patch
from elastyle.types import FloatArray, IntArray

TEMPO_SEARCHES = 2  # searches about the clip's tempo after the first (each from the previous one's tempo)
# the tempo is read from patches whose legs' mismatch is below this, whatever --keep-action-above says: it
# separates standing from stepping (a gesture given a walk's style: 0.69 to 0.75) and keeps stepping at
# another pace or gait (a walk against a walk retimed to 0.6 to 2 times its cadence, or a run: 0.23 to 0.58)
TEMPO_MISMATCH = 0.65
# searched again only where the tempo lies over this share of --stretch from the range's tempo
TEMPO_MOVE = 0.25
# fewer tried lengths are too coarse to read a tempo from (the median jumps between the range's ends)
MIN_TEMPO_LENGTHS = 5
MIN_TEMPO_PATCHES = 2  # patches needed to read a tempo


def searched_about_tempo(
    search: Callable[[IntArray], list[Patch]],
    patches: list[Patch],
    content_actions: FloatArray,
    library_actions: FloatArray,
    config: TransferConfig,
    patch_frames: int,
    fps: float,
    leg_columns: IntArray,
) -> list[Patch]:
    """The patches of a search again about the clip's tempo, or `patches` (the first search's, over
    `config.source_lengths`) where there is no tempo to read or the range already surrounds it.

    search: the tried source lengths (S,) -> the sequential search's patches; content_actions (T, A) and
    library_actions (N, A): the action descriptors whose leg columns (K,) say which patches step alike."""
    lengths = config.source_lengths(patch_frames, fps)
    range_tempo = 1.0  # the tempo the tried stretches surround
    for _ in range(TEMPO_SEARCHES if len(lengths) >= MIN_TEMPO_LENGTHS else 0):
        tempo = stepping_tempo(content_actions, library_actions, patches, patch_frames, leg_columns)
        if tempo is None or abs(tempo / range_tempo - 1) <= TEMPO_MOVE * config.stretch:
            break  # no tempo to read, or the range already surrounds it
        centred = config.source_lengths(patch_frames, fps, tempo)
        if np.array_equal(centred, lengths):
            break
        range_tempo, lengths = tempo, centred
        patches = search(lengths)
    return patches


def stepping_tempo(
    content_actions: FloatArray,
    library_actions: FloatArray,
    patches: list[Patch],
    patch_frames: int,
    leg_columns: IntArray,
) -> float | None:
    """The clip's tempo: the median over patches of the content frames read per output frame, L' / L (above
    1 where the style moves faster than the content), over the patches that lie inside the content
    (T frames of actions (T, A)) and whose legs act as their windows' do (legs' mismatch below
    `TEMPO_MISMATCH`: a walk's pace says nothing of a wave's); None with fewer than `MIN_TEMPO_PATCHES`."""
    mismatch = part_mismatch(content_actions, library_actions, patches, patch_frames, leg_columns)
    stretches = [
        p.content_frames / patch_frames
        for p, legs in zip(patches, mismatch)
        if legs < TEMPO_MISMATCH and p.content_start + p.content_frames <= len(content_actions)
    ]
    if len(stretches) < MIN_TEMPO_PATCHES:
        return None
    return float(np.exp(median(np.log(stretches))))
