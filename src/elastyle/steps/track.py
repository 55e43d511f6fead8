"""One style's result as a function of content time: whiten, match, place, cross-fade and colour.

docs/method.md, "Transfer". A style track holds, on a fine grid of content times c (G,), the coloured
latents z(c) (G, Z) and the log playback rate log r(c) = log(L / L'(c)) (output frames per content frame)
of one style library. Strength, transitions and blends are weights over tracks (`steps.timeline`).
"""

from __future__ import annotations

import logging
from functools import partial
from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from elastyle.core.resample import interpolate_rows
from elastyle.core.smoothing import smooth
from elastyle.core.stats import median
from elastyle.errors import ClipTooShortError
from elastyle.steps.action import TURNING_COLUMN, sustained_turning
from elastyle.steps.arms import arm_mismatch, back_and_forth, steady_rhythm
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import StyleLibrary, match_frames
from elastyle.steps.search import (
    Patch,
    SideGuard,
    StyleWindows,
    half_shifted,
    mean_gap,
    patch_windows,
    search_fixed,
    search_sequential,
)
from elastyle.steps.whiten import LatentStats, adain
from elastyle.types import BoolArray, FloatArray, IntArray

log = logging.getLogger(__name__)
MIN_PATCH_FRAMES = 4
SHORT_PATCH_SHARE = 0.5  # patches shortened below this share of --patch-s get a warning, not a note
FALLBACK_RAMP = (
    0.15  # the fallback to statistics rises from 0 to 1 over this much similarity below its threshold
)


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
KEEP_RAMP = 0.15  # a part's share of the content's action rises from 0 to 1 over this much mismatch
# each arm keeps the content's action at the clip's first and last frames, the share easing to the matched
# windows' over this many patches: there one of the two half-shifted sequences alone covers the clip, and
# its window, matched over a span that mixes the content's rest pose with its action, may begin or end mid-
# gesture (27 of 150 held-out gesture and cross outputs had a hand over 0.3 legs from the content's at an end)
ARM_ENDS_PATCHES = 0.5
MISMATCH_FLOOR = 0.3  # legs (per second): what a part's mismatch is relative to, at the least


class StyleTrack(NamedTuple):
    """latents (G, Z) coloured, on the content-time grid; log_rate (G,); the matched patches (empty for
    the statistics-only methods) and their length L in frames; fallback (G,), 0 to 1, the share of the
    style's statistics alone where no style window matched well (1 for the statistics-only methods);
    mismatch: per body part, each patch's action mismatch (P,) (`part_mismatch`); measures: per body
    part, each patch's other measures of what it does (the legs' turning difference, rad/s; each arm's hand
    offset and rhythm difference, `steps.arms`); keep: per body part (G,), 0 to 1, the share of the
    content's own action where the matched windows do another; other_action: per body part (G,), 0 to 1,
    where it keeps the content's action because the windows perform another (the legs: travel and steps,
    not turning), so the style's statistics colour it (`TransferConfig.kept_statistics`)."""

    latents: FloatArray
    log_rate: FloatArray
    patches: list[Patch]
    patch_frames: int
    fallback: FloatArray
    mismatch: dict[str, FloatArray]
    measures: dict[str, dict[str, FloatArray]]
    keep: dict[str, FloatArray]
    other_action: dict[str, FloatArray]


def requested_patch_frames(config: TransferConfig, fps: float) -> int:
    """The patch length L (frames at the model's rate) that `--patch-s` asks for."""
    return max(int(round(config.patch_s * fps)), MIN_PATCH_FRAMES)


def shortened_patch_note(patch_frames: int, config: TransferConfig, fps: float) -> str:
    """The one-line note for patches shortened to the longest style clip."""
    return (
        f"the style clips are at most {patch_frames / fps:.2f} s long, so patches are {patch_frames / fps:.2f} s "
        f"instead of --patch-s {config.patch_s:g}"
    )


