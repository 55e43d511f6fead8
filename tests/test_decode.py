"""Decoding: residual decoding returns the content at strength 0 at any frame rate, the report's plain
decoding differs, and a clip the model cannot represent is named in a warning."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from elastyle import Motion, TransferConfig, transfer


def _largest_displacement_cm(a: Motion, b: Motion) -> float:
    assert a.num_frames == b.num_frames
    return float(np.linalg.norm(a.positions() - b.positions(), axis=-1).max())  # the dataset is in cm


@pytest.mark.parametrize("fps", [30.0, 60.0, 24.0])
@pytest.mark.parametrize("timing", ["style", "content"])
def test_strength_zero_returns_the_content(
    model, content: Motion, style_clip: Motion, fps: float, timing: str
) -> None:  # type: ignore[no-untyped-def]
    clip = content.resample(fps)
    out = transfer(clip, style_clip, model=model, strength=0.0, timing=timing).motion  # clean-up on
    assert out.fps == clip.fps
    assert _largest_displacement_cm(out, clip) <= 1e-9  # exact: not merely close


def test_strength_acts_smoothly_from_zero(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    """Strength 0.1 stays near the content, full strength moves it far, 0.5 lies between."""
    config = TransferConfig(method="rigid", cleanup=False)  # the content's timeline, so frames align
    moves = [
        float(np.mean(np.linalg.norm(
            transfer(content, style_clip, config, model=model, strength=s).motion.positions() - content.positions(),
            axis=-1,
        )))
        for s in (0.1, 0.5, 1.0)
    ]  # fmt: skip
    assert moves[0] < moves[1] < moves[2]
    assert moves[0] < 0.25 * moves[2]


def test_plain_decoding_differs_and_is_the_reports(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    plain = transfer(content, style_clip, model=model, decode="plain").motion
    residual = transfer(content, style_clip, model=model).motion
    assert plain.num_frames == residual.num_frames  # the same timeline
    assert _largest_displacement_cm(plain, residual) > 0.5
    # at strength 0, plain decoding gives the content through the model (not the content itself)
    at_zero = transfer(content, style_clip, model=model, decode="plain", strength=0.0, cleanup=False).motion
    assert _largest_displacement_cm(at_zero, content) > 0.1


def _unlike_any_training_clip(motion: Motion) -> Motion:
    """The same walk with both arms twisted far out of any recorded pose."""
    rotations = motion.rotations.copy()
    arms = [j for j, name in enumerate(motion.skeleton.names) if "Arm" in name or "Shoulder" in name]
    rotations[:, arms] += np.array([2.0, 1.0, -1.5])
    return Motion(motion.skeleton, rotations, motion.translations, motion.fps)


def test_warning_names_a_clip_the_model_cannot_represent(
    model, content: Motion, style_clip: Motion, caplog: pytest.LogCaptureFixture
) -> None:  # type: ignore[no-untyped-def]
    with caplog.at_level(logging.WARNING, logger="elastyle"):
        result = transfer(content, style_clip, model=model, content_name="held_out_walk.bvh")
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    threshold = model.metadata.get("reconstruction_warn_cm", 3.0)
    assert result.explain["content_reconstruction_cm"] < threshold
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="elastyle"):
        twisted = transfer(
            _unlike_any_training_clip(content), style_clip, model=model, content_name="twisted.bvh"
        )
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "twisted.bvh" in warnings[0] and "elastyle train" in warnings[0]
    assert twisted.explain["content_reconstruction_cm"] > threshold
