"""The style converter on real dataset walks: methods, placement, controls, root handling, edge cases."""

from __future__ import annotations

import numpy as np
import pytest

from elastyle import ClipTooShortError, ConfigError, Motion
from elastyle.core.body import heading_yaw, pelvis_forward_local, yaw_matrices
from elastyle.eval.metrics import cadence_steps_s, timing_error
from elastyle.eval.reconstruction import reconstruct
from elastyle.io.dataset import ClipRef
from elastyle.pipeline import transfer
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import prepare_style
from tests.conftest import clip_named


def _path(motion: Motion) -> np.ndarray:
    return motion.positions()[:, motion.skeleton.pelvis][:, [0, 2]]


def _end_tolerance(content: Motion) -> float:
    """How far an output's root may end from the content's: a stride's sway, plus the 10 % of the path's
    length the root may stray to follow the legs' stride (`--root-follows-legs`)."""
    return 15 + 0.1 * float(np.linalg.norm(np.diff(_path(content), axis=0), axis=-1).sum())


@pytest.mark.parametrize("method", ["elastic", "rigid", "wct", "adain"])
def test_each_method_gives_a_clip_on_the_content_skeleton(
    model, content: Motion, style_clip: Motion, method: str
) -> None:  # type: ignore[no-untyped-def]
    result = transfer(content, style_clip, TransferConfig(method=method), model=model)
    out = result.motion
    assert out.skeleton is content.skeleton
    assert out.fps == content.fps
    assert np.all(np.isfinite(out.rotations))
    if method in ("wct", "adain", "rigid"):
        assert out.num_frames == content.num_frames  # no stretch: the content's own timeline
    # the root walks the content's path: same start point, the end point within the stated tolerance
    path = _path(content)
    np.testing.assert_allclose(_path(out)[0], path[0], atol=15)
    np.testing.assert_allclose(_path(out)[-1], path[-1], atol=_end_tolerance(content))
    exact = transfer(content, style_clip, TransferConfig(method=method, root_follows_legs=0), model=model)
    np.testing.assert_allclose(_path(exact.motion)[-1], path[-1], atol=15)
    # and it differs from the content
    n = min(out.num_frames, content.num_frames)
    assert np.linalg.norm(out.positions()[:n] - content.positions()[:n], axis=-1).mean() > 3.0