def style_track(
    content_latents: FloatArray,
    content_actions: FloatArray,
    library: StyleLibrary,
    grid: FloatArray,
    config: TransferConfig,
    fps: float,
    part_columns: dict[str, IntArray] | None = None,
    still: BoolArray | None = None,
) -> StyleTrack:
    """The track of one library for content latents (T, Z) and action descriptors (T, A) on grid times
    (G,) in content frames; part_columns: the action columns of each body part (`steps.action`); still:
    (T,) content frames where the body holds still, read unstretched (`search.search_sequential`)."""
    content_stats = LatentStats.of([content_latents])
    if config.method in ("wct", "adain"):
        if config.method == "wct":
            floor = config.whiten_floor
            styled = library.stats.colour(content_stats.whiten(content_latents, floor), floor)
        else:
            styled = adain(content_latents, [content_latents], [library.latents])
        unchanged = np.zeros_like(grid)  # the content's own pace
        return StyleTrack(
            interpolate_rows(styled, grid), unchanged, [], 0, np.ones_like(grid), {}, {}, {}, {}
        )
    wanted = requested_patch_frames(config, fps)
    patch_frames = min(wanted, library.longest_clip)
    if patch_frames < MIN_PATCH_FRAMES:
        names = ", ".join(dict.fromkeys(library.names))
        raise ClipTooShortError(
            f"{names}: too short for a patch ({library.longest_clip} frame(s) at {fps:g} fps at most; patches "
            f"need at least {MIN_PATCH_FRAMES})"
        )
    if patch_frames < SHORT_PATCH_SHARE * wanted:  # so short a style gives little to swap in: said plainly
        log.warning(
            "warning: %s; windows this short carry little of a style's manner and the output may step or "
            "slide oddly: give a style clip at least as long as --patch-s",
            shortened_patch_note(patch_frames, config, fps),
        )
    elif patch_frames < wanted:
        log.info("note: %s", shortened_patch_note(patch_frames, config, fps))
    # whiten, then match: the elastic search over stretched content patches, in two half-shifted sequences
    windows = library.windows(
        patch_frames, config.whiten_floor, config.action_weight, config.match_frame_step(fps)
    )
    white_content = content_stats.whiten(content_latents, config.whiten_floor)

    def search(
        frames: FloatArray, windows: StyleWindows, lengths: IntArray, guard: SideGuard | None
    ) -> list[Patch]:
        if config.placement == "sequential":
            return search_sequential(frames, windows, lengths, guard, still)
        return search_fixed(frames, windows, lengths, guard)

    content_frames = match_frames(white_content, content_actions, config.action_weight)
    lengths = config.source_lengths(patch_frames, fps)
    guard = side_guard(content_actions, library, patch_frames, part_columns or {})
    patches = search(content_frames, windows, lengths, guard)
    leg_columns = (part_columns or {}).get("legs", np.zeros(0, dtype=np.int64))
    about_tempo = config.stretch_centre == "tempo" and config.placement == "sequential"
    range_tempo = 1.0  # the tempo the tried stretches surround
    for _ in range(TEMPO_SEARCHES if about_tempo and len(lengths) >= MIN_TEMPO_LENGTHS else 0):
        # search again about the clip's tempo, so a pace beyond the first range is reached
        tempo = stepping_tempo(content_actions, library.actions, patches, patch_frames, leg_columns)
        if tempo is None or abs(tempo / range_tempo - 1) <= TEMPO_MOVE * config.stretch:
            break  # no tempo to read, or the range already surrounds it
        centred = config.source_lengths(patch_frames, fps, tempo)
        if np.array_equal(centred, lengths):
            break
        range_tempo, lengths = tempo, centred
        patches = search(content_frames, windows, lengths, guard)
    shifted = half_shifted(content_frames, windows, patches, guard)
    # place and cross-fade: each grid time reads both sequences' style windows, weighted by a triangle
    cover_a, cover_b = _cover(grid, patches), _cover(grid, shifted)
    position_a, weight_a, log_rate, similarity_a = _patch_sample(cover_a, patches, patch_frames)
    position_b, weight_b, _, similarity_b = _patch_sample(cover_b, shifted, patch_frames)
    library_white = library.white(config.whiten_floor)
    total = weight_a + weight_b
    white = (
        weight_a[:, None] * interpolate_rows(library_white, position_a)
        + weight_b[:, None] * interpolate_rows(library_white, position_b)
    ) / total[:, None]
    # fall back to the style's statistics alone where the best window is a poor match (another action)
    similarity = (weight_a * similarity_a + weight_b * similarity_b) / total
    step = float(grid[1] - grid[0]) if len(grid) > 1 else 1.0
    ease = 0.25 * patch_frames / step  # shares ease in and out over a quarter patch (grid steps)
    fallback = fallback_share(similarity, config.fallback_below, ease)
    if np.any(fallback > 0):
        own = interpolate_rows(white_content, grid)  # the content's own whitened latents (G, Z)
        white = (1 - fallback)[:, None] * white + fallback[:, None] * own
        log_rate = (1 - fallback) * log_rate  # the content's own pace where it keeps its action
    # per body part: where the legs do another action than the matched windows (a walk matched against a
    # run or a wave), the legs and the spine keep the content's action and the output its pace
    mismatch = {
        part: part_mismatch(content_actions, library.actions, patches, patch_frames, columns)
        for part, columns in (part_columns or {}).items()
    }
    measures: dict[str, dict[str, FloatArray]] = {}  # per part, each measure's value per patch (P,)
    keep: dict[str, FloatArray] = {}
    other_action: dict[str, FloatArray] = {}

    def on_grid(values: FloatArray, shifted_values: FloatArray) -> FloatArray:
        """(G,) per-patch values of both sequences (P,), (P - 1,), cross-faded as the latents are."""
        return (weight_a * cover_a.values(values) + weight_b * cover_b.values(shifted_values)) / total

    if "legs" in mismatch:
        shifted_mismatch = part_mismatch(content_actions, library.actions, shifted, patch_frames, leg_columns)
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
            part_mismatch(content_actions, library.actions, sequence, patch_frames,
                          leg_columns[leg_columns != TURNING_COLUMN])
            for sequence in (patches, shifted)
        ]  # fmt: skip
        measures["legs"] = {"turning_difference": turning[0], "gait_mismatch": gait[0]}
        share = np.maximum(
            keep_share(on_grid(mismatch["legs"], shifted_mismatch), config.keep_action_above, ease),
            keep_share(on_grid(*turning), config.legs_turning_above, ease),
        )
        keep = {"legs": share, "spine": share}
        other_action["legs"] = keep_share(on_grid(*gait), config.keep_action_above, ease)
        log_rate = (1 - share) * log_rate
    # each arm: where its hand is elsewhere or goes back and forth where the window's does not (or the
    # other way round), it keeps the content's action; the timeline stays the style's
    for part, columns in (part_columns or {}).items():
        if part == "legs":
            continue
        content_hand, library_hand = content_actions[:, columns[:3]], library.actions[:, columns[:3]]
        one_clip = np.zeros(1, dtype=np.int64)
        content_rhythm = _steady_hand_rhythm(content_hand, one_clip, fps)
        library_rhythm = library.derived(
            ("rhythm", tuple(columns[:3].tolist()), fps),
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
        keep[part] = np.max([*shares, end_share(grid, ARM_ENDS_PATCHES * patch_frames)], axis=0)
    # colour with the style's statistics
    coloured = library.stats.colour(white, config.whiten_floor)
    return StyleTrack(
        coloured, log_rate, patches, patch_frames, fallback, mismatch, measures, keep, other_action
    )


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


def side_guard(
    content_actions: FloatArray, library: StyleLibrary, patch_frames: int, part_columns: dict[str, IntArray]
) -> SideGuard | None:
    """The `SideGuard` for a content (actions (T, A)) against a library with mirrored clips, from each arm's
    hand columns (`steps.action.part_channels`); None without mirrored clips or without both arms."""
    if not any(library.mirrored) or not {"left-arm", "right-arm"} <= part_columns.keys():
        return None
    left, right = part_columns["left-arm"][:3], part_columns["right-arm"][:3]

    def library_sides() -> tuple[FloatArray, BoolArray]:
        sides = library.actions[:, left] - library.actions[:, right]  # (N_frames, 3) legs
        total = np.concatenate([np.zeros((1, 3)), np.cumsum(sides, axis=0)])
        num_windows = max(len(sides) - patch_frames + 1, 0)
        windows = (
            total[patch_frames : patch_frames + num_windows] - total[:num_windows]
        ) / patch_frames  # (N, 3)
        clip = np.searchsorted(library.clip_starts, np.arange(num_windows), side="right") - 1
        return windows, np.asarray(library.mirrored, dtype=bool)[clip]

    key = ("sides", tuple(left.tolist()), tuple(right.tolist()), patch_frames)
    windows, mirrored = library.derived(key, library_sides)
    return SideGuard(content_actions[:, left] - content_actions[:, right], windows, mirrored)


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


def keep_share(mismatch: FloatArray, above: float, ease_steps: float, held: bool = False) -> FloatArray:
    """(G,) 0 where a part's mismatch (G,) is at most `above`, rising smoothly to 1 at `KEEP_RAMP` over it,
    eased in and out in time (Gaussian, sigma `ease_steps` grid steps); held: each share first held at its
    running maximum over `ease_steps` either side, so the easing widens a short peak (an arm's mismatch
    that lasts less than a patch, a raise's top against a wave's) instead of flattening it."""
    return _eased((mismatch - above) / KEEP_RAMP, ease_steps, held)


def end_share(grid: FloatArray, span: float) -> FloatArray:
    """(G,) 1 at the grid's (G,) first and last times, easing (smoothstep) to 0 at `span` content frames
    from them."""
    distance = np.minimum(grid - grid[0], grid[-1] - grid) if len(grid) else grid
    x = np.clip(1 - distance / max(span, 1e-9), 0.0, 1.0)
    return x * x * (3 - 2 * x)


def fallback_share(similarity: FloatArray, below: float, ease_steps: float) -> FloatArray:
    """(G,) 0 where the matched windows' similarity (G,) is at least `below`, rising smoothly to 1 at
    `FALLBACK_RAMP` under it, then eased in and out in time (Gaussian, sigma `ease_steps` grid steps)."""
    if below <= -1:
        return np.zeros_like(similarity)
    return _eased((below - similarity) / FALLBACK_RAMP, ease_steps)


def _eased(ramp: FloatArray, ease_steps: float, held: bool = False) -> FloatArray:
    """(G,) a ramp (G,) clipped to [0, 1] through a smoothstep, then eased in and out in time (Gaussian,
    sigma `ease_steps` grid steps), held at its running maximum over `ease_steps` either side first if
    asked."""
    x = np.clip(ramp, 0.0, 1.0)
    x = x * x * (3 - 2 * x)
    if held and len(x):
        reach = int(round(ease_steps))
        x = sliding_window_view(np.pad(x, reach, mode="edge"), 2 * reach + 1).max(axis=-1)
    return np.clip(smooth(x, ease_steps), 0.0, 1.0)


class _Cover(NamedTuple):
    """Where a patch sequence covers a grid (G,): each grid time's patch (an index into the sequence), its
    phase in that patch (0 to 1), and whether any patch covers it."""

    which: IntArray
    phase: FloatArray
    inside: BoolArray

    def values(self, per_patch: FloatArray) -> FloatArray:
        """(G,) each patch's value (P,) at the grid times it covers (0 where none does)."""
        if not len(per_patch):
            return np.zeros(len(self.which))
        return np.where(self.inside, np.asarray(per_patch, dtype=np.float64)[self.which], 0.0)


def _cover(grid: FloatArray, patches: list[Patch]) -> _Cover:
    """Patch i covers content times [start_i - 0.5, start_i + frames_i - 0.5); patches are in content order
    and do not overlap."""
    if not patches:
        return _Cover(
            np.zeros(len(grid), dtype=np.int64), np.zeros_like(grid), np.zeros(len(grid), dtype=bool)
        )
    starts, frames = np.array([(p.content_start, p.content_frames) for p in patches], dtype=np.float64).T
    which = np.clip(np.searchsorted(starts - 0.5, grid, side="right") - 1, 0, len(patches) - 1)  # (G,)
    phase = (grid - starts[which] + 0.5) / frames[which]  # in [0, 1) inside the patch
    inside = (grid >= starts[which] - 0.5) & (grid < starts[which] + frames[which] - 0.5)
    return _Cover(which, phase, inside)


def _patch_sample(
    cover: _Cover, patches: list[Patch], patch_frames: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """For each grid time of a cover (G,): library position, cross-fade weight, log rate and similarity of
    the covering patch (zeros where none does)."""
    if not patches:
        zeros = np.zeros(len(cover.which))
        return zeros, zeros.copy(), zeros.copy(), zeros.copy()
    frames, style_starts, similarities = np.array(
        [(p.content_frames, p.style_start, p.similarity) for p in patches], dtype=np.float64
    ).T  # (P,) each
    which, phase, inside = cover
    frame = phase * patch_frames - 0.5
    position = np.where(inside, style_starts[which] + np.clip(frame, 0, patch_frames - 1), 0.0)
    weight = np.where(inside, np.maximum(1 - np.abs(2 * phase - 1), 1e-3), 0.0)
    log_rate = np.where(inside, np.log(patch_frames / frames[which]), 0.0)
    return position, weight, log_rate, np.where(inside, similarities[which], 0.0)
