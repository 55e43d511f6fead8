"""The clip's tempo, and the search again about it (docs/method.md, "Transfer": timing).

The sequential search tries stretches of (1 - stretch) to (1 + stretch) about the content's own pace. A
style much faster or slower than the content lies beyond that range. Where both step, the first search is
centred on the ratio of their cadences (`cadence_tempo`: each read from the feet's heights); after it the
clip's tempo is read from the patches whose legs step as their windows' do, and the search runs again with
the range centred on it, up to `TEMPO_SEARCHES` times.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from elastyle.core.ground import PERCENTILE_METHOD
from elastyle.core.rhythm import dominant_frequency_hz
from elastyle.core.stats import median
from elastyle.steps.action import ActionLayout, airborne, sustained_turning, travelling_legs
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import StyleLibrary
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
    range_tempo: float = 1.0,
) -> list[Patch]:
    """The patches of a search again about the clip's tempo, or `patches` (the first search's, over
    `config.source_lengths` about `range_tempo`) where there is no tempo to read or the range already
    surrounds it.

    search: the tried source lengths (S,) -> the sequential search's patches; content_actions (T, A) and
    library_actions (N, A): the action descriptors whose leg columns (K,) say which patches step alike."""
    lengths = config.source_lengths(patch_frames, fps, range_tempo)
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


# the first search is centred on the cadences' ratio only where it lies over this share of --stretch from the
# content's pace (as `TEMPO_MOVE`; only beyond the first range, 1, left the wider pairs' runs at E 0.18 where
# this reaches 0.03)
CADENCE_MOVE = 0.25
# a clip steps where its pelvis travels over at least this share of its frames (`steps.action.travelling_legs`)
STEPPING_SHARE = 0.5
# two clips step in one gait where their shares of frames with both feet off the ground (`steps.action.airborne`)
# lie within this: dataset runs fly over 0.19 to 0.51 of their frames, walks 0 to 0.16
SAME_GAIT_FLIGHT = 0.15


def cadence_tempo(
    content_actions: FloatArray,
    library: StyleLibrary,
    layout: ActionLayout,
    config: TransferConfig,
    patch_frames: int,
    fps: float,
) -> float:
    """The tempo the first search centres on: the library's cadence over the content's (each read from its
    feet's heights, `feet_cadence`) where both step in one gait (their shares of frames with both feet off
    the ground within `SAME_GAIT_FLIGHT`) along alike paths (their sustained turning, over the tenth of
    frames where each turns most, within --legs-turning-above) and it lies beyond `CADENCE_MOVE` of the
    range from the content's own pace; else 1, its own pace. A walk's cadence says nothing of a run's pace:
    centred on it, a run given a walk's style was read slowly enough to match the walk, and walked; a
    turning walk keeps its turning steps against straight windows, its legs at a share of their own, and
    centred on their cadence one slid 16 cm/s (11 before). Patches of fewer tried lengths than
    `MIN_TEMPO_LENGTHS` keep the report's range about the content's pace, as they read no tempo."""
    if len(config.source_lengths(patch_frames, fps)) < MIN_TEMPO_LENGTHS:
        return 1.0
    one_clip = np.zeros(1, dtype=np.int64)
    content = feet_cadence(content_actions, layout, one_clip, fps)
    style = library.derived(
        ("cadence", tuple(layout.feet.tolist()), fps),
        lambda: feet_cadence(library.actions, layout, library.clip_starts, fps),
    )
    if content is None or style is None:
        return 1.0
    content_gait = _gait_and_path(content_actions, layout, one_clip, fps)
    style_gait = library.derived(
        ("gait and path", tuple(layout.feet.tolist()), fps),
        lambda: _gait_and_path(library.actions, layout, library.clip_starts, fps),
    )
    (content_flight, content_turning), (style_flight, style_turning) = content_gait, style_gait
    if (
        abs(content_flight - style_flight) > SAME_GAIT_FLIGHT
        or abs(content_turning - style_turning) > config.legs_turning_above
    ):
        return 1.0
    tempo = style / content
    return tempo if abs(tempo - 1) > CADENCE_MOVE * config.stretch else 1.0


def _gait_and_path(
    actions: FloatArray, layout: ActionLayout, clip_starts: IntArray, fps: float
) -> tuple[float, float]:
    """Of clips end to end from clip_starts (K,) (`action_channels` (T, A), their layout): the share of frames
    with both feet off the ground, and the sustained turning (rad/s) where they turn most (a tenth of their
    frames; the nearest percentile, as numpy's interpolating one imports numpy.ma)."""
    turning = np.abs(sustained_turning(actions, clip_starts, fps))
    return float(np.mean(airborne(actions, layout))), float(
        np.percentile(turning, 90, method=PERCENTILE_METHOD)
    )


def feet_cadence(
    actions: FloatArray, layout: ActionLayout, clip_starts: IntArray, fps: float
) -> float | None:
    """Steps per second of clips end to end from clip_starts (K,) (`action_channels` (T, A), their layout):
    twice the dominant frequency of one foot's height less the other's, over the clips that step (their
    median, each clip weighing its frames); None where none steps or the feet are not two."""
    if len(layout.feet) != 2:
        return None
    travelling = travelling_legs(actions, layout, clip_starts, fps)
    cadences, weights = [], []
    for start, end in zip(clip_starts, np.append(clip_starts[1:], len(actions))):
        if end - start < 2 or np.mean(travelling[start:end]) < STEPPING_SHARE:
            continue
        lead = actions[start:end, layout.feet[0]] - actions[start:end, layout.feet[1]]
        cadence = 2.0 * dominant_frequency_hz(lead, fps, 0.25, 2.0)
        if np.isfinite(cadence):
            cadences.append(cadence)
            weights.append(end - start)
    if not cadences:
        return None
    order = np.argsort(cadences)
    cumulative = np.cumsum(np.asarray(weights, dtype=np.float64)[order])
    return float(np.asarray(cadences)[order][np.searchsorted(cumulative, cumulative[-1] / 2)])
