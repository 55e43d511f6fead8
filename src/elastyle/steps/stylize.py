"""The transfer pipeline (METHOD.md sections 4 and 5): encode, whiten, search, cross-fade, colour, decode.

Every style's result is expressed as a function of the content's time c on a fine grid: its coloured
latents z(c) and its log playback rate log r(c) = log(L / L'(c)) (output frames per content frame).
Strength, transitions and blends are weights over these functions, so the output time map follows the
same weights as the latents: t(c) = integral of exp(sum_k w_k(c) log r_k(c)) dc.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from elastyle.steps.cleanup import adjust_root_speed, clean_feet, detect_contacts
from elastyle.errors import ClipTooShortError, ElastyleError, SkeletonMismatchError
from elastyle.core.mirror import mirror
from elastyle.model.file import StyleModel, load_model
from elastyle.core.motion import Motion
from elastyle.steps.search import Patch, StyleWindows, search_fixed, search_sequential
from elastyle.steps.schedule import Schedule
from elastyle.steps.whiten import LatentStats, adain
from elastyle.types import FloatArray

log = logging.getLogger(__name__)

METHODS = ("elastic", "rigid", "wct", "adain")
PLACEMENTS = ("sequential", "fixed")
TIMINGS = ("style", "content")
GRID_STEP = 0.5  # content frames between evaluations of each style's result
MIN_PATCH_FRAMES = 4


@dataclass(frozen=True)
class TransferConfig:
    """How to transfer. Times are in seconds; frame counts follow the model's frame rate.

    stretch: a content patch may be read from (1 - stretch) L to (1 + stretch) L frames.
    stretch_step_s: spacing of the tried source lengths (the report's 4 frames at 60 fps); 0 = every frame.
    """

    method: str = "elastic"
    placement: str = "sequential"
    patch_s: float = 1.0
    stretch: float = 0.25
    stretch_step_s: float = 4 / 60
    mirror_style: bool = True
    smooth_s: float = 0.0  # Gaussian low-pass of the decoded features, seconds (0 = the report's raw output)
    timing: str = "style"  # "content": warp the result back onto the content's timeline
    cleanup: bool = True  # plant the feet: contacts pinned by two-joint leg IK
    adjust_root: bool = False  # before that, move the root with the stance foot (the path may then drift)

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ElastyleError(f"unknown method {self.method!r}; choose one of {', '.join(METHODS)}")
        if self.placement not in PLACEMENTS:
            raise ElastyleError(
                f"unknown placement {self.placement!r}; choose one of {', '.join(PLACEMENTS)}"
            )
        if self.timing not in TIMINGS:
            raise ElastyleError(f"unknown timing {self.timing!r}; choose one of {', '.join(TIMINGS)}")
        if not 0 <= self.stretch < 1:
            raise ElastyleError(f"stretch must lie in [0, 1), got {self.stretch}")
        if self.patch_s <= 0:
            raise ElastyleError(f"patch length must be positive, got {self.patch_s} s")

    def source_lengths(self, patch_frames: int, fps: float) -> np.ndarray:
        """Candidate source lengths L' (frames) for a patch of L frames."""
        if self.method != "elastic" or self.stretch == 0:
            return np.array([patch_frames])
        low = max(2, int(round((1 - self.stretch) * patch_frames)))
        high = int(round((1 + self.stretch) * patch_frames))
        step = max(1, int(round(self.stretch_step_s * fps)))
        lengths = set(range(patch_frames, low - 1, -step)) | set(range(patch_frames, high + 1, step))
        return np.array(sorted(lengths))


@dataclass(frozen=True, eq=False)
class StyleLibrary:
    """Encoded style clips (with their mirrors): latents (N, Z) end to end, and pooled statistics."""

    names: list[str]
    mirrored: list[bool]
    clip_starts: np.ndarray
    latents: FloatArray
    stats: LatentStats
    _windows: dict[int, StyleWindows] = field(default_factory=dict)

    @cached_property
    def white(self) -> FloatArray:
        """The library's latents (N, Z) whitened with its own pooled statistics."""
        return self.stats.whiten(self.latents)

    def windows(self, patch_frames: int) -> StyleWindows:
        if patch_frames not in self._windows:
            self._windows[patch_frames] = StyleWindows(self.white, self.clip_starts, patch_frames)
        return self._windows[patch_frames]

    def locate(self, library_frame: int) -> tuple[int, int]:
        """(clip index, frame within that clip) of a library frame."""
        clip = int(np.searchsorted(self.clip_starts, library_frame, side="right") - 1)
        return clip, int(library_frame - self.clip_starts[clip])

    @property
    def longest_clip(self) -> int:
        ends = np.append(self.clip_starts[1:], self.latents.shape[0])
        return int(np.max(ends - self.clip_starts))


class TransferResult(NamedTuple):
    motion: Motion
    explain: dict[str, Any]


def prepare_style(
    model: StyleModel,
    motions: Sequence[Motion],
    names: Sequence[str] | None = None,
    mirror_style: bool = True,
) -> StyleLibrary:
    """Encode a style library: every clip, plus its mirror (METHOD.md section 2) when the skeleton allows."""
    names = list(names) if names is not None else [f"style{i}" for i in range(len(motions))]
    clips: list[tuple[str, bool, Motion]] = []
    for name, motion in zip(names, motions):
        model.check_clip(motion, name)
        motion = motion.resample(model.fps)
        clips.append((name, False, motion))
        if mirror_style:
            try:
                clips.append((name, True, mirror(motion)))
            except SkeletonMismatchError:
                log.info("%s: no left/right pairs, style used without its mirror", name)
    latents = [model.encode_motion(m)[0] for _, _, m in clips]
    starts = np.cumsum([0] + [z.shape[0] for z in latents[:-1]])
    return StyleLibrary(
        [c[0] for c in clips], [c[1] for c in clips], starts, np.concatenate(latents), LatentStats.of(latents)
    )


class _StyleTrack(NamedTuple):
    latents: FloatArray  # (G, Z) coloured latents on the content-time grid
    log_rate: FloatArray  # (G,)
    patches: list[Patch]
    patch_frames: int


def _patch_sample(
    grid: FloatArray, patches: list[Patch], patch_frames: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """For each grid time (G,): library position, cross-fade weight and log rate of the covering patch.

    Patch i covers content times [start_i - 0.5, start_i + frames_i - 0.5); patches are in content order
    and do not overlap. Grid times no patch covers get zeros.
    """
    if not patches:
        return np.zeros_like(grid), np.zeros_like(grid), np.zeros_like(grid)
    starts, frames, style_starts = np.array(
        [(p.content_start, p.content_frames, p.style_start) for p in patches], dtype=np.float64
    ).T  # (P,) each
    which = np.clip(np.searchsorted(starts - 0.5, grid, side="right") - 1, 0, len(patches) - 1)  # (G,)
    phase = (grid - starts[which] + 0.5) / frames[which]  # in [0, 1) inside the patch
    inside = (grid >= starts[which] - 0.5) & (grid < starts[which] + frames[which] - 0.5)
    frame = phase * patch_frames - 0.5
    position = np.where(inside, style_starts[which] + np.clip(frame, 0, patch_frames - 1), 0.0)
    weight = np.where(inside, np.maximum(1 - np.abs(2 * phase - 1), 1e-3), 0.0)
    log_rate = np.where(inside, np.log(patch_frames / frames[which]), 0.0)
    return position, weight, log_rate


def _interpolate_rows(values: FloatArray, positions: FloatArray) -> FloatArray:
    """Rows of values (N, Z) at fractional positions (G,), linearly."""
    lower = np.clip(np.floor(positions).astype(np.int64), 0, values.shape[0] - 1)
    upper = np.minimum(lower + 1, values.shape[0] - 1)
    weight = (positions - lower)[:, None]
    return (1 - weight) * values[lower] + weight * values[upper]


def _style_track(
    content_latents: FloatArray, library: StyleLibrary, grid: FloatArray, config: TransferConfig, fps: float
) -> _StyleTrack:
    content_stats = LatentStats.of([content_latents])
    if config.method == "wct":
        coloured = library.stats.colour(content_stats.whiten(content_latents))
        return _StyleTrack(_interpolate_rows(coloured, grid), np.zeros_like(grid), [], 0)
    if config.method == "adain":
        styled = adain(content_latents, [content_latents], [library.latents])
        return _StyleTrack(_interpolate_rows(styled, grid), np.zeros_like(grid), [], 0)
    patch_frames = min(max(int(round(config.patch_s * fps)), MIN_PATCH_FRAMES), library.longest_clip)
    if patch_frames < MIN_PATCH_FRAMES:
        raise ClipTooShortError(
            f"style clips are at most {library.longest_clip} frames; patches need {MIN_PATCH_FRAMES}"
        )
    windows = library.windows(patch_frames)
    white_content = content_stats.whiten(content_latents)
    search = search_sequential if config.placement == "sequential" else search_fixed
    lengths = config.source_lengths(patch_frames, fps)
    patches, shifted = search(white_content, windows, lengths)
    position_a, weight_a, log_rate = _patch_sample(grid, patches, patch_frames)
    position_b, weight_b, _ = _patch_sample(grid, shifted, patch_frames)
    white = (
        weight_a[:, None] * _interpolate_rows(library.white, position_a)
        + weight_b[:, None] * _interpolate_rows(library.white, position_b)
    ) / (weight_a + weight_b)[:, None]
    return _StyleTrack(library.stats.colour(white), log_rate, patches, patch_frames)


def _as_schedule(value: float | str | Schedule, name: str) -> Schedule:
    if isinstance(value, Schedule):
        return value
    if isinstance(value, str):
        return Schedule.parse(value, name)
    return Schedule.parse(str(float(value)), name)


def transfer(
    content: Motion,
    style: Motion | Sequence[Motion] | StyleLibrary,
    model: StyleModel | None = None,
    config: TransferConfig | None = None,
    *,
    strength: float | str | Schedule = 1.0,
    second_style: Motion | Sequence[Motion] | StyleLibrary | None = None,
    second_weight: float | str | Schedule = 0.0,
    style_names: Sequence[str] | None = None,
    second_style_names: Sequence[str] | None = None,
    content_name: str = "content",
) -> TransferResult:
    """Perform `content` in the manner and timing of `style`.

    style: one clip, several clips (one library), or a prepared `StyleLibrary`.
    strength: 0 (content through the autoencoder) to 1 (full style), constant or keyframed (content seconds).
    second_style, second_weight: a second library and its share (0 to 1, keyframed for a transition
        from `style` to `second_style`, constant for a blend).
    Returns the output motion (content's skeleton, content's frame rate) and an explain record.
    """
    model = model or load_model()
    config = config or TransferConfig()
    model.check_clip(content, content_name)
    fps = model.fps
    working = content.resample(fps)
    if working.num_frames < 2:
        raise ClipTooShortError(f"{content_name}: {content.num_frames} frame(s); a transfer needs at least 2")
    libraries = [_as_library(model, style, style_names, config)]
    if second_style is not None:
        libraries.append(_as_library(model, second_style, second_style_names, config))
    content_latents, root = model.encode_motion(working)
    grid = np.arange(0, working.num_frames - 1 + 1e-9, GRID_STEP)  # (G,) content frames
    grid_s = grid / fps
    alpha = _as_schedule(strength, "strength").at(grid_s)
    shares = [np.ones_like(grid)]
    if second_style is not None:
        mix = _as_schedule(second_weight, "second-weight").at(grid_s)
        shares = [1 - mix, mix]
    tracks = [_style_track(content_latents, lib, grid, config, fps) for lib in libraries]
    latents = (1 - alpha)[:, None] * _interpolate_rows(content_latents, grid)
    log_rate = np.zeros_like(grid)
    for track, share in zip(tracks, shares):
        weight = alpha * share
        latents += weight[:, None] * track.latents
        log_rate += weight * track.log_rate
    # output time of each grid point, then the content time of each output frame
    rate = np.exp(log_rate)
    output_time = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(grid))])
    num_output = int(np.floor(output_time[-1] + 1e-6)) + 1
    content_time = np.interp(np.arange(num_output), output_time, grid)  # (T_out,) content frames
    grid_index = np.interp(content_time, grid, np.arange(len(grid)))
    output_latents = _interpolate_rows(latents, grid_index)
    features = model.decode_latents(output_latents, config.smooth_s)
    decoded = model.features.decode(features, root.sample(content_time), fps)
    if config.timing == "content":
        # the style's manner on the content's clock: output frame of each content frame, by the inverse map
        decoded = decoded.sample(
            np.interp(np.arange(working.num_frames), content_time, np.arange(num_output))
        )
    # the content's own skeleton (its offsets and End Sites), so the output drops into the content's rig
    motion = Motion(content.skeleton, decoded.rotations, decoded.translations, fps)
    if config.cleanup:
        contacts = None  # found by clean_feet from its own forward kinematics
        if config.adjust_root:
            contacts = detect_contacts(motion)
            motion = adjust_root_speed(motion, contacts)
        motion = clean_feet(motion, contacts)
    motion = motion.resample(content.fps)
    explain = _explain(tracks, libraries, content_time, fps, config)
    return TransferResult(motion, explain)


