"""The project's quality benchmark: fixed transfer pairs of held-out dataset walks, scored per method.

Pairs: every held-out take (take % 5 == 0, never seen in training) of a neutral ('normal') walk as
content, against held-out walks of the other styles as style, kept where the two cadences differ by at
least 0.15 steps/s, the first `max_pairs` in name order.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from elastyle.core.motion import Motion
from elastyle.eval.metrics import cadence_steps_s
from elastyle.eval.report import transfer_figures
from elastyle.io.dataset import ClipRef, find_clips, labelled_clips
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


def benchmark_pairs(data: str, max_pairs: int = 24) -> list[Pair]:
    clips = labelled_clips(find_clips([data], pattern="*_walk_*"), held_out=True)
    contents = [clip for clip, label in clips if label.style == "normal"]
    styles = [(clip, label) for clip, label in clips if label.style != "normal"]
    read = {c.name: c.read()[0] for c in contents + [clip for clip, _ in styles]}
    cadence = {name: cadence_steps_s(m) for name, m in read.items()}
    pairs = []
    # interleave styles so a small max_pairs still covers every style
    by_style: dict[str, list[ClipRef]] = {}
    for clip, label in styles:
        by_style.setdefault(label.style, []).append(clip)
    ordered = [c for group in zip(*by_style.values()) for c in group]
    for content in contents:
        for style in ordered:
            if abs(cadence[content.name] - cadence[style.name]) >= MIN_CADENCE_GAP:
                pairs.append(
                    Pair(
                        content, style, read[content.name], read[style.name], cadence[content.name],
                        cadence[style.name],
                    )
                )  # fmt: skip
    return pairs[:max_pairs]


class Recognisers(Protocol):
    """Style and content classifiers of clip descriptors (`elastyle.eval.suite.Classifiers`)."""

    def recognised(self, output: Motion, style: ClipRef, content: ClipRef) -> tuple[bool, bool]: ...


def score_pairs(
    pairs: list[Pair], model: StyleModel, config: TransferConfig, recognisers: Recognisers | None = None
) -> dict[str, float]:
    """Medians over the pairs of timing error, skating and jitter, the largest bone length error, the mean
    time per transfer, and with `recognisers` the share of outputs recognised as the style and the content."""
    figures, seconds, style_hits, content_hits = [], [], [], []
    for pair in pairs:
        library = prepare_style(model, [pair.style_motion], [pair.style.name], config.mirror_style)
        started = time.perf_counter()
        output = transfer(pair.content_motion, library, config, model=model).motion
        seconds.append(time.perf_counter() - started)
        figures.append(transfer_figures(output, pair.content_motion, pair.style_motion))
        if recognisers is not None:
            style_hit, content_hit = recognisers.recognised(output, pair.style, pair.content)
            style_hits.append(style_hit)
            content_hits.append(content_hit)
    errors = [f["timing_error"] for f in figures]
    scores = {
        "timing_error_median": float(np.median(errors)),
        "timing_error_mean": float(np.mean(errors)),
        "skating_cm_s": float(np.median([f["skating_output_cm_s"] for f in figures])),
        "skating_own_contacts_cm_s": float(
            np.median([f["skating_own_contacts_output_cm_s"] for f in figures])
        ),
        "jitter_vs_content": float(np.median([f["jitter_vs_content"] for f in figures])),
        "bone_length_error_cm": float(np.max([f["bone_length_error_cm"] for f in figures])),
        "seconds_per_transfer": float(np.mean(seconds)),
    }
    if recognisers is not None:
        scores["style_accuracy"] = float(np.mean(style_hits))
        scores["content_accuracy"] = float(np.mean(content_hits))
    return scores
