"""The project's quality benchmark: fixed transfer pairs of held-out dataset walks, scored per method.

Pairs: every held-out take (take % 5 == 0, never seen in training) of a neutral ('normal') walk as
content, against held-out walks of the other styles as style, kept where the two cadences differ by at
least 0.15 steps/s, the first `max_pairs` in name order.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from elastyle.core.motion import Motion
from elastyle.eval.metrics import cadence_steps_s
from elastyle.eval.report import transfer_figures
from elastyle.io.dataset import ClipRef, dataset_label, find_clips
from elastyle.model.file import StyleModel
from elastyle.pipeline import transfer
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import prepare_style

MIN_CADENCE_GAP = 0.15


@dataclass(frozen=True)
class Pair:
    content: ClipRef
    style: ClipRef
    content_motion: Motion
    style_motion: Motion
    content_cadence: float
    style_cadence: float


def benchmark_pairs(data: str, max_pairs: int = 24, holdout_every: int = 5) -> list[Pair]:
    clips = [
        c
        for c in find_clips([data], pattern="*_walk_*")
        if (label := dataset_label(c)) and label[2] % holdout_every == 0
    ]
    contents = [c for c in clips if dataset_label(c)[1] == "normal"]  # type: ignore[index]
    styles = [c for c in clips if dataset_label(c)[1] != "normal"]  # type: ignore[index]
    read = {c.name: c.read()[0] for c in contents + styles}
    cadence = {name: cadence_steps_s(m) for name, m in read.items()}
    pairs = []
    # interleave styles so a small max_pairs still covers every style
    by_style: dict[str, list[ClipRef]] = {}
    for clip in styles:
        by_style.setdefault(dataset_label(clip)[1], []).append(clip)  # type: ignore[index]
    ordered = [c for group in zip(*by_style.values()) for c in group]
    for content in contents:
        for style in ordered:
            if abs(cadence[content.name] - cadence[style.name]) >= MIN_CADENCE_GAP:
                pairs.append(
                    Pair(
                        content,
                        style,
                        read[content.name],
                        read[style.name],
                        cadence[content.name],
                        cadence[style.name],
                    )
                )
    return pairs[:max_pairs]


def score_pairs(pairs: list[Pair], model: StyleModel, config: TransferConfig) -> dict[str, float]:
    """Median timing error, skating and jerk ratio over the pairs, and the mean time per transfer."""
    figures, seconds = [], []
    for pair in pairs:
        library = prepare_style(model, [pair.style_motion], [pair.style.name], config.mirror_style)
        started = time.perf_counter()
        result = transfer(pair.content_motion, library, config, model=model)
        seconds.append(time.perf_counter() - started)
        figures.append(transfer_figures(result.motion, pair.content_motion, pair.style_motion))
    errors = [f["timing_error"] for f in figures]
    return {
        "timing_error_median": float(np.median(errors)),
        "timing_error_mean": float(np.mean(errors)),
        "skating_cm_s": float(np.median([f["skating_output_cm_s"] for f in figures])),
        "jerk_ratio": float(np.median([f["jitter_vs_content"] for f in figures])),
        "seconds_per_transfer": float(np.mean(seconds)),
    }
