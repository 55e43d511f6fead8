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

from elastyle.core.resample import interpolate_rows
from elastyle.errors import ClipTooShortError
from elastyle.steps.action import ActionLayout
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import StyleLibrary, match_frames
from elastyle.steps.part_action import eased, part_keeps
from elastyle.steps.search import (
    Patch,
    SideGuard,
    StyleWindows,
    half_shifted,
    search_fixed,
    search_sequential,
)
from elastyle.steps.tempo import cadence_tempo, searched_about_tempo
from elastyle.steps.whiten import LatentStats, adain
from elastyle.types import BoolArray, FloatArray, IntArray

log = logging.getLogger(__name__)
MIN_PATCH_FRAMES = 4
# patches shortened below this share of --patch-s get a warning, not a note: a walk given 10 to 24 frames of
# an active walk (less than a stride) skated 4 to 38 cm/s after the clean-up, given 29 to 45 frames 2 to 7
SHORT_PATCH_SHARE = 0.9
FALLBACK_RAMP = (
    0.15  # the fallback to statistics rises from 0 to 1 over this much similarity below its threshold
)


class StyleTrack(NamedTuple):
    """latents (G, Z) coloured, on the content-time grid; log_rate (G,); the matched patches (empty for
    the statistics-only methods) and their length L in frames; fallback (G,), 0 to 1, the share of the
    style's statistics alone where no style window matched well (1 for the statistics-only methods);
    mismatch: per body part, each patch's action mismatch (P,) (`part_mismatch`); measures: per body
    part, each patch's other measures of what it does (the legs' turning difference, rad/s; each arm's hand
    offset and rhythm difference, `steps.arms`); keep: per body part (G,), 0 to 1, the share of the
    content's own action where the matched windows do another; other_action: per body part (G,), 0 to 1,
    where it keeps the content's action because the windows perform another (the legs: travel and steps,
    not turning), so the style's statistics colour it (`TransferConfig.kept_statistics`); posture: per body
    part (G,), 0 to 1, the weight of each time in the style's mean posture that part takes where it keeps
    the content's action (`steps.keep`)."""

    latents: FloatArray
    log_rate: FloatArray
    patches: list[Patch]
    patch_frames: int
    fallback: FloatArray
    mismatch: dict[str, FloatArray]
    measures: dict[str, dict[str, FloatArray]]
    keep: dict[str, FloatArray]
    other_action: dict[str, FloatArray]
    posture: dict[str, FloatArray]


def requested_patch_frames(config: TransferConfig, fps: float) -> int:
    """The patch length L (frames at the model's rate) that `--patch-s` asks for."""
    return max(int(round(config.patch_s * fps)), MIN_PATCH_FRAMES)


def patch_notes(
    library: StyleLibrary, patch_frames: int, config: TransferConfig, fps: float
) -> list[tuple[int, str]]:
    """The notes (logging level, text) on a library's patches of `patch_frames`: patches shortened to its
    longest clip (a warning below `SHORT_PATCH_SHARE` of --patch-s and below a default patch, where the
    output may step or slide), and clips shorter than a patch, none of whose windows can be matched."""
    notes = []
    names = ", ".join(dict.fromkeys(library.names))
    if patch_frames < requested_patch_frames(config, fps):
        shortened = (
            f"{names}: the style clips are at most {patch_frames / fps:.2f} s long, so patches are "
            f"{patch_frames / fps:.2f} s instead of --patch-s {config.patch_s:g}"
        )
        # short of what was asked, and short of a default patch (13 s of a 60 s one are no short window), by
        # the same share (a 28-frame clip: a note under --patch-s 1, and under 2 as well)
        asked = min(requested_patch_frames(config, fps), requested_patch_frames(TransferConfig(), fps))
        if patch_frames < SHORT_PATCH_SHARE * asked:
            notes.append((logging.WARNING, (
                f"warning: {shortened}; windows this short carry little of a style's manner and the output may "
                "step or slide oddly: give a style clip at least as long as --patch-s"
            )))  # fmt: skip
        else:
            notes.append((logging.INFO, f"note: {shortened}"))
    lengths = np.diff(np.append(library.clip_starts, library.latents.shape[0]))  # (K,) frames
    short = list(dict.fromkeys(n for n, length in zip(library.names, lengths) if length < patch_frames))
    if short:
        notes.append((logging.WARNING, (
            f"note: {', '.join(short)}: shorter than a patch ({patch_frames / fps:.2f} s), so none of its windows "
            "is matched; it adds only to the style's statistics"
        )))  # fmt: skip
    sided = {
        name: side for name, side, mirrored in zip(library.names, library.sided, library.mirrored)
        if side is not None and mirrored
    }  # fmt: skip
    for name, (joint, degrees) in sided.items():
        notes.append((logging.INFO, (
            f"note: {name}: its manner is held to one side (its {joint} {degrees:.0f} degrees from its mirror's), so "
            "its mirror is taken only where it matches clearly better (a hand or a turn the other way); "
            "--no-mirror-style leaves the mirror out"
        )))  # fmt: skip
    return notes