def _as_library(
    model: StyleModel,
    style: Motion | Sequence[Motion] | StyleLibrary,
    names: Sequence[str] | None,
    config: TransferConfig,
) -> StyleLibrary:
    if isinstance(style, StyleLibrary):
        return style
    motions = [style] if isinstance(style, Motion) else list(style)
    if not motions:
        raise ElastyleError("no style clips given")
    return prepare_style(model, motions, names, config.mirror_style)


def _explain(
    tracks: list[_StyleTrack],
    libraries: list[StyleLibrary],
    content_time: FloatArray,
    fps: float,
    config: TransferConfig,
) -> dict[str, Any]:
    """Per output patch: its style clip, start frame, stretch factor, similarity and times."""
    styles = []
    for track, library in zip(tracks, libraries):
        rows = []
        for patch in track.patches:
            clip, frame = library.locate(patch.style_start)
            start_out = float(np.searchsorted(content_time, patch.content_start)) / fps
            rows.append(
                {
                    "output_start_s": round(start_out, 4),
                    "content_start_s": round(patch.content_start / fps, 4),
                    "style_clip": library.names[clip],
                    "style_mirrored": library.mirrored[clip],
                    "style_start_frame": frame,
                    "style_frames": track.patch_frames,
                    "stretch": round(patch.content_frames / track.patch_frames, 4),
                    "similarity": round(patch.similarity, 4),
                }
            )
        styles.append({"clips": sorted(set(library.names)), "patches": rows})
    return {
        "method": config.method,
        "placement": config.placement,
        "patch_s": config.patch_s,
        "stretch": config.stretch,
        "model_fps": fps,
        "output_frames": int(len(content_time)),
        "styles": styles,
    }
