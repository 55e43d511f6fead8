"""Knowing when the model is out of its depth: how well it reconstructs a clip, against held-out takes.

A transfer can show no more of a motion than the model can represent. The model file records what it
reaches on its held-out takes (`calibrate`, run at the end of training); a clip reconstructed far worse
than that (`WARN_FACTOR` times the held-out 95th percentile, and at least `WARN_FLOOR_CM`) gets a one-line
warning naming it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from elastyle.core.body import centimetres_per_unit
from elastyle.core.ground import ground_level, has_feet
from elastyle.core.motion import Motion
from elastyle.model.features import RootPath
from elastyle.model.file import StyleModel
from elastyle.types import FloatArray

WARN_FACTOR = 2.0  # warn above this many times the held-out 95th percentile of the reconstruction error
# ... and never below this: a model that draws its own takes to a few millimetres would otherwise warn about
# clips it draws to under a centimetre (a new performer of a motion it knows), which no viewer would see
WARN_FLOOR_CM = 1.0
DEFAULT_WARN_CM = 3.0  # for model files written before calibration was recorded


EVERY_FRAMES = 3  # the error is measured on every third frame: the same figure for a third of the cost


def reconstruction_error_cm(
    model: StyleModel,
    motion: Motion,
    latents: FloatArray,
    root: RootPath,
    positions: FloatArray | None = None,
) -> float:
    """Mean joint position error (cm, relative to the pelvis) of a clip at the model's frame rate (T frames)
    read back from its own latents (T, Z) on its own root path, over every `EVERY_FRAMES`-th frame.
    positions: the clip's world positions (T, J, 3) (`Motion.positions`), when already known."""
    frames = np.arange(0, motion.num_frames, EVERY_FRAMES)
    features = model.decode_latents(latents, frames=frames)
    decoded = model.features.decode(features, root.sample(frames.astype(np.float64)), model.fps)
    pelvis = motion.skeleton.pelvis
    if positions is None:
        sampled = Motion(motion.skeleton, motion.rotations[frames], motion.translations[frames], motion.fps)
        ours = sampled.positions()
    else:
        ours = positions[frames]
    theirs = decoded.positions()
    error = (theirs - theirs[:, pelvis : pelvis + 1]) - (ours - ours[:, pelvis : pelvis + 1])
    return float(np.sqrt(np.sum(error**2, axis=-1)).mean() * centimetres_per_unit(motion.skeleton))


def clip_depth(model: StyleModel, motion: Motion, name: str) -> tuple[float, str | None]:
    """A clip's reconstruction error (cm) and, when it is far above the held-out takes', the warning."""
    sized = model.at_model_size(model.on_model_hierarchy(motion))[0]
    working = model.on_model_floor(sized).resample(model.fps)
    latents, root = model.encode_motion(working)
    error = reconstruction_error_cm(model, working, latents, root)
    return error, depth_warning(model, error, name)


def calibrate(model: StyleModel, held_out: Sequence[Motion]) -> dict[str, Any]:
    """Held-out figures for the model's metadata: the toes' ground level its takes stand on (model units,
    the median over clips with toes; `StyleModel.ground`), and the reconstruction error's median and 95th
    percentile (cm) on that floor with the warning threshold derived from them."""
    sized = [model.at_model_size(model.on_model_hierarchy(motion))[0] for motion in held_out]
    grounds = [ground_level(motion) for motion in sized if has_feet(motion)]
    figures: dict[str, Any] = {"ground": round(float(np.median(grounds)), 4)} if grounds else {}
    floored = replace(model, metadata={**model.metadata, **figures})
    errors = [clip_depth(floored, motion, "held-out take")[0] for motion in held_out]
    if not errors:
        return figures
    p95 = float(np.percentile(errors, 95))
    return {
        **figures,
        "held_out_joint_error_cm": {"median": round(float(np.median(errors)), 3), "p95": round(p95, 3)},
        "reconstruction_warn_cm": round(max(WARN_FACTOR * p95, WARN_FLOOR_CM), 2),
    }


def depth_warning(model: StyleModel, error_cm: float, name: str) -> str | None:
    """The warning for a clip reconstructed with `error_cm`, or None when the model represents it well."""
    calibrated = "reconstruction_warn_cm" in model.metadata
    threshold = float(model.metadata.get("reconstruction_warn_cm", DEFAULT_WARN_CM))
    if error_cm <= threshold:
        return None
    basis = (
        f", {WARN_FACTOR:g} times what it reaches on 95 % of its held-out takes and at least {WARN_FLOOR_CM:g} cm"
        if calibrated
        else ""
    )
    return (
        f"warning: {name}: the model reproduces this clip with {error_cm:.1f} cm mean joint error (warning "
        f"above {threshold:.1f} cm{basis}): it has not learnt motions like it, so the output will not show "
        "them faithfully; train a model that includes such clips with `elastyle train` and pass it with --model"
    )
