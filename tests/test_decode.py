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


@pytest.mark.parametrize(
    ("content_stem", "style_stem"),
    [("wave-right-hand_normal_005", "walk_masculine_005"), ("walk_normal_005", "walk_masculine_005")],
)
def test_a_partial_strength_keeps_the_contents_action_and_plants_the_feet(
    model, dataset_clips, content_stem: str, style_stem: str
) -> None:  # type: ignore[no-untyped-def]
    """Between strength 0 and 1 the output lies between the two ends: a standing wave given a walk's style
    keeps its feet still and waves about as high as at either end (its legs and arm keep the content's
    action at any strength), and a walk's planted feet slide no more than at full strength."""
    from elastyle.eval.metrics import floor_skating_cm_s
    from tests.conftest import clip_named

    content = clip_named(dataset_clips, f"dataset-2_{content_stem}").read()[0]
    style = clip_named(dataset_clips, f"dataset-2_{style_stem}").read()[0]
    skeleton = content.skeleton
    toes, hand = [skeleton.index("Toes_L"), skeleton.index("Toes_R")], skeleton.index("Hand_R")
    ends = {s: transfer(content, style, model=model, strength=s).motion for s in (0.0, 1.0)}
    half = transfer(content, style, model=model, strength=0.5).motion
    if content_stem.startswith("wave"):
        steps = np.linalg.norm(np.diff(half.positions()[:, toes][:, :, [0, 2]], axis=0), axis=-1)
        assert steps.sum() < 5.0  # cm over the clip (at strength 0.5 before: 310)
        peaks = [motion.positions()[:, hand, 1].max() for motion in (ends[0.0], half, ends[1.0])]
        assert peaks[1] >= min(peaks[0], peaks[2]) - 1.0  # cm
    else:
        assert floor_skating_cm_s(half) <= floor_skating_cm_s(ends[1.0]) + 1.0  # cm/s


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
