"""The explain record of a transfer: where every output patch's manner came from (`--explain FILE.json`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields
from typing import Any

import numpy as np

from elastyle.steps.config import TransferConfig
from elastyle.steps.library import StyleLibrary
from elastyle.steps.timeline import GRID_STEP
from elastyle.steps.track import StyleTrack, patch_notes
from elastyle.types import FloatArray


def explain(
    tracks: Sequence[StyleTrack],
    libraries: Sequence[StyleLibrary],
    content_time: FloatArray,
    fps: float,
    config: TransferConfig,
) -> dict[str, Any]:
    """Per output patch: its style clip (mirrored or not), start (frames at the model's rate, and seconds),
    stretch factor, similarity, times (the output's on the output's clock: the content's with `--timing
    content`), and how it was used (mode: swap; statistics where the fallback took over; content where the
    legs and spine keep the content's action; blend between them), with per body part the action mismatch
    (the legs' turning difference, gait mismatch and place offset, the spine's lean offset, each arm's hand
    offset and rhythm difference too), the share of the content kept and, for the legs, the share of the style's
    statistics on it; content_time (T_out,) is the content frame of each output frame."""
    styles = []
    notes: list[str] = []  # automatic adjustments, as printed
    for track, library in zip(tracks, libraries):
        rows = []
        for index, patch in enumerate(track.patches):
            clip, frame = library.locate(patch.style_start)
            span = slice(
                int(patch.content_start / GRID_STEP),
                int((patch.content_start + patch.content_frames) / GRID_STEP),
            )
            fallback = _mean(track.fallback[span])
            content_share = _part_share(track, "legs", span, config)
            parts = {
                part: {
                    "mismatch": round(float(mismatch[index]), 3),
                    "content_share": round(_part_share(track, part, span, config), 3),
                }
                | (
                    {
                        "statistics_share": 0.0
                        if part in config.kept_parts  # kept as the content performs it, uncoloured
                        else round(config.kept_statistics * _mean(track.other_action[part][span]), 3)
                    }
                    if part in track.other_action
                    else {}
                )
                for part, mismatch in track.mismatch.items()
            }
            for part, measures in track.measures.items():
                parts[part] |= {name: round(float(values[index]), 3) for name, values in measures.items()}
            # where the patch starts in the output: on its own clock, or the content's (--timing content)
            start_out = (
                patch.content_start / fps
                if config.timing == "content"
                else float(np.searchsorted(content_time, patch.content_start)) / fps
            )
            rows.append(
                {
                    "output_start_s": round(start_out, 4),
                    "content_start_s": round(patch.content_start / fps, 4),
                    "style_clip": library.names[clip],
                    "style_mirrored": library.mirrored[clip],
                    "style_backwards": library.backwards[clip],
                    "style_start_frame": frame,  # frames at model_fps, as the style's clip was read
                    "style_start_s": round(frame / fps, 4),
                    "style_frames": track.patch_frames,
                    "stretch": round(patch.content_frames / track.patch_frames, 4),
                    "similarity": round(patch.similarity, 4),
                    "mode": _mode(fallback, content_share),
                    "statistics_share": round(fallback, 3),
                    "parts": parts,
                }
            )
        entry: dict[str, Any] = {"clips": sorted(set(library.names)), "patches": rows}
        if track.patch_frames:
            entry["patch_s_used"] = round(track.patch_frames / fps, 4)
            notes += [text for _, text in patch_notes(library, track.patch_frames, config, fps)]
        styles.append(entry)
    settings = {field.name: getattr(config, field.name) for field in fields(config)}  # every option
    return {
        **settings,
        "strength": _strength(config),  # a number, or keyframes in content seconds ('SECONDS:VALUE,...')
        "model_fps": fps,
        "model_rate_frames": int(len(content_time)),  # the output's timeline at model_fps
        "styles": styles,
        "notes": notes,
    }


def _strength(config: TransferConfig) -> float | str:
    schedule = config.strength_schedule
    return float(schedule.values[0]) if len(schedule.values) == 1 else schedule.text()


def _part_share(track: StyleTrack, part: str, span: slice, config: TransferConfig) -> float:
    """The share of the content's own action a part keeps over a patch's span of the grid: 1 for a part
    the user keeps (`--keep-part`), else the track's automatic share."""
    if part in config.kept_parts:
        return 1.0
    return _mean(track.keep[part][span]) if part in track.keep else 0.0


def _mean(values: FloatArray) -> float:
    return float(np.mean(values)) if len(values) else 0.0


def _mode(statistics_share: float, content_share: float) -> str:
    """How a patch was used: swap, statistics (the fallback), content (the legs keep the content's
    action) or blend where either is partial."""
    if statistics_share > 0.99:
        return "statistics"
    if content_share > 0.99:
        return "content"
    return "swap" if max(statistics_share, content_share) < 0.01 else "blend"
