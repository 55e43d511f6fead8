"""Autoencoder quality on held-out takes: reconstruct each clip and compare (docs/method.md, "Autoencoder")."""

from __future__ import annotations

import numpy as np

from elastyle.core.motion import Motion
from elastyle.eval.metrics import reconstruction_errors
from elastyle.model.file import StyleModel


def reconstruct(model: StyleModel, motion: Motion, smooth_s: float = 0.0) -> Motion:
    """The clip through the autoencoder, on its own root path, timeline, skeleton and size."""
    sized, factor = model.at_model_size(motion)
    latents, root = model.encode_motion(sized.resample(model.fps))
    decoded = model.features.decode(model.decode_latents(latents, smooth_s), root, model.fps)
    decoded = decoded.resample(motion.fps)
    return Motion(motion.skeleton, decoded.rotations, decoded.translations / factor, motion.fps)


def reconstruction_report(
    model: StyleModel, motions: list[Motion], smooth_s: float = 0.0
) -> dict[str, float]:
    """Mean over clips of the figures of `reconstruction_errors`, with skating as a ratio too."""
    rows = [reconstruction_errors(m, reconstruct(model, m, smooth_s)) for m in motions]
    report = {key: float(np.mean([r[key] for r in rows])) for key in rows[0]}
    report["skating_ratio"] = report["skating_cm_s"] / max(report["original_skating_cm_s"], 1e-9)
    return report