def test_elastic_takes_the_style_timing_and_rigid_does_not(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    f_content, f_style = cadence_steps_s(content), cadence_steps_s(style_clip)
    assert abs(f_content - f_style) > 0.15
    elastic = transfer(content, style_clip, model=model).motion
    rigid = transfer(content, style_clip, TransferConfig(method="rigid"), model=model).motion
    fixed = transfer(content, style_clip, TransferConfig(placement="fixed"), model=model).motion
    e_elastic = timing_error(cadence_steps_s(elastic), f_content, f_style)
    e_rigid = timing_error(cadence_steps_s(rigid), f_content, f_style)
    e_fixed = timing_error(cadence_steps_s(fixed), f_content, f_style)
    assert e_elastic < 0.5 < e_rigid
    assert e_fixed > 0.5  # the literal placement keeps the content's timing
    assert fixed.num_frames == content.num_frames


@pytest.mark.parametrize("pace", [0.6, 1.6])
def test_a_style_far_slower_or_faster_than_the_content_still_sets_the_pace(
    model, content: Motion, style_clip: Motion, pace: float
) -> None:  # type: ignore[no-untyped-def]
    # the style clip retimed to step at `pace` times the content's cadence: beyond the report's +-25 %
    f_content = cadence_steps_s(content)
    retimed = style_clip.resample(style_clip.fps * cadence_steps_s(style_clip) / (pace * f_content))
    style = Motion(style_clip.skeleton, retimed.rotations, retimed.translations, style_clip.fps)
    f_style = cadence_steps_s(style)
    assert not 0.7 < f_style / f_content < 1.4
    outputs = {
        centre: transfer(content, style, TransferConfig(stretch_centre=centre), model=model).motion
        for centre in ("tempo", "content")
    }
    errors = {
        centre: timing_error(cadence_steps_s(out), f_content, f_style) for centre, out in outputs.items()
    }
    assert errors["tempo"] < 0.25 < errors["content"]


@pytest.mark.parametrize(
    "content_name, style_name",
    [("run_normal_035", "run_masculine_005"), ("run_normal_010", "run_active_025")],
)
def test_the_first_search_starts_from_the_cadences_ratio(
    model, dataset_clips: list[ClipRef], content_name: str, style_name: str
) -> None:  # type: ignore[no-untyped-def]
    """Held-out runs given runs' styles whose cadences are 9 and 11 % slower: the first search is centred on
    their ratio (each read from the feet's heights), so the output steps at the style's cadence (timing error
    0.13 and 0.00; centred on the content's own pace first, 0.31 both: the first range's patches read a tempo
    short of the style's)."""
    content = clip_named(dataset_clips, f"dataset-2_{content_name}").read()[0]
    style = clip_named(dataset_clips, f"dataset-2_{style_name}").read()[0]
    f_content, f_style = cadence_steps_s(content), cadence_steps_s(style)
    out = transfer(content, style, model=model).motion
    assert timing_error(cadence_steps_s(out), f_content, f_style) < 0.2


@pytest.mark.parametrize("patch_s", [0.2, 0.25])
def test_short_patches_read_no_tempo(model, content: Motion, style_clip: Motion, patch_s: float) -> None:  # type: ignore[no-untyped-def]
    # three or so tried lengths are too coarse to read a tempo from: the output is the report's range's
    outputs = [
        transfer(
            content, style_clip, TransferConfig(patch_s=patch_s, stretch_centre=centre), model=model
        ).motion
        for centre in ("tempo", "content")
    ]
    np.testing.assert_array_equal(outputs[0].rotations, outputs[1].rotations)


def test_a_short_gesture_takes_a_much_slower_styles_pace(model, dataset_clips: list[ClipRef]) -> None:  # type: ignore[no-untyped-def]
    # a 1.8 s raise (two whole patches) given an elderly raise that takes 2.6 times as long: its tempo is
    # read from those two patches, so the output slows beyond the report's +-25 % and holds the hand up
    content = clip_named(dataset_clips, "dataset-2_raise-up-left-hand_normal_005").read()[0]
    style = clip_named(dataset_clips, "dataset-2_raise-up-left-hand_elderly_005").read()[0]
    outputs = {
        centre: transfer(content, style, TransferConfig(stretch_centre=centre), model=model).motion
        for centre in ("tempo", "content")
    }
    assert (
        outputs["content"].num_frames
        < 1.4 * content.num_frames
        < 1.6 * content.num_frames
        < outputs["tempo"].num_frames
    )

    def held_up_s(motion: Motion) -> float:
        """How long the left hand stays within a fifth of its highest above the pelvis, seconds."""
        hand = motion.skeleton.names.index("Hand_L")
        height = motion.positions()[:, hand, 1] - motion.positions()[:, motion.skeleton.pelvis, 1]
        return float(np.sum(height > height.min() + 0.8 * np.ptp(height)) / motion.fps)

    assert held_up_s(outputs["tempo"]) > 1.4 > 1.0 > held_up_s(outputs["content"])


def test_a_wave_given_the_other_hands_wave_waves_its_own_hand(model, dataset_clips: list[ClipRef]) -> None:  # type: ignore[no-untyped-def]
    # the style's mirrored windows wave the content's hand; mirrored on axes its raised arm chose, they had both
    # arms half raised and neither waving (right hand 20 cm above the pelvis, left 40)
    content = clip_named(dataset_clips, "dataset-2_wave-right-hand_normal_010").read()[0]
    style = clip_named(dataset_clips, "dataset-2_wave-left-hand_youthful_005").read()[0]
    out = transfer(content, style, model=model).motion
    names, positions = out.skeleton.names, out.positions()
    middle = slice(out.num_frames // 4, 3 * out.num_frames // 4)
    above = {side: positions[middle, names.index(f"Hand_{side}"), 1] - positions[middle, out.skeleton.pelvis, 1]
             for side in "LR"}  # fmt: skip
    assert np.median(above["R"]) > 60 and np.median(above["L"]) < 0, {
        k: np.median(v) for k, v in above.items()
    }


def test_the_output_walks_the_contents_path_to_its_ends(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    # on the content's clock, the root on the content's path: the pelvis starts and ends where the content's does
    out = transfer(content, style_clip, model=model, timing="content", root_follows_legs=0.0).motion
    gaps = np.linalg.norm(_path(out)[[0, -1]] - _path(content)[[0, -1]], axis=1)
    assert np.all(gaps < 3.0), gaps  # cm; the path smoothed with held ends started 8 and ended 10 cm inside
    # a clip of a second or less keeps its travel (held ends kept 10 of 26 cm of a third of a second)
    for frames in (10, 30):
        short = content.slice(60, 60 + frames)
        travelled = np.linalg.norm(_path(short)[-1] - _path(short)[0])
        kept = np.linalg.norm(np.subtract(*_path(transfer(short, style_clip, model=model).motion)[[-1, 0]]))
        assert kept > 0.85 * travelled, (frames, kept, travelled)


def test_tempo_centred_stretches_surround_the_tempo() -> None:
    config = TransferConfig()
    np.testing.assert_array_equal(config.source_lengths(30, 30.0), np.arange(22, 39, 2))  # the report's range
    centred = config.source_lengths(30, 30.0, tempo=1.5)
    assert 34 <= centred.min() < centred.max() <= 56 and 45 in centred


def test_plain_decoding_at_strength_zero_is_the_content_through_the_autoencoder(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    config = TransferConfig(cleanup=False, decode="plain", smooth_s=0.0)  # the decoder's output as it is
    out = transfer(content, style_clip, config, model=model, strength=0.0).motion
    assert out.num_frames == content.num_frames
    np.testing.assert_allclose(out.positions(), reconstruct(model, content).positions(), atol=1e-3)


def test_strength_schedule_fades_the_style_in(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    raw = TransferConfig(cleanup=False)
    faded = transfer(content, style_clip, raw, model=model, strength="0:0,2:0,4:1").motion
    full = transfer(content, style_clip, raw, model=model).motion
    # during the first two seconds the output is the content, frame for frame
    np.testing.assert_allclose(faded.positions()[:60], content.positions()[:60], atol=1e-6)
    # the style's faster pace fades in with it: shorter than the content, longer than the full transfer
    assert full.num_frames < faded.num_frames < content.num_frames
    # on the content's clock (frames align): after the fade the output is the full transfer's, not the content
    on_clock = TransferConfig(cleanup=False, timing="content")
    faded_on_clock = transfer(content, style_clip, on_clock, model=model, strength="0:0,2:0,4:1").motion
    full_on_clock = transfer(content, style_clip, on_clock, model=model).motion
    after = slice(135, -15)  # from 4.5 s; the last half second left out: the two timelines end differently
    assert (
        np.linalg.norm(faded_on_clock.positions()[after] - full_on_clock.positions()[after], axis=-1).max()
        < 1.0
    )
    assert (
        np.linalg.norm(faded_on_clock.positions()[after] - content.positions()[after], axis=-1).max() > 10.0
    )


def test_transition_and_blend_of_two_styles(
    model, content: Motion, style_clip: Motion, dataset_clips
) -> None:  # type: ignore[no-untyped-def]
    slow_style = clip_named(dataset_clips, "dataset-2_walk_masculine_010").read()[0]
    raw = TransferConfig(cleanup=False, timing="content")  # frames align with the content's
    first = transfer(content, style_clip, raw, model=model).motion
    second = transfer(content, slow_style, raw, model=model).motion
    change = transfer(
        content, style_clip, raw, model=model, second_style=slow_style, second_weight="3:0,5:1"
    ).motion

    def mean_gap(a: Motion, b: Motion, frames: slice = slice(None)) -> float:
        return float(np.linalg.norm(a.positions()[frames] - b.positions()[frames], axis=-1).mean())

    # before the change begins, the output is the first style's; after it ends, the second's
    np.testing.assert_allclose(change.positions()[:60], first.positions()[:60], atol=1e-3)
    assert mean_gap(change, second, slice(165, None)) < 0.5 < 5.0 < mean_gap(change, first, slice(165, None))
    # a blend at one half lies between the two styles
    half = transfer(content, style_clip, raw, model=model, second_style=slow_style, second_weight=0.5).motion
    gap = mean_gap(first, second)
    for one in (first, second):
        assert 0.25 * gap < mean_gap(half, one) < 0.75 * gap


def test_explain_lists_every_patch(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    result = transfer(content, style_clip, model=model, style_names=["slow.bvh"])
    patches = result.explain["styles"][0]["patches"]
    assert len(patches) >= content.duration_s / 1.25 - 1
    for row in patches:
        assert row["style_clip"] == "slow.bvh"
        assert 0.73 <= row["stretch"] <= 1.27
        assert -1 <= row["similarity"] <= 1
        assert 0 <= row["style_start_frame"] < style_clip.num_frames
    assert any(row["style_mirrored"] for row in patches)  # the library holds the style's mirror
    unmirrored = transfer(content, style_clip, model=model, style_names=["slow.bvh"], mirror_style=False)
    assert not any(row["style_mirrored"] for row in unmirrored.explain["styles"][0]["patches"])
    # output times advance by one patch (1 s) per row
    starts = [row["output_start_s"] for row in patches]
    assert np.allclose(np.diff(starts), 1.0, atol=0.05)


def test_style_library_of_several_clips_and_a_short_style(model, content: Motion, dataset_clips) -> None:  # type: ignore[no-untyped-def]
    styles = [clip_named(dataset_clips, f"dataset-2_walk_elderly_{take:03d}").read()[0] for take in (5, 10)]
    library = prepare_style(model, styles, ["a.bvh", "b.bvh"])
    result = transfer(content, library, model=model)
    assert result.explain["styles"][0]["clips"] == ["a.bvh", "b.bvh"]
    short_style = styles[0].slice(0, 45)  # 1.5 s, shorter than the content
    short = transfer(content, short_style, model=model)
    assert short.motion.num_frames > 0.5 * content.num_frames
    assert all(
        r["style_start_frame"] + r["style_frames"] <= 45 for r in short.explain["styles"][0]["patches"]
    )


def test_content_shorter_than_one_patch_still_transfers(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    short = content.slice(0, 12)  # 0.4 s, less than the 1 s patch: documented fallback
    result = transfer(short, style_clip, model=model)
    assert 1 <= result.motion.num_frames <= 12 * 1.5
    assert len(result.explain["styles"][0]["patches"]) == 1
    assert any("shorter than one patch" in note for note in result.explain["notes"])  # printed and recorded
    assert not transfer(content, style_clip, model=model).explain["notes"]
    same = transfer(short, style_clip, model=model, strength=0.0).motion
    np.testing.assert_allclose(same.positions(), short.positions(), atol=1e-9)
    with pytest.raises(ClipTooShortError, match="at least 2"):
        transfer(content.slice(0, 1), style_clip, model=model)


def test_style_shorter_than_minimum_patch_is_a_clear_error(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ClipTooShortError, match=r"style0: too short for a patch \(3 frame\(s\) at 30 fps"):
        transfer(content, style_clip.slice(0, 3), TransferConfig(mirror_style=False), model=model)


def test_same_input_gives_identical_output(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    first = transfer(content, style_clip, model=model).motion
    second = transfer(content, style_clip, model=model).motion
    np.testing.assert_array_equal(first.rotations, second.rotations)


def test_content_timing_keeps_the_content_clock(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    out = transfer(content, style_clip, TransferConfig(timing="content"), model=model).motion
    assert out.num_frames == content.num_frames
    f_content, f_style = cadence_steps_s(content), cadence_steps_s(style_clip)
    assert timing_error(cadence_steps_s(out), f_content, f_style) > 0.7
    np.testing.assert_allclose(_path(out)[-1], _path(content)[-1], atol=_end_tolerance(content))


@pytest.mark.parametrize("timing", ["style", "content"])
def test_cleanup_plants_the_feet(model, content: Motion, style_clip: Motion, timing: str) -> None:  # type: ignore[no-untyped-def]
    from elastyle.core.ground import ground_level
    from elastyle.eval.metrics import foot_skating_cm_s
    from elastyle.eval.report import bone_length_error_cm

    raw = transfer(content, style_clip, TransferConfig(timing=timing, cleanup=False), model=model).motion
    clean = transfer(content, style_clip, TransferConfig(timing=timing), model=model).motion
    assert foot_skating_cm_s(clean) <= 8.0 < foot_skating_cm_s(raw)
    assert bone_length_error_cm(clean, content) < 1e-6
    toes = clean.positions()[:, [clean.skeleton.index("Toes_L"), clean.skeleton.index("Toes_R")], 1]
    assert toes.min() >= ground_level(raw) - 1e-6
    if timing == "style":  # the clean-up keeps the style's timing (the benchmark's median is in the README)
        f_content, f_style = cadence_steps_s(content), cadence_steps_s(style_clip)
        e_clean = timing_error(cadence_steps_s(clean), f_content, f_style)
        assert e_clean < 0.5
        assert abs(e_clean - timing_error(cadence_steps_s(raw), f_content, f_style)) <= 0.05


@pytest.mark.parametrize("floor_cm", [10.0, -20.0])
def test_a_clip_on_another_floor_stands_as_high_above_it(  # type: ignore[no-untyped-def]
    model, content: Motion, style_clip: Motion, floor_cm: float
) -> None:
    """The model reads the pelvis's height above y = 0: a walk on a floor 10 cm up came out 11 cm lower
    than its own pelvis, its toes dragging, and one 20 cm down walked in the air. On its own floor it now
    stands as the same walk does on the model's, its feet on that floor, and its timing alike (moved only
    to the edge of the floors taken for the same, 1.6 cm, its feet sank 1 cm or floated 1.5)."""
    from elastyle.core.ground import ground_level, raised

    on_floor = transfer(content, style_clip, model=model).motion
    moved = transfer(raised(content, floor_cm), style_clip, model=model).motion
    pelvis = content.skeleton.pelvis
    lift = moved.positions()[:, pelvis, 1].mean() - on_floor.positions()[:, pelvis, 1].mean()
    assert abs(lift - floor_cm) <= 0.3, lift
    assert abs(ground_level(moved) - floor_cm - ground_level(on_floor)) <= 0.3
    assert abs(moved.num_frames - on_floor.num_frames) <= 1
    at_strength_0 = transfer(raised(content, floor_cm), style_clip, model=model, strength=0.0).motion
    np.testing.assert_array_equal(at_strength_0.translations, raised(content, floor_cm).translations)


def test_legs_that_keep_their_own_action_over_most_of_the_clip_are_noted(
    dataset_clips: list[ClipRef],
) -> None:
    """A walk given a run's style keeps its legs' action throughout: said, as a walk given a walk's is not
    (a slowed walk given a fast one came back nearly as it was, and nothing said why)."""
    walk, run, active = (
        clip_named(dataset_clips, f"dataset-2_{name}").read()[0]
        for name in ("walk_normal_005", "run_active_005", "walk_active_010")
    )
    said = "legs keep their own action over 100 % of the clip"
    assert any(said in note for note in transfer(walk, run).explain["notes"])
    assert not any("legs keep their own action" in note for note in transfer(walk, active).explain["notes"])


def test_fading_the_strength_out_keeps_the_feet_planted(dataset_clips: list[ClipRef]) -> None:
    """Fading out, the pelvis comes back to the content's path over planted feet as the strength falls: the
    root's move, blended back with the clean-up below strength 0.25, slid a stance foot 75 to 150 cm/s (an
    elderly walk's style faded out over 2.5 s skated 21.8 cm/s against 12.8 at full strength)."""
    from elastyle.eval.metrics import floor_skating_cm_s

    content, style = (
        clip_named(dataset_clips, f"dataset-2_{name}").read()[0]
        for name in ("walk_normal_005", "walk_elderly_010")
    )
    full = floor_skating_cm_s(transfer(content, style).motion)
    faded = floor_skating_cm_s(transfer(content, style, strength="0:1,5:1,7.5:0").motion)
    assert faded <= full + 3.0, (faded, full)  # measured 13.3 and 12.8


def _hand_ranges_cm(motion: Motion) -> np.ndarray:
    """(H,) how far each hand rises and falls relative to the pelvis (90th - 10th percentile height)."""
    from elastyle.core.body import centimetres_per_unit, find_limbs

    positions = motion.positions()
    heights = positions[:, find_limbs(motion.skeleton).hands, 1] - positions[:, [motion.skeleton.pelvis], 1]
    return (np.percentile(heights, 90, axis=0) - np.percentile(heights, 10, axis=0)) * centimetres_per_unit(
        motion.skeleton
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("content_name", "style_name"),
    [
        ("raise-up-left-hand_normal_010", "raise-up-left-hand_feminine_005"),
        ("raise-up-right-hand_normal_060", "raise-up-right-hand_exhausted_015"),
        ("raise-up-right-hand_normal_010", "raise-up-right-hand_masculine_005"),
    ],
)
def test_a_one_handed_raise_up_keeps_its_hand(
    model, dataset_clips: list[ClipRef], content_name: str, style_name: str
) -> None:  # type: ignore[no-untyped-def]
    """The style library holds the style clip and its mirror; matching what the hands do keeps the
    content's raised hand (with the latents alone, the other hand rose 25 to 70 cm on these pairs)."""
    content, style = (
        clip_named(dataset_clips, f"dataset-2_{n}").read()[0] for n in (content_name, style_name)
    )
    raised = int(np.argmax(_hand_ranges_cm(content)))
    ranges = _hand_ranges_cm(transfer(content, style, model=model).motion)
    assert int(np.argmax(ranges)) == raised
    assert ranges[1 - raised] < 0.25 * ranges[raised], ranges


@pytest.mark.slow
def test_the_fallback_engages_on_a_cross_pair_and_not_on_a_walk_pair(
    model, dataset_clips: list[ClipRef]
) -> None:  # type: ignore[no-untyped-def]
    """A walk given a wave's style finds no window that walks: the style's statistics take over there."""
    walk, wave, proud = (
        clip_named(dataset_clips, f"dataset-2_{n}").read()[0]
        for n in ("walk_normal_005", "wave-right-hand_feminine_005", "walk_masculine_010")
    )

    def modes(style: Motion) -> list[str]:
        result = transfer(walk, style, model=model, fallback_below=0.4)
        return [patch["mode"] for patch in result.explain["styles"][0]["patches"]]

    on_wave, on_walk = modes(wave), modes(proud)
    assert on_wave.count("statistics") >= len(on_wave) // 2, on_wave
    assert set(on_walk) == {"swap"}, on_walk
    default = transfer(walk, wave, model=model).explain["styles"][0]["patches"]
    assert "statistics" not in {patch["mode"] for patch in default}  # off unless asked


def test_a_path_given_for_a_clip_says_to_read_it_first(model, content: Motion, walk_clip: ClipRef) -> None:  # type: ignore[no-untyped-def]
    path = walk_clip.name
    with pytest.raises(TypeError, match="content must be a Motion.*read_bvh"):
        transfer(path, content, model=model)
    with pytest.raises(TypeError, match="style must be a Motion.*read_bvh"):
        transfer(content, path, model=model)
    with pytest.raises(TypeError, match=r"returns \(motion, layout\)"):
        transfer(content, [walk_clip.read()], model=model)


def _pelvis_steps_cm(motion: Motion) -> np.ndarray:
    """(T - 1,) how far the pelvis moves over the ground from each frame to the next (cm at 30 fps)."""
    pelvis = motion.positions()[:, motion.skeleton.pelvis][:, [0, 2]]
    return np.linalg.norm(np.diff(pelvis, axis=0), axis=1)


@pytest.mark.parametrize("style_stem", ["walk_feminine_010", "walk_elderly_010"])
def test_the_output_keeps_moving_to_its_last_frame(
    model, content: Motion, dataset_clips: list[ClipRef], style_stem: str
) -> None:  # type: ignore[no-untyped-def]
    """The last output frame reads the content's last frame: no frame past the time map's end repeating the
    pose before it (the pelvis stepped 7 of 113 cm/s into the feminine walk's last frame), which shows as a
    hitch where a clip loops or blends into the next."""
    style = clip_named(dataset_clips, f"dataset-2_{style_stem}").read()[0]
    steps = _pelvis_steps_cm(transfer(content, style, model=model).motion)
    assert steps[-1] > 0.6 * np.median(steps[-10:-1]), steps[-10:]


@pytest.mark.parametrize("style_stem", ["walk_elderly_010", "wave-both-hands_masculine_010"])
def test_a_still_content_keeps_its_length(
    model, content: Motion, dataset_clips: list[ClipRef], style_stem: str
) -> None:  # type: ignore[no-untyped-def]
    """A body holding still (a walk's first pose held for 3 s) has no pace to take: read unstretched, its
    length stays (a two-handed wave's style made 3 s of idle 2.07 s, each patch at a chance stretch)."""
    idle = Motion(
        content.skeleton,
        np.repeat(content.rotations[:1], 90, axis=0),
        np.repeat(content.translations[:1], 90, axis=0),
        content.fps,
    )
    style = clip_named(dataset_clips, f"dataset-2_{style_stem}").read()[0]
    result = transfer(idle, style, model=model)
    assert result.motion.num_frames == idle.num_frames
    assert {p["stretch"] for p in result.explain["styles"][0]["patches"]} == {1.0}


@pytest.mark.parametrize(("fps", "frames"), [(60.0, 150), (120.0, 302), (24.0, None)])
def test_content_at_another_frame_rate_keeps_moving_to_its_last_frame(
    model, content: Motion, style_clip: Motion, fps: float, frames: int | None
) -> None:  # type: ignore[no-untyped-def]
    """The model-rate copy of a content at another rate ends at the content's last frame, so the output does
    too: a 60 fps walk's joints moved 126 cm/s, then 5 on the last step (its end lay past the copy's,
    where the styled pose was held), and at 24 fps a strength ending at 0 missed the last frame by 4 cm."""
    resampled = content.resample(fps)
    clip = Motion(resampled.skeleton, resampled.rotations[:frames], resampled.translations[:frames], fps)
    out = transfer(clip, style_clip, model=model).motion
    speeds = np.linalg.norm(np.diff(out.positions(), axis=0), axis=-1).mean(axis=1)  # (T - 1,)
    assert speeds[-1] > 0.6 * np.median(speeds[-10:-1]), speeds[-10:]
    fading = transfer(clip, style_clip, model=model, strength=f"0:1,{clip.duration_s / 2:.2f}:0").motion
    assert np.abs(fading.positions()[-1] - clip.positions()[-1]).max() < 1e-6


def _one_cycle(walk: Motion) -> Motion:
    """One gait cycle (two steps) of a walk, in place: from frame 100 to the later frame, about a cycle on,
    whose pose relative to the pelvis is nearest frame 100's; the pelvis held over its first place."""
    relative = walk.positions() - walk.positions()[:, walk.skeleton.pelvis][:, None]
    start = 100
    distance = [
        np.linalg.norm(relative[k] - relative[start], axis=-1).mean() for k in range(start + 25, start + 45)
    ]
    cycle = walk.slice(start, start + 25 + int(np.argmin(distance)))
    translations = cycle.translations.copy()
    translations[:, walk.skeleton.pelvis, [0, 2]] = translations[:1, walk.skeleton.pelvis, [0, 2]]
    return Motion(cycle.skeleton, cycle.rotations, translations, cycle.fps)


def _seam_and_worst_inside_cm(motion: Motion) -> tuple[float, float]:
    """How far the pose (the pelvis and the joints below it, in its heading frame) misses, at the wrap from
    the last frame to the first, and at worst inside the clip, where its last two frames carry it on (cm): a
    loop's seam is no worse inside."""
    skeleton = motion.skeleton
    world_rotations, positions = motion.world()
    body = [j for j in range(skeleton.num_joints) if skeleton.pelvis in skeleton.with_ancestors([j])]
    relative = positions[:, body] - positions[:, skeleton.pelvis][:, None]
    yaw = heading_yaw(world_rotations[:, skeleton.pelvis], pelvis_forward_local(skeleton))
    relative = np.einsum("tij,tkj->tki", yaw_matrices(-yaw), relative)
    wrapped = np.concatenate([relative[-2:], relative[:2]])  # the last two frames, then the first two

    def misses(poses: np.ndarray) -> np.ndarray:
        return np.linalg.norm(poses[2:] - (2 * poses[1:-1] - poses[:-2]), axis=-1).max(axis=-1)

    return float(misses(wrapped).max()), float(misses(relative).max())


def _heading_turn_degrees(motion: Motion) -> float:
    """How far the pelvis's heading turns from the first frame to the last."""
    world_rotations = motion.world([motion.skeleton.pelvis])[0][:, motion.skeleton.pelvis]
    yaw = heading_yaw(world_rotations, pelvis_forward_local(motion.skeleton))
    return float(np.degrees(yaw[-1] - yaw[0]))


def test_a_cycle_transferred_as_one_loops(model, dataset_clips: list[ClipRef]) -> None:  # type: ignore[no-untyped-def]
    """A walk cycle of a held-out take (in place, as game engines keep them) given a masculine walk's style:
    read from its first frame to its last, its output popped where it wraps. With `loop` it loops as the
    cycle does, at the style's pace; a turning cycle keeps its turn. Poses in the pelvis's heading frame."""
    cycle = _one_cycle(clip_named(dataset_clips, "dataset-2_walk_normal_010").read()[0])
    style = clip_named(dataset_clips, "dataset-2_walk_masculine_010").read()[0]
    seam, inside = _seam_and_worst_inside_cm(cycle)
    assert seam <= 1.5 * inside  # the content loops, near enough (5.5 cm against 4.6)
    once = transfer(cycle, style, model=model)
    looped = transfer(cycle, style, model=model, loop=True)
    seam, inside = _seam_and_worst_inside_cm(looped.motion)
    assert seam <= 1.1 * inside, (seam, inside)  # 3.4 cm against 3.2
    assert _seam_and_worst_inside_cm(once.motion)[0] > 3 * inside  # read once, it does not (16.1 cm)
    assert looped.explain["loop"] and looped.explain["output_frames"] == looped.motion.num_frames
    assert abs(looped.motion.num_frames - once.motion.num_frames) <= 2  # the style's pace either way
    pelvis = looped.motion.positions()[:, cycle.skeleton.pelvis]
    np.testing.assert_allclose(
        pelvis[0, [0, 2]], cycle.positions()[0, cycle.skeleton.pelvis, [0, 2]], atol=5.0
    )
    with pytest.raises(ConfigError, match="loop takes a constant strength"):
        transfer(cycle, style, model=model, loop=True, strength="0:0,1:1")
    # a turning cycle goes on turning from copy to copy, so its loop keeps the turn (tiled without it, the
    # loop turned -1 degrees, its start's cross-fade taking the turn back)
    turning = _one_cycle(clip_named(dataset_clips, "dataset-2_walk-turn-left_normal_010").read()[0])
    turned = transfer(turning, style, model=model, loop=True).motion
    seam, inside = _seam_and_worst_inside_cm(turned)
    assert abs(_heading_turn_degrees(turned) - _heading_turn_degrees(turning)) < 2  # 13.5 against 13.5
    assert seam <= 1.1 * inside, (seam, inside)  # 2.7 cm against 2.9
