"""`elastyle eval --benchmark`: the project's quality report over fixed held-out transfer pairs.

Pairs come from `elastyle.eval.benchmark.benchmark_pairs` (walk, gesture and cross sets, documented
there). Every method is scored per set with the figures of one transfer plus style and content
recognition by ridge classifiers trained on the dataset's training takes (take % 5 != 0) of every content
type and tested on its held-out takes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastyle.core.motion import Motion
from elastyle.errors import DatasetError
from elastyle.eval.benchmark import benchmark_pairs, score_pairs
from elastyle.eval.classify import RidgeClassifier, describe
from elastyle.io.dataset import (
    LABELLED_NAME_TEXT,
    ClipRef,
    DatasetLabel,
    dataset_label,
    find_clips,
    is_held_out,
    labelled_clips,
)
from elastyle.model.file import StyleModel
from elastyle.steps.config import TransferConfig

log = logging.getLogger(__name__)

VARIANTS: dict[str, TransferConfig] = {
    "elastic (sequential)": TransferConfig(),
    "elastic, raw (no foot clean-up)": TransferConfig(cleanup=False),
    # the report's swap for the legs and spine: none kept for their action, their place or a lean
    "elastic, swap everywhere (--keep-action-above 2 --legs-place-above 9 --spine-lean-above 9)": TransferConfig(
        keep_action_above=2.0, legs_place_above=9.0, spine_lean_above=9.0
    ),
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
    model: StyleModel  # descriptors are taken on its joints (`described`), at its frame rate

    def recognised(self, output: Motion, style: ClipRef, content: ClipRef) -> tuple[bool, bool]:
        """Whether `output` is classified as the style clip's style, and as the content clip's content."""
        descriptor = described(output, self.model)[None]
        style_label, content_label = _label(style), _label(content)
        return (
            self.style.predict(descriptor)[0] == style_label.style,
            self.content.predict(descriptor)[0] == content_label.content,
        )


def _label(clip: ClipRef) -> DatasetLabel:
    label = dataset_label(clip)
    if label is None:
        raise ValueError(f"{clip.name}: not a dataset clip name")
    return label


def train_classifiers(data: str, model: StyleModel, per_class: int = 12) -> Classifiers:
    """Style (7) and content (10) classifiers on every content type and style, both held-out tested."""
    groups: dict[tuple[str, str, bool], list[tuple[ClipRef, DatasetLabel]]] = {}
    for clip, label in labelled_clips(find_clips([data])):
        groups.setdefault((label.content, label.style, is_held_out(clip)), []).append((clip, label))
    chosen = [item for group in groups.values() for item in group[:per_class]]
    descriptors = {c.name: described(c.read()[0], model) for c, _ in chosen}

    def split(held_out: bool) -> tuple[np.ndarray, list[str], list[str]]:
        rows = [(c, label) for c, label in chosen if is_held_out(c) == held_out]
        x = np.array([descriptors[c.name] for c, _ in rows])
        return x, [label.style for _, label in rows], [label.content for _, label in rows]

    x_train, styles, contents = split(False)
    x_test, styles_test, contents_test = split(True)
    if len(set(styles)) < 2 or len(set(contents)) < 2 or not len(x_test):
        raise DatasetError(
            f"{data}: the benchmark's classifiers need training takes (take % 5 != 0) of at least two styles "
            f"and two content types, and held-out takes (% 5 == 0), in files named {LABELLED_NAME_TEXT}; found "
            f"{len(x_train)} training clips of {len(set(styles))} style(s) and {len(set(contents))} content "
            f"type(s), {len(x_test)} held-out"
        )
    style, content = RidgeClassifier.fit(x_train, styles), RidgeClassifier.fit(x_train, contents)
    return Classifiers(
        style, content, style.accuracy(x_test, styles_test), content.accuracy(x_test, contents_test),
        model,
    )  # fmt: skip


def described(motion: Motion, model: StyleModel) -> np.ndarray:
    """A clip's descriptor (`eval.classify.describe`) on the model's joints (`StyleModel.on_model_hierarchy`:
    a clip of another export of the model's rig too) at the model's frame rate."""
    return describe(model.on_model_hierarchy(motion).resample(model.fps), model.features)


class _SaidOnce(logging.Filter):
    """Lets each note or warning through the first time its text comes."""

    def __init__(self) -> None:
        super().__init__()
        self.said: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        text = record.getMessage()
        if text in self.said:
            return False
        self.said.add(text)
        return True


def run_benchmark(data: str, model: StyleModel, max_pairs: int = 24) -> dict[str, Any]:
    """Every method of `VARIANTS` on every set's pairs (at most `max_pairs` each)."""
    sets = benchmark_pairs(data, max_pairs)
    for pair in (p for pairs in sets.values() for p in pairs):  # one line naming a clip the model cannot read
        model.check_clip(pair.content_motion, pair.content.name)
        break
    classifiers = train_classifiers(data, model)
    rows = []
    # each method transfers the same pairs: a clip's note is printed once, not per method (each handler its own)
    handlers = [
        (h, _SaidOnce()) for h in {*logging.getLogger().handlers, *logging.getLogger("elastyle").handlers}
    ]
    for handler, said in handlers:
        handler.addFilter(said)
    try:
        for name, config in VARIANTS.items():
            for set_name, pairs in sets.items():
                log.info("benchmark: %s, %s", name, set_name)
                scores = score_pairs(pairs, model, config, classifiers) if pairs else {}
                rows.append({"method": name, "set": set_name, "pairs": len(pairs), **scores})
    finally:
        for handler, said in handlers:
            handler.removeFilter(said)
    return {
        "pairs": {
            name: [{"content": p.content.stem, "style": p.style.stem} for p in pairs]
            for name, pairs in sets.items()
        },
        "classifier_held_out_accuracy": {
            "style": classifiers.style_accuracy,
            "content": classifiers.content_accuracy,
        },
        "rows": rows,
    }


def markdown_table(report: dict[str, Any]) -> str:
    accuracy = report["classifier_held_out_accuracy"]
    counts = ", ".join(f"{name} {len(pairs)}" for name, pairs in report["pairs"].items())
    lines = [
        f"Held-out pairs per set: {counts} (walk: neutral walk -> a walk in another style, cadence gap >= "
        "0.15 steps/s; gesture: a neutral wave or raise-up -> the same gesture in another style; cross: "
        "content and style of different content types). Timing error where both inputs step and their "
        f"cadences differ by >= 0.15 steps/s. Classifiers' own held-out accuracy: style {accuracy['style']:.2f}, "
        f"content {accuracy['content']:.2f}.",
        "",
        "| method | set | timing error (median) | foot skating cm/s (floor) | (own contacts) | jitter vs content "
        "| bone length error cm | style recognised | content recognised |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in report["rows"]:
        if not row["pairs"]:
            continue
        lines.append(
            f"| {row['method']} | {row['set']} | {_figure(row['timing_error_median'])} | {row['skating_cm_s']:.1f} | "
            f"{row['skating_own_contacts_cm_s']:.1f} | "
            f"{row['jitter_vs_content']:.2f} | {row['bone_length_error_cm']:.4f} | {row['style_accuracy']:.2f} | "
            f"{row['content_accuracy']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def _figure(value: float) -> str:
    """A median as the table prints it: '-' where it is not defined (no pair steps)."""
    return "-" if not np.isfinite(value) else f"{value:.2f}"
