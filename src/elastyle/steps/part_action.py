"""Per body part: whether it does what its matched style windows do, and where it keeps the content's own
action instead (docs/method.md, "Per body part").

The legs compare their travel and steps (`part_mismatch`), their turning and, in place, where the feet and
pelvis are; the spine, in place, how the head leans; each arm where its hand is and whether it goes back and
forth (`steps.arms`), and keeps the content's action outright where the content keeps its place under
travelling windows. A part's share of the content's action rises from 0 to 1 over `KEEP_RAMP` past its
threshold (`TransferConfig`), eased in and out in time; `steps.keep` performs it.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from elastyle.core.smoothing import smooth, smoothstep
from elastyle.steps.action import ActionLayout, sustained_turning, travelling_legs
from elastyle.steps.arms import arm_mismatch, back_and_forth, steady_rhythm
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import StyleLibrary
from elastyle.steps.search import Patch, mean_gap, patch_windows, window_rows
from elastyle.types import FloatArray, IntArray

KEEP_RAMP = 0.15  # a part's share of the content's action rises from 0 to 1 over this much mismatch
# each arm keeps the content's action at the clip's first and last frames, the share easing to the matched
# windows' over this many patches: there one of the two half-shifted sequences alone covers the clip, and
# its window, matched over a span that mixes the content's rest pose with its action, may begin or end mid-
# gesture (27 of 150 held-out gesture and cross outputs had a hand over 0.3 legs from the content's at an end)
ARM_ENDS_PATCHES = 0.5
# where the content travels, its head's gaze counts where it departs from the window's by this many times
# `TransferConfig.spine_lean_above`: a walk looking 55 degrees aside given a walk's style kept 8 to 19 degrees
# of it, now 34 to 39; at the threshold itself, a walk's or a run's ordinary head motion counted too, and the
# referee's turn and run naturalness fell (2.16 -> 2.27, 3.67 -> 3.77); at twice, 13 of its 78 outputs change,
# and of its figures only the run naturalness, 3.67 -> 3.65
TRAVELLING_GAZE = 2.0
MISMATCH_FLOOR = 0.3  # legs (per second): what a part's mismatch is relative to, at the least


class PartKeeps(NamedTuple):
    """Per body part (`StyleTrack`'s fields of the same names): mismatch, each patch's action mismatch (P,);
    measures, each patch's other measures; keep (G,), the share of the content's own action; other_action
    (G,), where it keeps it because the windows perform another action; posture (G,), where the change the
    matched windows make to it counts towards the style's mean posture; own_pace (G,), where the legs keep
    the content's pace: where they keep its action for another gait or place, not for another turn alone (a
    turning walk's legs keep its turning steps at the style's cadence)."""

    mismatch: dict[str, FloatArray]
    measures: dict[str, dict[str, FloatArray]]
    keep: dict[str, FloatArray]
    other_action: dict[str, FloatArray]
    posture: dict[str, FloatArray]
    own_pace: FloatArray


def part_keeps(
    content_actions: FloatArray,
    library: StyleLibrary,
    sequences: tuple[list[Patch], list[Patch]],
    patch_frames: int,
    layout: ActionLayout | None,
    config: TransferConfig,
    fps: float,
    on_grid: Callable[[FloatArray, FloatArray], FloatArray],
    grid: FloatArray,
    ease: float,
) -> PartKeeps:
    """What each body part does against its matched windows, for content action descriptors (T, A) and the
    two half-shifted patch sequences; layout: their columns (`steps.action`; None: no parts); on_grid:
    two sequences' per-patch values (P,), (P - 1,) -> (G,) on the grid (G,) as the latents are cross-faded;
    ease: the shares' easing in time, grid steps. Where the legs do another action than the windows (a walk
    matched against a run or a wave, in place a kick or a crouch against a stand), legs and spine keep the
    content's action; where the content does not travel and its head leans away from its carriage otherwise
    than the window's (a bow against a standing wave), or turns further from it (a nod, a look aside; where it
    travels, `TRAVELLING_GAZE` times as far), the spine does; where an arm's hand is elsewhere or
    goes back and forth where the window's does not (or the other way round), and wherever the content keeps
    its place and its legs their action while the windows travel, that arm does. The spine's mean posture
    reads where it keeps the content's action for the legs' sake, not where it leans otherwise (the change
    there is a bow undone, not a carriage)."""
    patches, shifted = sequences
    parts = {} if layout is None else layout.parts
    mismatch = {
        part: part_mismatch(content_actions, library.actions, patches, patch_frames, columns)
        for part, columns in parts.items()
    }
    measures: dict[str, dict[str, FloatArray]] = {}  # per part, each measure's value per patch (P,)
    keep: dict[str, FloatArray] = {}
    other_action: dict[str, FloatArray] = {}
    posture: dict[str, FloatArray] = {}
    in_place = np.ones_like(grid)  # (G,) where the content does not travel
    own_pace = np.zeros_like(grid)  # (G,) where the legs keep the content's pace
    in_place_under_travel = np.zeros_like(grid)  # (G,) where the content keeps its place, the windows travel
    stepping_alike = np.zeros_like(grid)  # (G,) where the content travels, its legs acting as the windows'
    if layout is not None:
        shifted_mismatch = part_mismatch(content_actions, library.actions, shifted, patch_frames, layout.legs)
        # a turning walk matched against straight windows keeps its turn, and the other way round
        content_turning = sustained_turning(content_actions, np.zeros(1, dtype=np.int64), fps)[:, None]
        library_turning = library.derived(
            ("turning", fps), lambda: sustained_turning(library.actions, library.clip_starts, fps)[:, None]
        )
        turning = [
            mean_gap(content_turning, library_turning, sequence, patch_frames)
            for sequence in (patches, shifted)
        ]
        # the gait alone (travel and steps without the turning): another action, not another path
        gait = [
            part_mismatch(content_actions, library.actions, sequence, patch_frames, layout.gait)
            for sequence in (patches, shifted)
        ]
        measures["legs"] = {"turning_difference": turning[0], "gait_mismatch": gait[0]}
        one_clip = np.zeros(1, dtype=np.int64)
        travelling = np.interp(
            grid,
            np.arange(len(content_actions)),
            travelling_legs(content_actions, layout, one_clip, fps),
        )
        travelling = np.clip(smooth(travelling, ease), 0.0, 1.0)  # (G,)
        in_place = 1 - travelling
        shares = [
            keep_share(on_grid(mismatch["legs"], shifted_mismatch), config.keep_action_above, ease),
            keep_share(on_grid(*turning), config.legs_turning_above, ease),
        ]
        if len(layout.place):  # each foot's height, the pelvis's
            # in place, where the feet and the pelvis are (a kick, a crouch against standing windows): a few
            # columns among the legs' many, they hardly moved their mismatch; a travelling body's are its gait's
            place = [
                _largest_gap(content_actions, library.actions, sequence, patch_frames, layout.place)
                for sequence in (patches, shifted)
            ]
            measures["legs"]["place_offset"] = place[0]
            in_place_share = keep_share(on_grid(*place), config.legs_place_above, ease, held=True)
            shares.append(in_place_share * in_place)
        share = np.max(shares, axis=0)
        # another action, not another turn: the legs' mismatch counts their turning too, so it keeps the pace
        # only where the gait alone (travel and steps) differs as well; turning steps take any pace
        gait_share = keep_share(on_grid(*gait), config.keep_action_above, ease)
        own_pace = np.max([np.minimum(shares[0], gait_share), *shares[2:]], axis=0)
        keep = {"legs": share, "spine": share}
        posture["spine"] = share
        # legs that do not travel take none of a stepping style's statistics: its legs' mean is a stride's
        # bent knees and lifted heels, not a manner (a raise given a run's statistics stood on tiptoe, knees
        # bent; a kick given a walk's rose half as high)
        other_action["legs"] = gait_share * travelling
        # the content keeps to its place, its legs keep its action, and the windows travel
        library_travelling = library.derived(
            ("travelling", tuple(layout.travel.tolist()), fps),
            lambda: travelling_legs(library.actions, layout, library.clip_starts, fps)[:, None],
        )
        windows_travel = on_grid(
            *(
                _window_mean(library_travelling[:, 0], sequence, patch_frames)
                for sequence in (patches, shifted)
            )
        )
        in_place_under_travel = share * in_place * np.clip(windows_travel, 0.0, 1.0)
        stepping_alike = (1 - share) * travelling * np.clip(windows_travel, 0.0, 1.0)
    if "spine" in parts and layout is not None:
        # the head's turn counts where the content's departs from its carriage at least as far as the window's:
        # a nod or a look aside the window lacks, not a look up at a raised hand the style adds (its manner)
        lean, gaze = (
            [
                _largest_gap(content_actions, library.actions, sequence, patch_frames, columns, departs)
                for sequence in (patches, shifted)
            ]
            for columns, departs in ((layout.lean, False), (layout.gaze, True))
        )
        measures["spine"] = {"lean_offset": lean[0], "gaze_offset": gaze[0]}
        # where the content does not travel: there a lean is an action (a bow, a reach down), and so is a turn of
        # the head (a nod, a look aside); a travelling body's lean is its gait's manner (a youthful run leans 0.19
        # legs further forward than a normal one), and only a turn of its head far from the window's counts
        leans, looks = (
            keep_share(on_grid(*gap), config.spine_lean_above, ease, held=True) * in_place
            for gap in (lean, gaze)
        )
        # travelling, a turn of the head far from the window's is an action too (a look aside while walking)
        above = TRAVELLING_GAZE * config.spine_lean_above
        looks = looks + (1 - in_place) * keep_share(on_grid(*gaze), above, ease, held=True)
        keep["spine"] = np.max([keep.get("spine", np.zeros_like(grid)), leans, looks], axis=0)
        # where the head alone turns otherwise, the windows' change to the trunk is still its carriage; where
        # the trunk leans otherwise, that change is a bow undone, not a carriage
        posture["spine"] = np.maximum(posture.get("spine", np.zeros_like(grid)), looks) * (1 - leans)
    for part, hand in ({} if layout is None else layout.arm_hands).items():
        content_hand, library_hand = content_actions[:, hand], library.actions[:, hand]
        one_clip = np.zeros(1, dtype=np.int64)
        content_rhythm = _steady_hand_rhythm(content_hand, one_clip, fps)
        library_rhythm = library.derived(
            ("rhythm", tuple(hand.tolist()), fps),
            partial(_steady_hand_rhythm, library_hand, library.clip_starts, fps),
        )
        arm, shifted_arm = (
            arm_mismatch(content_hand, content_rhythm, library_hand, library_rhythm, sequence, patch_frames)
            for sequence in (patches, shifted)
        )
        measures[part] = arm._asdict()
        offset = on_grid(arm.hand_offset, shifted_arm.hand_offset)
        rhythm = on_grid(arm.rhythm_difference, shifted_arm.rhythm_difference)
        # where the windows' hand goes back and forth more than the content's (a raise's held top against a
        # wave), a short mismatch is held over the easing rather than flattened by it: the arm keeps the
        # content's action fully there instead of taking part of the windows' sway
        sways_more = on_grid(
            *(
                _sways_more(content_rhythm, library_rhythm, sequence, patch_frames)
                for sequence in (patches, shifted)
            )
        )
        shares = []
        for values, above in ((offset, config.arm_offset_above), (rhythm, config.arm_rhythm_above)):
            plain, held = keep_share(values, above, ease), keep_share(values, above, ease, held=True)
            shares.append(plain + sways_more * (held - plain))
        # where both walk alike, the arms swing with the stride: where the windows' hand goes back and forth
        # less, that is the swing's manner (a sad walk's hanging arms, a heavy walk's slow swing), not another
        # action, so the rhythm does not count there; where the content's does less, it holds something still
        shares[1] *= 1 - stepping_alike * (1 - sways_more)
        # where the content keeps its place, and its legs their action, while the windows travel, their arms
        # swing with the stride: the arm keeps the content's action whatever it does (punches, which come and go
        # like a swing, took a walk's swing)
        keep[part] = np.max(
            [*shares, end_share(grid, ARM_ENDS_PATCHES * patch_frames), in_place_under_travel], axis=0
        )
    return PartKeeps(mismatch, measures, keep, other_action, posture, own_pace)


def part_mismatch(
    content_actions: FloatArray,
    library_actions: FloatArray,
    patches: list[Patch],
    patch_frames: int,
    columns: IntArray,
) -> FloatArray:
    """(P,) how differently a body part acts in each patch's content span (stretched to L frames) and its
    style window: the RMS difference of the part's action descriptors (T, A) columns (K,), relative to
    their RMS in both (at least `MISMATCH_FLOOR`). 0: the same action; 1: as different as they are large."""
    if not patches or not len(columns):
        return np.zeros(len(patches))
    content, style = patch_windows(content_actions, library_actions, patches, patch_frames, columns)
    difference = np.sqrt(np.mean((content - style) ** 2, axis=(1, 2)))
    size = np.sqrt(np.mean(content**2, axis=(1, 2)) + np.mean(style**2, axis=(1, 2)))
    return difference / (size + MISMATCH_FLOOR)


def _window_mean(values: FloatArray, patches: list[Patch], patch_frames: int) -> FloatArray:
    """(P,) per patch, the mean of per-frame library values (N,) over its style window."""
    if not patches:
        return np.zeros(0)
    return np.asarray(values, dtype=np.float64)[window_rows(patches, patch_frames, len(values))].mean(axis=1)


def _largest_gap(
    content_actions: FloatArray,
    library_actions: FloatArray,
    patches: list[Patch],
    patch_frames: int,
    columns: IntArray,
    content_departs: bool = False,
) -> FloatArray:
    """(P,) per patch, the largest distance over its L frames between the content span's values of the
    action columns (K,) (stretched to L frames) and its window's: a kick lasts less than a patch, and the
    patches' means halved it. content_departs: only frames where the content's values lie at least as far
    from zero (its carriage) as the window's count: an action the window lacks, not a manner it adds."""
    if not patches:
        return np.zeros(0)
    spans, windows = patch_windows(content_actions, library_actions, patches, patch_frames, columns)
    gaps = np.linalg.norm(spans - windows, axis=2)  # (P, L)
    if content_departs:
        gaps *= np.linalg.norm(spans, axis=2) >= np.linalg.norm(windows, axis=2)
    return gaps.max(axis=1)


