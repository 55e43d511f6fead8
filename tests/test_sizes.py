"""Clips of another length unit or another body size: transferred at the model's size, written at their own."""

from __future__ import annotations

import numpy as np
import pytest

from elastyle import Motion
from elastyle.eval.report import transfer_figures
from elastyle.model.depth import clip_depth
from elastyle.pipeline import transfer


@pytest.mark.slow
def test_clips_in_metres_transfer_as_in_centimetres(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    in_cm = transfer(content, style_clip, model=model).motion
    in_m = transfer(content.scaled(0.01), style_clip.scaled(0.01), model=model).motion
    assert np.array_equal(
        in_m.skeleton.offsets, content.scaled(0.01).skeleton.offsets
    )  # the content's own skeleton
    assert np.abs(in_m.positions() * 100 - in_cm.positions()).max() < 1e-6  # cm
    figures = transfer_figures(in_m, content, style_clip)  # eval: each clip in its own unit
    assert figures["bone_length_error_cm"] < 1e-6
    assert figures["jitter_vs_content"] == pytest.approx(
        transfer_figures(in_cm, content, style_clip)["jitter_vs_content"]
    )


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.01, 0.85, 1.15])
def test_another_size_is_read_as_well_as_the_models_own(model, content: Motion, factor: float) -> None:  # type: ignore[no-untyped-def]
    own, warning = clip_depth(model, content, "walk")
    assert warning is None
    error, warning = clip_depth(model, content.scaled(factor), "walk")
    assert (
        warning is None and error < 1.3 * own
    )  # read at the model's size (15 % off read raw: about 10 times)


@pytest.mark.slow
def test_a_smaller_character_keeps_its_size_and_stays_the_content_at_strength_zero(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    small = content.scaled(0.8)
    output = transfer(small, style_clip, model=model, strength=0.0).motion
    assert np.array_equal(output.skeleton.offsets, small.skeleton.offsets)
    np.testing.assert_array_equal(output.rotations, small.rotations)  # the content itself, to the last bit
    np.testing.assert_array_equal(output.translations, small.translations)
    kept = transfer(small, style_clip, model=model, keep_part="legs,spine,arms").motion
    np.testing.assert_array_equal(kept.translations, small.translations)
    styled = transfer(small, style_clip, model=model).motion
    pelvis = small.skeleton.pelvis
    heights = styled.positions()[:, pelvis, 1].mean(), small.positions()[:, pelvis, 1].mean()
    assert abs(heights[0] / heights[1] - 1) < 0.1  # its own size, not the model's


def test_training_brings_its_clips_to_one_size(content: Motion) -> None:
    """Training reads clips as a transfer does: another unit or another body size at the first clip's size."""
    from elastyle.training.clips import at_one_size

    taller = content.scaled(1.01)  # within the performers' own spread: kept as it is
    sized = at_one_size([content, content.scaled(0.01), content.scaled(1.1), taller], content.skeleton)
    assert sized[0] is content and sized[3] is taller
    for motion in sized[1:3]:
        np.testing.assert_allclose(motion.translations, content.translations, rtol=1e-12, atol=1e-9)


def test_a_resized_clips_figures_are_at_the_models_size_whether_its_unit_is_stated_or_guessed(
    model, content: Motion
) -> None:  # type: ignore[no-untyped-def]
    from elastyle.core.body import in_units

    for factor in (0.5, 1.5):
        large = content.scaled(factor)
        assert clip_depth(model, in_units(large, "cm"), "walk")[0] == pytest.approx(
            clip_depth(model, large, "walk")[0]
        )


@pytest.mark.parametrize(
    "factor, unit_cm",
    [(1.0, 1.0), (0.75, 1.0), (1 / 2.54, 2.54), (1.2 / 2.54, 2.54), (0.01, 100.0), (10.0, 0.1), (8.0, 0.1)],
)
def test_the_unit_is_guessed_from_the_bodys_height_not_its_rest_pose(
    content: Motion, factor: float, unit_cm: float
) -> None:
    from elastyle.core.body import centimetres_per_unit

    # the dataset's rest pose lies along X, 99.8 cm tall: a smaller body in centimetres was read as inches
    skeleton = content.scaled(factor).skeleton
    assert centimetres_per_unit(skeleton) == unit_cm, factor


def test_the_pelvis_offset_a_file_does_not_use_does_not_size_it(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    # a pelvis with position channels is placed by them, so its OFFSET line (0 0 0 in most exporters' files)
    # moves nothing; the body's size read from the rest pose's extent counted it, so a zero offset read the
    # clip 7.6 times too large and the output collapsed to its knees
    from dataclasses import replace

    clip = content.slice(0, 90)
    offsets = clip.skeleton.offsets.copy()
    offsets[clip.skeleton.pelvis] = 0.0
    zeroed = Motion(replace(clip.skeleton, offsets=offsets), clip.rotations, clip.translations, clip.fps)
    np.testing.assert_allclose(zeroed.positions(), clip.positions(), atol=1e-9)  # the same motion
    ours, theirs = (transfer(c, style_clip, model=model).motion.positions() for c in (clip, zeroed))
    np.testing.assert_allclose(theirs, ours, atol=1e-6)


def test_a_guessed_unit_other_than_centimetres_is_said(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    notes = transfer(content.slice(0, 60).scaled(1 / 2.54), style_clip, model=model).explain["notes"]
    assert any("guessed as in" in note and "--units" in note for note in notes), notes


def test_a_guessed_unit_is_printed_once_per_rig_and_kept_in_every_record(
    model, content: Motion, style_clip: Motion, caplog: pytest.LogCaptureFixture
) -> None:  # type: ignore[no-untyped-def]
    """A batch of one rig's clips in metres printed the same note for every clip (a cold review's run)."""
    import logging

    from elastyle import pipeline

    pipeline._SAID_ONCE.clear()  # as in a new process
    metres = content.slice(0, 60).scaled(0.01)  # centimetres as metres
    with caplog.at_level(logging.WARNING, logger="elastyle"):
        records = [
            transfer(metres, style_clip, model=model, content_name=f"clip{i}", strength=0.0).explain["notes"]
            for i in range(3)
        ]
    assert all(any("length unit guessed" in note for note in notes) for notes in records)
    printed = [r.message for r in caplog.records if "length unit guessed" in r.message]
    assert len(printed) == 1, printed