def style_track(
    content_latents: FloatArray,
    content_actions: FloatArray,
    library: StyleLibrary,
    grid: FloatArray,
    config: TransferConfig,
    fps: float,
    layout: ActionLayout | None = None,
    still: BoolArray | None = None,
) -> StyleTrack:
    """The track of one library for content latents (T, Z) and action descriptors (T, A) on grid times
    (G,) in content frames; layout: the action descriptors' columns (`steps.action`; None: no parts); still:
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
            interpolate_rows(styled, grid), unchanged, [], 0, np.ones_like(grid), {}, {}, {}, {}, {}
        )
    wanted = requested_patch_frames(config, fps)
    patch_frames = min(wanted, library.longest_clip)
    if patch_frames < MIN_PATCH_FRAMES:
        names = ", ".join(dict.fromkeys(library.names))
        raise ClipTooShortError(
            f"{names}: too short for a patch ({library.longest_clip} frame(s) at {fps:g} fps at most; patches "
            f"need at least {MIN_PATCH_FRAMES})"
        )
    for level, text in patch_notes(library, patch_frames, config, fps):
        log.log(level, "%s", text)
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
    about_tempo = config.stretch_centre == "tempo" and config.placement == "sequential"
    # where both step, the first search about the ratio of their cadences (a pace beyond the first range)
    tempo = (
        cadence_tempo(content_actions, library, layout, config, patch_frames, fps)
        if about_tempo and layout
        else 1.0
    )
    lengths = config.source_lengths(patch_frames, fps, tempo)
    guard = side_guard(content_actions, library, patch_frames, layout)
    patches = search(content_frames, windows, lengths, guard)
    if about_tempo:  # a pace beyond the first range, read from the patches that step alike
        patches = searched_about_tempo(
            partial(search, content_frames, windows, guard=guard), patches, content_actions, library.actions,
            config, patch_frames, fps, np.zeros(0, np.int64) if layout is None else layout.legs, tempo,
        )  # fmt: skip
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

    # per body part: where it does another action than the matched windows (legs: a walk matched against a
    # run or a wave; an arm: a raise against a wave), it keeps the content's action; legs of another gait or
    # place keep the content's pace too (turning steps take the style's)
    def on_grid(values: FloatArray, shifted_values: FloatArray) -> FloatArray:
        """(G,) per-patch values of both sequences (P,), (P - 1,), cross-faded as the latents are."""
        return (weight_a * cover_a.values(values) + weight_b * cover_b.values(shifted_values)) / total

    parts = part_keeps(
        content_actions, library, (patches, shifted), patch_frames, layout, config, fps, on_grid,
        grid, ease,
    )  # fmt: skip
    log_rate = (1 - parts.own_pace) * log_rate
    # colour with the style's statistics
    coloured = library.stats.colour(white, config.whiten_floor)
    return StyleTrack(
        coloured, log_rate, patches, patch_frames, fallback, parts.mismatch, parts.measures, parts.keep,
        parts.other_action, parts.posture,
    )  # fmt: skip


def side_guard(
    content_actions: FloatArray, library: StyleLibrary, patch_frames: int, layout: ActionLayout | None
) -> SideGuard | None:
    """The `SideGuard` for a content (actions (T, A), their `ActionLayout`) against a library with mirrored
    clips, from each arm's hand place; None without mirrored clips, a layout or both arms."""
    hands = {} if layout is None else layout.arm_hands
    if not any(library.mirrored) or not {"left-arm", "right-arm"} <= hands.keys():
        return None
    left, right = hands["left-arm"], hands["right-arm"]

    def library_sides() -> tuple[FloatArray, BoolArray]:
        sides = library.actions[:, left] - library.actions[:, right]  # (N_frames, 3) legs
        total = np.concatenate([np.zeros((1, 3)), np.cumsum(sides, axis=0)])
        num_windows = max(len(sides) - patch_frames + 1, 0)
        windows = (
            total[patch_frames : patch_frames + num_windows] - total[:num_windows]
        ) / patch_frames  # (N, 3)
        clip = library.clip_of(np.arange(num_windows))
        return windows, np.asarray(library.mirrored, dtype=bool)[clip]

    key = ("sides", tuple(left.tolist()), tuple(right.tolist()), patch_frames)
    windows, mirrored = library.derived(key, library_sides)
    return SideGuard(content_actions[:, left] - content_actions[:, right], windows, mirrored)


def fallback_share(similarity: FloatArray, below: float, ease_steps: float) -> FloatArray:
    """(G,) 0 where the matched windows' similarity (G,) is at least `below`, rising smoothly to 1 at
    `FALLBACK_RAMP` under it, then eased in and out in time (Gaussian, sigma `ease_steps` grid steps)."""
    if below <= -1:
        return np.zeros_like(similarity)
    return eased((below - similarity) / FALLBACK_RAMP, ease_steps)


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