def keep_share(mismatch: FloatArray, above: float, ease_steps: float, held: bool = False) -> FloatArray:
    """(G,) 0 where a part's mismatch (G,) is at most `above`, rising smoothly to 1 at `KEEP_RAMP` over it,
    eased in and out in time (Gaussian, sigma `ease_steps` grid steps); held: each share first held at its
    running maximum over `ease_steps` either side, so the easing widens a short peak (an arm's mismatch
    that lasts less than a patch, a raise's top against a wave's) instead of flattening it."""
    return eased((mismatch - above) / KEEP_RAMP, ease_steps, held)


def end_share(grid: FloatArray, span: float) -> FloatArray:
    """(G,) 1 at the grid's (G,) first and last times, easing (smoothstep) to 0 at `span` content frames
    from them."""
    distance = np.minimum(grid - grid[0], grid[-1] - grid) if len(grid) else grid
    return smoothstep(1 - distance / max(span, 1e-9))


def eased(ramp: FloatArray, ease_steps: float, held: bool = False) -> FloatArray:
    """(G,) a ramp (G,) clipped to [0, 1] through a smoothstep, then eased in and out in time (Gaussian,
    sigma `ease_steps` grid steps), held at its running maximum over `ease_steps` either side first if
    asked."""
    x = smoothstep(ramp)
    if held and len(x):
        reach = int(round(ease_steps))
        x = sliding_window_view(np.pad(x, reach, mode="edge"), 2 * reach + 1).max(axis=-1)
    return np.clip(smooth(x, ease_steps), 0.0, 1.0)


def _sways_more(
    content_rhythm: FloatArray, library_rhythm: FloatArray, patches: list[Patch], patch_frames: int
) -> FloatArray:
    """(P,) 1.0 where a patch's style window goes back and forth more than its content span (the mean of
    each's steady rhythm, (T,) and (N,)), else 0.0."""
    if not patches:
        return np.zeros(0)
    spans, windows = patch_windows(
        content_rhythm[:, None], library_rhythm[:, None], patches, patch_frames, np.arange(1)
    )
    return (windows.mean(axis=(1, 2)) > spans.mean(axis=(1, 2))).astype(np.float64)


def _steady_hand_rhythm(hand: FloatArray, clip_starts: IntArray, fps: float) -> FloatArray:
    """(T,) how steadily a hand (T, 3), clips end to end from clip_starts (K,), goes back and forth
    (`steps.arms.back_and_forth` read as `steady_rhythm`)."""
    return steady_rhythm(back_and_forth(hand, clip_starts, fps), clip_starts, fps)
