"""`elastyle eval --benchmark`: the project's quality report over fixed held-out transfer pairs.

Pairs come from `elastyle.eval.benchmark.benchmark_pairs` (documented there). Every method is scored
with the figures of one transfer plus style and content recognition by ridge classifiers trained on
the dataset's training takes (take % 5 != 0) and tested on its held-out takes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastyle.eval.benchmark import Pair, benchmark_pairs
from elastyle.eval.classify import RidgeClassifier, describe
from elastyle.eval.report import transfer_figures
from elastyle.io.dataset import dataset_label, find_clips
from elastyle.model.file import StyleModel
from elastyle.pipeline import transfer
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import prepare_style

log = logging.getLogger(__name__)

VARIANTS: dict[str, TransferConfig] = {
    "elastic (sequential)": TransferConfig(),
    "elastic, raw (no foot clean-up)": TransferConfig(cleanup=False),
    "elastic, --timing content": TransferConfig(timing="content"),
    "elastic, fixed placement (report literal)": TransferConfig(placement="fixed"),
    "rigid": TransferConfig(method="rigid"),
    "wct": TransferConfig(method="wct"),
    "adain": TransferConfig(method="adain"),
}


@dataclass(frozen=True, eq=False)
class Classifiers:
    style: RidgeClassifier
    content: RidgeClassifier
    style_accuracy: float
    content_accuracy: float


def train_classifiers(data: str, model: StyleModel, per_class: int = 12) -> Classifiers:
    """Style classifier on walks (7 styles), content classifier on every content (10), both held-out tested."""
    clips = [c for c in find_clips([data]) if dataset_label(c)]
    groups: dict[tuple[str, str, bool], list[Any]] = {}
    for clip in clips:
        content, style, take = dataset_label(clip)  # type: ignore[misc]
        groups.setdefault((content, style, take % 5 == 0), []).append(clip)
    chosen = [c for group in groups.values() for c in group[:per_class]]
    descriptors = {c.name: describe(c.read()[0].resample(model.fps), model.features) for c in chosen}

    def split(held_out: bool, walks_only: bool) -> tuple[np.ndarray, list[str], list[str]]:
        rows = [c for c in chosen if (dataset_label(c)[2] % 5 == 0) == held_out]  # type: ignore[index]
        if walks_only:
            rows = [c for c in rows if dataset_label(c)[0] == "walk"]  # type: ignore[index]
        x = np.array([descriptors[c.name] for c in rows])
        return x, [dataset_label(c)[1] for c in rows], [dataset_label(c)[0] for c in rows]  # type: ignore[index]

    x_walk, styles, _ = split(False, True)
    x_all, _, contents = split(False, False)
    style = RidgeClassifier.fit(x_walk, styles)
    content = RidgeClassifier.fit(x_all, contents)
    x_walk_test, styles_test, _ = split(True, True)
    x_all_test, _, contents_test = split(True, False)
    return Classifiers(
        style, content, style.accuracy(x_walk_test, styles_test), content.accuracy(x_all_test, contents_test)
    )


def run_benchmark(data: str, model: StyleModel, max_pairs: int = 24) -> dict[str, Any]:
    pairs = benchmark_pairs(data, max_pairs)
    classifiers = train_classifiers(data, model)
    rows = []
    for name, config in VARIANTS.items():
        log.info("benchmark: %s", name)
        rows.append({"method": name, **_score(pairs, model, config, classifiers)})
    return {
        "pairs": [{"content": p.content.stem, "style": p.style.stem} for p in pairs],
        "classifier_held_out_accuracy": {
            "style": classifiers.style_accuracy,
            "content": classifiers.content_accuracy,
        },
        "rows": rows,
    }


def _score(
    pairs: list[Pair], model: StyleModel, config: TransferConfig, classifiers: Classifiers
) -> dict[str, float]:
    figures, style_hits, content_hits = [], [], []
    for pair in pairs:
        library = prepare_style(model, [pair.style_motion], [pair.style.name], config.mirror_style)
        output = transfer(pair.content_motion, library, config, model=model).motion
        figures.append(transfer_figures(output, pair.content_motion, pair.style_motion))
        descriptor = describe(output.resample(model.fps), model.features)[None]
        style_hits.append(classifiers.style.predict(descriptor)[0] == dataset_label(pair.style)[1])  # type: ignore[index]
        content_hits.append(classifiers.content.predict(descriptor)[0] == dataset_label(pair.content)[0])  # type: ignore[index]
    return {
        "timing_error_median": float(np.median([f["timing_error"] for f in figures])),
        "skating_cm_s": float(np.median([f["skating_output_cm_s"] for f in figures])),
        "jitter_vs_content": float(np.median([f["jitter_vs_content"] for f in figures])),
        "bone_length_error_cm": float(np.max([f["bone_length_error_cm"] for f in figures])),
        "style_accuracy": float(np.mean(style_hits)),
        "content_accuracy": float(np.mean(content_hits)),
    }


def markdown_table(report: dict[str, Any]) -> str:
    accuracy = report["classifier_held_out_accuracy"]
    lines = [
        f"{len(report['pairs'])} held-out pairs (neutral walk -> other style, cadence gap >= 0.15 steps/s). "
        f"Classifiers' own held-out accuracy: style {accuracy['style']:.2f}, content {accuracy['content']:.2f}.",
        "",
        "| method | timing error (median) | foot skating cm/s | jitter vs content | bone length error cm "
        "| style recognised | content recognised |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in report["rows"]:
        lines.append(
            f"| {row['method']} | {row['timing_error_median']:.2f} | {row['skating_cm_s']:.1f} | "
            f"{row['jitter_vs_content']:.2f} | {row['bone_length_error_cm']:.4f} | {row['style_accuracy']:.2f} | "
            f"{row['content_accuracy']:.2f} |"
        )
    return "\n".join(lines) + "\n"
