"""Features, mirroring and resampling on real clips and on a 3-channel skeleton of another naming scheme."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from elastyle import Motion, SkeletonMismatchError, mirror, read_bvh
from elastyle.core.mirror import local_reflections
from elastyle.core.rotations import continuous_log, from_quat, to_quat
from elastyle.model.features import FeatureSpec
from tests.conftest import clip_named


def test_quaternion_round_trip_and_identity_is_safe() -> None:
    rng = np.random.default_rng(0)
    rotvecs = rng.normal(size=(100, 3))
    rotvecs /= np.maximum(1, np.linalg.norm(rotvecs, axis=1, keepdims=True) / 3.0)
    rotvecs[0] = 0.0
    np.testing.assert_allclose(from_quat(to_quat(rotvecs)), rotvecs, atol=1e-9)
    np.testing.assert_array_equal(from_quat(to_quat(np.zeros((1, 3)))), np.zeros((1, 3)))


def test_continuous_log_never_jumps_across_pi() -> None:
    angles = np.linspace(2.8, 3.5, 50)  # passes through pi
    rotvecs = np.stack([np.zeros_like(angles), angles, np.zeros_like(angles)], axis=1)
    rotvecs[angles > np.pi, 1] -= 2 * np.pi  # as scipy would give them: a jump
    smooth = continuous_log(rotvecs[:, None, :], axis=0)[:, 0]
    assert np.abs(np.diff(smooth, axis=0)).max() < 0.05


def test_features_round_trip_real_clips(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    clips = [
        c
        for c in dataset_clips
        if c.stem.endswith(("walk_normal_001", "run_active_003", "wave-left-hand_elderly_002"))
    ]
    motions = [c.read()[0] for c in clips]
    spec = FeatureSpec.fit(motions)
    for motion in motions:
        features, root = spec.encode(motion)
        assert features.shape == (motion.num_frames, spec.num_channels)
        decoded = spec.decode(features, root, motion.fps)
        np.testing.assert_allclose(decoded.positions(), motion.positions(), atol=1e-3)
        # continuous: no rotation feature jumps by more than 1 rad between frames
        assert np.abs(np.diff(features[:, :-3], axis=0)).max() < 1.0


def test_mirror_twice_is_identity_and_reflects_fk(walk_clip) -> None:  # type: ignore[no-untyped-def]
    motion, _ = walk_clip.read()
    mirrored = mirror(motion)
    partner = motion.skeleton.mirror_pairs()
    reflected = motion.positions()[:, partner] * np.array([-1.0, 1.0, 1.0])
    # each bone keeps its own length: the captured rig's left and right ones differ by up to 0.4 mm
    np.testing.assert_allclose(mirrored.positions(), reflected, atol=0.1)
    twice = mirror(mirrored)
    np.testing.assert_allclose(twice.positions(), motion.positions(), atol=1e-4)
    np.testing.assert_allclose(twice.rotations, motion.rotations, atol=1e-6)
    # a joint that moves on one side only: its partner takes its motion (held at its rest offset, it lost it)
    shoulder = motion.skeleton.names.index("UpperArm_L")
    translations = motion.translations.copy()
    translations[:, shoulder, 1] += 3.0 * np.sin(np.arange(motion.num_frames) / 5.0)
    moving = Motion(motion.skeleton, motion.rotations, translations, motion.fps)
    reflected = moving.positions()[:, partner] * np.array([-1.0, 1.0, 1.0])
    np.testing.assert_allclose(mirror(moving).positions(), reflected, atol=0.1)
    np.testing.assert_allclose(mirror(mirror(moving)).positions(), moving.positions(), atol=1e-4)


def test_a_one_handed_gesture_is_mirrored_on_the_same_axes_as_a_walk(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    # a limb's offsets leave a twist about its bone open; the clip's most symmetric frames choose it, so a raised
    # arm does not: a left-handed wave's mirror turned both arms 90 degrees about their bones, which the model
    # then read as another pose (a right-handed wave given its style lost the wave)
    def reflections(stem: str) -> np.ndarray:
        motion = clip_named(dataset_clips, f"dataset-2_{stem}").read()[0]
        return local_reflections(motion, motion.skeleton.mirror_pairs())

    walk = reflections("walk_normal_001")
    # an End Site of zeros carrying a file's rounding does not choose a head's axes (it turned the head 90 degrees)
    motion = clip_named(dataset_clips, "dataset-2_walk_normal_001").read()[0]
    ends = motion.skeleton.end_sites.copy()
    ends[motion.skeleton.names.index("Head")] = [0.0, 1e-4, 1e-4]
    noisy = Motion(
        replace(motion.skeleton, end_sites=ends), motion.rotations, motion.translations, motion.fps
    )
    np.testing.assert_array_equal(local_reflections(noisy, noisy.skeleton.mirror_pairs()), walk)
    for stem in ("wave-left-hand_youthful_005", "raise-up-left-hand_youthful_005", "wave-right-hand_normal_005",
                 "walk-turn-left_normal_025"):  # fmt: skip
        np.testing.assert_array_equal(reflections(stem), walk, err_msg=stem)


def test_mirror_on_other_naming_scheme(three_channel_bvh: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    partner = motion.skeleton.mirror_pairs()
    assert motion.skeleton.names[partner[2]] == "RightLeg"
    mirrored = mirror(motion)
    np.testing.assert_allclose(
        mirrored.positions(), motion.positions()[:, partner] * np.array([-1.0, 1.0, 1.0]), atol=1e-9
    )


def test_mirror_without_pairs_is_a_clear_error(three_channel_bvh: Path, tmp_path: Path) -> None:
    text = three_channel_bvh.read_text().replace("LeftLeg", "legA").replace("RightLeg", "legB")
    text = text.replace("LeftFoot", "footA").replace("RightFoot", "footB")
    path = tmp_path / "nopairs.bvh"
    path.write_text(text)
    motion, _ = read_bvh(path)
    with pytest.raises(SkeletonMismatchError, match="no left/right joint pairs"):
        mirror(motion)


@pytest.mark.parametrize(
    "name_pairs", [("Foot_L", "Foot_R"), ("l_hip", "r_hip"), ("arm.L", "arm.R"), ("LeftArm", "RightArm")]
)
def test_side_markers_are_recognised(name_pairs: tuple[str, str]) -> None:
    from elastyle.core.skeleton import Skeleton

    names = ("root", *name_pairs)
    skeleton = Skeleton(names, np.array([-1, 0, 0]), np.zeros((3, 3)))
    assert skeleton.mirror_pairs().tolist() == [0, 2, 1]


def test_resample_keeps_duration_and_poses(walk_clip) -> None:  # type: ignore[no-untyped-def]
    motion, _ = walk_clip.read()
    doubled = motion.resample(60.0)
    assert doubled.num_frames == 2 * motion.num_frames - 1
    np.testing.assert_allclose(doubled.positions()[::2], motion.positions(), atol=1e-6)
    back = doubled.resample(motion.fps)
    np.testing.assert_allclose(back.positions(), motion.positions(), atol=1e-4)


def test_moving_sum_matches_scipy() -> None:
    from scipy.ndimage import uniform_filter1d

    from elastyle.core.smoothing import moving_sum

    values = np.random.default_rng(0).normal(size=(50, 4, 3))
    for width in (1, 2, 7, 30, 80):
        np.testing.assert_allclose(
            moving_sum(values, width),
            width * uniform_filter1d(values, width, axis=0, mode="nearest"),
            atol=1e-10,
        )


def test_smoothing_matches_scipy() -> None:
    from scipy.ndimage import gaussian_filter1d

    from elastyle.core.smoothing import smooth

    short = np.random.default_rng(0).normal(size=(50, 4, 3))
    long = np.random.default_rng(1).normal(size=(700, 5))
    wide = (40.0, 300.0)  # kernels wider than the short clip, then wider than the long one too
    for values in (short, long, long[:, 0]):
        for sigma in (0.5, 1.0, 7.5, *wide):
            np.testing.assert_allclose(
                smooth(values, sigma), gaussian_filter1d(values, sigma, axis=0, mode="nearest"), atol=1e-12
            )


def test_a_paths_smoothing_keeps_steady_travel_to_its_ends() -> None:
    from elastyle.core.smoothing import smooth, smooth_path

    frames = np.arange(40.0)
    travel = np.stack([3.0 * frames + 5.0, -0.5 * frames], axis=1)  # (T, 2) steady travel, units per frame
    sway = np.stack([np.sin(frames), np.zeros_like(frames)], axis=1)
    for num_frames in (40, 5, 2):  # longer and shorter than the kernel's radius (30 frames for sigma 7.5)
        line = travel[:num_frames]
        np.testing.assert_allclose(smooth_path(line, 7.5), line, atol=1e-9)
        assert abs(smooth(line, 7.5)[0, 0] - line[0, 0]) > 1.0 or num_frames == 2  # held edges pull it in
    # a sway about the travel is smoothed away as before, and the path runs through the clip's ends
    path = smooth_path(travel + sway, 3.0)
    assert np.max(np.abs(path - travel)[:-8]) < 0.05
    np.testing.assert_allclose(path[[0, -1]], (travel + sway)[[0, -1]], atol=1e-9)


def test_a_two_sided_walk_is_not_read_as_one_sided_even_with_a_bone_of_no_length(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    """A joint whose first child sits at the joint itself (a zero-length bone, as some exporters write a
    neck or a twist joint) pointed nowhere, which read as 90 degrees from its mirror: every clip of such a
    rig was taken for one held to one side."""
    from elastyle.core.mirror import ONE_SIDED_DEGREES, asymmetry, mirror
    from elastyle.core.skeleton import Skeleton

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0]
    assert asymmetry(walk, mirror(walk)).degrees < ONE_SIDED_DEGREES
    offsets = walk.skeleton.offsets.copy()
    offsets[walk.skeleton.index("Neck")] = 0.0
    skeleton = Skeleton(walk.skeleton.names, walk.skeleton.parents, offsets, walk.skeleton.end_sites)
    translations = walk.translations.copy()
    translations[:, walk.skeleton.index("Neck")] = 0.0
    zero = Motion(skeleton, walk.rotations, translations, walk.fps)
    assert asymmetry(zero, mirror(zero)).degrees < ONE_SIDED_DEGREES
