"""Decoding on the output's timeline: the report's plain decoding, or residual decoding.

docs/method.md, "Decode". Plain: the output is the decoder's reading of the styled latents, so whatever
the model cannot represent of the content (its reconstruction error) is in every output. Residual: the
output is the content, retimed, composed with the change the style makes to the model's reading of it,

    out(t) = styled(t) . E(t),    E(t) = base(t)^-1 . content(tau(t))      (local joint rotations)
    out(t) = styled(t) + E(t),    E(t) = content(tau(t)) - base(t)          (local joint translations)

where styled = decode(styled latents), base = decode(the content's own latents on the same timeline) and
tau(t) the content time of output frame t. At strength 0 styled = base, so the output is the content
exactly, at the content's own frame rate. Where the style acts, the model's error E of the content is
low-passed (a Gaussian of `residual_smooth_s`, blended in with the strength), so the decoder's frame-to-
frame noise in `base` does not pass into the output while the content's detail does.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.rotations import canonical_log, continuous_log_of_quats, multiply, quat_multiply, to_quat
from elastyle.core.smoothing import smooth
from elastyle.model.features import RootPath
from elastyle.model.file import StyleModel
from elastyle.types import FloatArray


def decode_plain(
    model: StyleModel, latents: Sequence[FloatArray], root: RootPath, smooth_s: float
) -> list[Motion]:
    """The report's decoding: each latent track (T_out, Z) -> features -> a clip on the root path (T_out
    frames). The features of every track go through the per-frame steps as one clip end to end (one pass)."""
    features = np.concatenate([model.decode_latents(track, smooth_s) for track in latents])
    together = model.features.decode(features, root.repeated(len(latents)), model.fps)
    frames = root.num_frames
    return [together.slice(k * frames, (k + 1) * frames) for k in range(len(latents))]


def output_frames(
    content_time: FloatArray, per_model_frame: float, content_frames: int, timing: str
) -> tuple[FloatArray, FloatArray]:
    """Where each output frame at the content's frame rate reads: its position on the model-rate output
    timeline (N,) and its content frame (N,) in the content's own frames.

    content_time: (T_out,) content frame (model rate) of each model-rate output frame, the last at the
    model-rate content's last (`steps.timeline.output_content_times`). per_model_frame: the content's own
    frames per model-rate frame (`Motion.resample_to_end`: the model-rate content ends at the content's
    last frame, so the output's last frame reads it). timing "style": the output keeps its own clock, its
    frames spread evenly over the model-rate timeline; "content": one output frame per content frame (the
    style's manner on the content's clock).
    """
    frames = np.arange(len(content_time), dtype=np.float64)
    last = len(content_time) - 1
    if timing == "content":
        own = np.arange(content_frames, dtype=np.float64)
        return np.interp(own / per_model_frame, content_time, frames), own
    count = max(1, int(round(last * per_model_frame)) + 1)
    positions = np.linspace(0.0, last, count) if count > 1 else np.zeros(1)
    read = np.interp(positions, frames, content_time) * per_model_frame
    return positions, np.minimum(read, content_frames - 1)


def compose_residual(
    styled_at: Motion, base_at: Motion, content_at: Motion, strength: FloatArray, residual_smooth_s: float
) -> Motion:
    """The residual output (N frames at the content's rate): see the module docstring.

    styled_at, base_at: the decoded clips read at the output's N frames (`frames_of` at their positions);
    content_at: the content read at its N frames; strength (N,) in [0, 1]: how far E is low-passed.
    """
    error_rotations = continuous_log_of_quats(
        quat_multiply(to_quat(-base_at.rotations), to_quat(content_at.rotations))
    )  # (N, J, 3)
    error_translations = content_at.translations - base_at.translations  # (N, J, 3)
    sigma = residual_smooth_s * content_at.fps
    keep = (1 - strength)[:, None, None]  # the raw error at strength 0, its low-pass at 1
    low_rotations = smooth(error_rotations, sigma)
    low_translations = smooth(error_translations, sigma)
    error_rotations = low_rotations + keep * (error_rotations - low_rotations)
    error_translations = low_translations + keep * (error_translations - low_translations)
    rotations = multiply(styled_at.rotations, error_rotations)
    translations = styled_at.translations + error_translations
    # at strength 0 the output is the content itself, not its recomposition (exact to the last bit)
    exact = strength <= 0
    rotations[exact] = content_at.rotations[exact]
    translations[exact] = content_at.translations[exact]
    return Motion(content_at.skeleton, rotations, translations, content_at.fps)


def frames_of(motion: Motion, frames: FloatArray) -> Motion:
    """The clip at frames (N,): whole frames taken as they are (the common case: the model's frame rate),
    fractional ones by `Motion.sample`."""
    whole = np.rint(frames)
    if np.array_equal(whole, frames):
        index = np.clip(whole.astype(np.int64), 0, motion.num_frames - 1)
        return Motion(motion.skeleton, motion.rotations[index], motion.translations[index], motion.fps)
    return motion.sample(frames)


def blend_by_strength(before: Motion, after: Motion, strength: FloatArray) -> Motion:
    """Per frame (strength (T,)) or per frame and joint ((T, J)), `before` at strength 0, `after` at 1, and
    between them (rotations by slerp) in between: how a step that follows the style (the foot clean-up)
    fades out towards strength 0, and how body parts keep the content's action."""
    if np.all(strength >= 1):
        return after
    weight = np.clip(strength, 0.0, 1.0)
    weight = np.broadcast_to(weight[:, None] if weight.ndim == 1 else weight, before.rotations.shape[:2])
    rotations = np.where((weight >= 1)[:, :, None], after.rotations, before.rotations)  # (T, J, 3)
    mixed = (weight > 0) & (weight < 1)  # (T, J): only these need the slerp
    if np.any(mixed):
        before_quats = to_quat(before.rotations[mixed])  # (M, 4); its conjugate is the inverse
        inverse = before_quats * np.array([-1.0, -1.0, -1.0, 1.0])
        change = canonical_log(quat_multiply(inverse, to_quat(after.rotations[mixed])))  # (M, 3)
        rotations[mixed] = canonical_log(
            quat_multiply(before_quats, to_quat(weight[mixed][:, None] * change))
        )
    translations = before.translations + weight[:, :, None] * (after.translations - before.translations)
    return Motion(after.skeleton, rotations, translations, after.fps)
