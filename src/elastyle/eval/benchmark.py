"""The project's quality benchmark: fixed transfer pairs of held-out dataset clips in three sets, scored per method.

Every clip is a held-out take (take % 5 == 0, never seen in training); content is always a neutral
('normal') take, style a take in another style; within a set, styles are interleaved so a few pairs still
cover every style, and pairs are taken in name order up to `max_pairs` per set.

    walk     a walk as content, a walk as style, kept where the two cadences differ by at least 0.15 steps/s
    gesture  a standing gesture (a wave or a raise-up) as content, the same gesture as style
    cross    content and style of different content types: every other content type given a walk's style
             (what a user with one walk clip does to a whole library), and a walk given each other type's
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


SETS = ("walk", "gesture", "cross")
GESTURES = ("wave", "raise-up")  # content types that stand and move the arms start with these


def benchmark_pairs(data: str, max_pairs: int = 24) -> dict[str, list[Pair]]:
    """The pairs of each set (see the module docstring), at most `max_pairs` each."""
    clips = labelled_clips(find_clips([data]), held_out=True)
    contents: dict[str, list[ClipRef]] = {}
    styles: dict[str, dict[str, list[ClipRef]]] = {}  # content type -> style -> clips
    for clip, label in clips:
        if label.style == "normal":
            contents.setdefault(label.content, []).append(clip)
        else:
            styles.setdefault(label.content, {}).setdefault(label.style, []).append(clip)

    def interleaved(kind: str) -> list[ClipRef]:
        by_style = styles.get(kind, {})
        return [c for group in zip(*by_style.values()) for c in group]

    gestures = [kind for kind in sorted(contents) if kind.startswith(GESTURES)]
    others = [kind for kind in sorted(contents) if kind != "walk"]
    candidates = {
        "walk": [(c, s) for c in contents.get("walk", []) for s in interleaved("walk")],
        "gesture": _alternate([[(c, s) for c in contents[k] for s in interleaved(k)] for k in gestures]),
        "cross": _alternate(
            [[(c, s) for c in contents[k] for s in interleaved("walk")] for k in others]
            + [[(c, s) for c in contents.get("walk", []) for s in interleaved(k)] for k in others]
        ),
    }
    motions: dict[str, Motion] = {}
    cadences: dict[str, float] = {}

    def pair(content: ClipRef, style: ClipRef) -> Pair:
        for clip in (content, style):
            if clip.name not in motions:
                motions[clip.name] = clip.read()[0]
                cadences[clip.name] = cadence_steps_s(motions[clip.name])
        return Pair(content, style, motions[content.name], motions[style.name], cadences[content.name],
                    cadences[style.name])  # fmt: skip

    sets: dict[str, list[Pair]] = {}
    for name in SETS:
        chosen: list[Pair] = []
        for content, style in candidates[name]:
            if len(chosen) == max_pairs:
                break
            candidate = pair(content, style)
            if name != "walk" or abs(candidate.content_cadence - candidate.style_cadence) >= MIN_CADENCE_GAP:
                chosen.append(candidate)
        sets[name] = chosen
    return sets


def _alternate(groups: list[list[tuple[ClipRef, ClipRef]]]) -> list[tuple[ClipRef, ClipRef]]:
    """One item of each group in turn (then the next of each), so a few pairs cover every group."""
    merged = []
    for index in range(max((len(g) for g in groups), default=0)):
        merged += [group[index] for group in groups if index < len(group)]
    return merged


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
        output = transfer(
            pair.content_motion, library, config, model=model, content_name=pair.content.name
        ).motion
        seconds.append(time.perf_counter() - started)
        figures.append(transfer_figures(output, pair.content_motion, pair.style_motion))
        if recognisers is not None:
            style_hit, content_hit = recognisers.recognised(output, pair.style, pair.content)
            style_hits.append(style_hit)
            content_hits.append(content_hit)
    # defined where both inputs step and their cadences differ by at least MIN_CADENCE_GAP
    errors = [
        f["timing_error"] if abs(p.content_cadence - p.style_cadence) >= MIN_CADENCE_GAP else np.nan
        for f, p in zip(figures, pairs)
    ]
    defined = [e for e in errors if np.isfinite(e)]
    scores = {
        "timing_error_median": float(np.median(defined)) if defined else float("nan"),
        "timing_error_mean": float(np.mean(defined)) if defined else float("nan"),
        "skating_cm_s": float(np.nanmedian([f["skating_output_cm_s"] for f in figures])),
        "skating_own_contacts_cm_s": float(
            np.nanmedian([f["skating_own_contacts_output_cm_s"] for f in figures])
        ),
        "jitter_vs_content": float(np.nanmedian([f["jitter_vs_content"] for f in figures])),
        "bone_length_error_cm": float(np.max([f["bone_length_error_cm"] for f in figures])),
        "seconds_per_transfer": float(np.mean(seconds)),
    }
    if recognisers is not None:
        scores["style_accuracy"] = float(np.mean(style_hits))
        scores["content_accuracy"] = float(np.mean(content_hits))
    return scores
