"""Whether an arm does what its matched style windows do: where its hand is, and whether it goes back and forth.

The legs tell a walk from a wave by their travel and steps (`steps.part_action.part_mismatch`); an arm needs two
other measures, both in leg lengths, so any unit and skeleton size compare alike:

    hand offset        the distance between the hand's mean place (relative to the pelvis, heading frame)
                       over the content's span and over the style window: a raised hand against a lowered
                       one is about 1 leg; two manners of the same action differ by a few tenths
    rhythm difference  the difference of the share of the hand's path that comes back on itself within about
                       a second (`back_and_forth`): a wave or an arm swing is near 1, raising, lowering
                       or holding near 0, whatever the motion's size, so a large wave and a small one agree;
                       both read as their median over a few seconds (`steady_rhythm`), so a raise's one
                       turn at its top does not count as back and forth

Where either is over its threshold (`TransferConfig.arm_offset_above`, `arm_rhythm_above`), the arm keeps
the content's action (`steps.keep`): a waving hand given a walk's style still waves, a raised hand given a
wave's style does not start to wave.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from elastyle.core.smoothing import moving_sum
from elastyle.steps.search import Patch, mean_gap
from elastyle.types import FloatArray, IntArray

RHYTHM_WINDOW_S = 1.0  # the back-and-forth is measured over this long: one arm swing, several waves
PATH_FLOOR = 0.2  # legs per window: a hand moving less than this reads as still (share near 0)
STEADY_RHYTHM_S = 3.0  # both rhythms compared are their median over this long (`steady_rhythm`)


class ArmMismatch(NamedTuple):
    """Per patch (P,): the hand offset (legs) and the rhythm difference (0 to 1) of one arm."""

    hand_offset: FloatArray
    rhythm_difference: FloatArray


def back_and_forth(hand: FloatArray, clip_starts: IntArray, fps: float) -> FloatArray:
    """(T,) per frame, the share (0 to 1) of the hand's path over `RHYTHM_WINDOW_S` about it that comes back
    on itself: (path - net displacement) / (path + `PATH_FLOOR`). hand: (T, 3) positions in legs, clips
    end to end from clip_starts (K,) (a window never reaches into the next clip)."""
    width = max(int(round(RHYTHM_WINDOW_S * fps)), 2)
    share = np.zeros(len(hand))
    for start, end in zip(clip_starts, np.append(clip_starts[1:], len(hand))):
        if end - start < 2:
            continue
        steps = np.diff(hand[start:end], axis=0, prepend=hand[start : start + 1])  # (n, 3) legs per frame
        path = moving_sum(np.linalg.norm(steps, axis=1), width)
        net = np.linalg.norm(moving_sum(steps, width), axis=1)
        share[start:end] = (path - net) / (path + PATH_FLOOR)
    return share


def steady_rhythm(rhythm: FloatArray, clip_starts: IntArray, fps: float) -> FloatArray:
    """(T,) `back_and_forth` (T,) of clips end to end from clip_starts (K,), each as its running median over
    `STEADY_RHYTHM_S` about each frame, the window cut at its clip's ends (a clip shorter than it: its
    median over the whole clip): the one turn of a raise from rising to lowering comes back on itself
    within a second too, but for a moment, so it does not read as a wave, while a wave's or an arm swing's
    rhythm, which lasts, does. (Where a cut window holds an even count, the lower of its two middle values;
    sorted rows, not numpy's median, which imports numpy.ma on its first call.)"""
    half = max(1, int(round(STEADY_RHYTHM_S * fps / 2)))
    steady = np.zeros(len(rhythm))
    for start, end in zip(clip_starts, np.append(clip_starts[1:], len(rhythm))):
        padded = np.full(end - start + 2 * half, np.nan)
        padded[half : half + end - start] = rhythm[start:end]
        windows = np.sort(sliding_window_view(padded, 2 * half + 1), axis=-1)  # (n, 2 * half + 1), NaN last
        count = np.sum(~np.isnan(windows), axis=-1)  # (n,) the frames each cut window holds
        steady[start:end] = windows[np.arange(end - start), (count - 1) // 2]
    return steady


def arm_mismatch(
    content_hand: FloatArray,
    content_rhythm: FloatArray,
    library_hand: FloatArray,
    library_rhythm: FloatArray,
    patches: list[Patch],
    patch_frames: int,
) -> ArmMismatch:
    """How differently one arm acts in each patch's content span and its style window: hands (T, 3) and
    (N, 3) in legs, their `back_and_forth` (T,) and (N,); windows of `patch_frames`."""
    return ArmMismatch(
        mean_gap(content_hand, library_hand, patches, patch_frames),
        mean_gap(content_rhythm[:, None], library_rhythm[:, None], patches, patch_frames),
    )
