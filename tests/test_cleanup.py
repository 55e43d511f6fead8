"""Foot contact cleanup: contacts on real walks, pinned feet with exact bones, smooth legs, other skeletons."""

from __future__ import annotations

import numpy as np
import pytest

from elastyle.core.body import centimetres_per_unit, find_limbs, leg_length
from elastyle.core.ground import ground_level
from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.eval.metrics import foot_skating_cm_s, jerk
from elastyle.io.bvh_read import parse_bvh
from elastyle.io.dataset import ClipRef
from elastyle.steps.cleanup import clean_feet, lift_to_ground, plant_feet
from elastyle.steps.contacts import (
    HEEL,
    TOE,
    detect_contacts,
    detect_point_contacts,
    held_footing,
    mask_runs,
)
from elastyle.steps.root_follow import adjust_root_speed
from elastyle.types import BoolArray, FloatArray
from tests.conftest import THREE_CHANNEL_BVH, clip_named

DRIFT_CM_S = np.array([15.0, 0.0, 20.0])  # added to the pelvis: 25 cm/s of sliding on every planted foot


def contact_skating_cm_s(motion: Motion, contacts: BoolArray) -> float:
    """Mean horizontal toe speed (cm/s) over frame steps where the foot is in contact at both ends.

    Unlike `foot_skating_cm_s`, swing feet passing low over the ground at full speed do not count.
    """
    toes = motion.positions()[:, find_limbs(motion.skeleton).toes][..., [0, 2]]  # (T, F, 2)
    speed_cm_s = (
        np.linalg.norm(np.diff(toes, axis=0), axis=-1) * motion.fps * centimetres_per_unit(motion.skeleton)
    )
    return float(speed_cm_s[contacts[1:] & contacts[:-1]].mean())


def knee_angles_deg(motion: Motion) -> FloatArray:
    """(T, F) interior angle at each knee between thigh and shin."""
    skeleton, limbs = motion.skeleton, find_limbs(motion.skeleton)
    knees = skeleton.parents[limbs.ankles]
    positions = motion.positions()
    thigh = positions[:, skeleton.parents[knees]] - positions[:, knees]
    shin = positions[:, limbs.ankles] - positions[:, knees]
    cosine = np.sum(thigh * shin, -1) / np.linalg.norm(thigh, axis=-1) / np.linalg.norm(shin, axis=-1)
    return np.degrees(np.arccos(np.clip(cosine, -1, 1)))


def bone_lengths(motion: Motion) -> FloatArray:
    """(T, B) distances from each joint below the pelvis's translation to its parent."""
    skeleton = motion.skeleton
    joints = np.array([j for j in range(1, skeleton.num_joints) if j != skeleton.pelvis])
    positions = motion.positions()
    return np.linalg.norm(positions[:, joints] - positions[:, skeleton.parents[joints]], axis=-1)


def with_drift(motion: Motion, speed_cm_s: FloatArray = DRIFT_CM_S) -> Motion:
    translations = motion.translations.copy()
    time_s = np.arange(motion.num_frames)[:, None] / motion.fps  # (T, 1)
    translations[:, motion.skeleton.pelvis] += time_s * speed_cm_s / centimetres_per_unit(motion.skeleton)
    return Motion(motion.skeleton, motion.rotations, translations, motion.fps)


def with_stretched_root_path(motion: Motion, scale: float) -> Motion:
    """The pelvis covers `scale` times its horizontal path in the same time: planted feet slide."""
    translations = motion.translations.copy()
    pelvis = translations[:, motion.skeleton.pelvis]  # (T, 3) view
    pelvis[:, [0, 2]] = pelvis[0, [0, 2]] + scale * (pelvis[:, [0, 2]] - pelvis[0, [0, 2]])
    return Motion(motion.skeleton, motion.rotations, translations, motion.fps)


def path_length(motion: Motion) -> float:
    pelvis = motion.positions()[:, motion.skeleton.pelvis][:, [0, 2]]
    return float(np.linalg.norm(np.diff(pelvis, axis=0), axis=-1).sum())


def check_cleaned(before: Motion, after: Motion) -> None:
    """Same frames, bones exact, no toe under the input's ground, all finite."""
    assert after.num_frames == before.num_frames and after.fps == before.fps
    assert after.skeleton is before.skeleton
    assert np.all(np.isfinite(after.rotations)) and np.all(np.isfinite(after.translations))
    np.testing.assert_allclose(bone_lengths(after), bone_lengths(before), atol=1e-6)
    toes = find_limbs(before.skeleton).toes
    assert after.positions()[:, toes, 1].min() >= ground_level(before) - 1e-6


def test_contacts_on_a_real_walk(walk_clip: ClipRef) -> None:
    motion = walk_clip.read()[0]
    contacts = detect_contacts(motion)
    assert contacts.shape == (motion.num_frames, 2) and contacts.dtype == bool
    duty = contacts.mean(axis=0)
    assert np.all((duty > 0.45) & (duty < 0.8)), duty
    for foot in range(2):  # a step every second or so: several separate contacts per foot
        starts = np.flatnonzero(np.diff(contacts[:, foot].astype(int)) == 1)
        assert len(starts) >= 3
    assert np.any(contacts.all(axis=1)) and contacts.any(axis=1).all()  # double support, never airborne
    # the same walk with sliding feet has the same contacts, nearly; in metres, exactly the same
    assert np.mean(detect_contacts(with_drift(motion)) == contacts) > 0.9
    skeleton = motion.skeleton
    in_metres = Skeleton(skeleton.names, skeleton.parents, skeleton.offsets / 100, skeleton.end_sites / 100)
    metres = Motion(in_metres, motion.rotations, motion.translations / 100, motion.fps)
    np.testing.assert_array_equal(detect_contacts(metres), contacts)
    np.testing.assert_allclose(
        clean_feet(metres).positions() * 100, clean_feet(motion).positions(), atol=1e-6
    )


def test_heel_and_toe_have_their_own_tracks(dataset_clips: list[ClipRef]) -> None:
    """A walk rolls from heel to toe: most stances start on the heel and end on the toe; the foot's contact
    is the union of its two tracks."""
    for stem in ("dataset-2_walk_normal_005", "dataset-2_walk_feminine_015"):
        motion = clip_named(dataset_clips, stem).read()[0]
        points, feet = detect_point_contacts(motion), detect_contacts(motion)
        assert points.shape == (motion.num_frames, 2, 2)
        assert np.all(points.any(axis=2) <= feet)  # a planted toe or heel is a planted foot
        heel_first = toe_last = stances = 0
        for foot in range(2):
            for start, stop in mask_runs(feet[:, foot]):
                toe, heel = (np.flatnonzero(points[start:stop, foot, k]) for k in (TOE, HEEL))
                assert len(toe) or len(heel)
                if len(toe) and len(heel):
                    stances += 1
                    heel_first += heel[0] < toe[0]
                    toe_last += toe[-1] > heel[-1]
        assert stances >= 6 and heel_first >= 0.6 * stances and toe_last >= 0.8 * stances, stem


def test_contacts_of_a_run_are_short(dataset_clips: list[ClipRef]) -> None:
    run = clip_named(dataset_clips, "dataset-2_run_normal_005").read()[0]
    contacts = detect_contacts(run)
    assert np.all(contacts.mean(axis=0) < 0.4) and contacts.any(axis=0).all()
    assert not contacts.any(axis=1).all()  # flight phases


def test_clean_feet_pins_sliding_feet_of_a_real_walk(walk_clip: ClipRef) -> None:
    drifted = with_drift(walk_clip.read()[0])
    contacts = detect_contacts(drifted)
    cleaned = clean_feet(drifted, contacts)
    check_cleaned(drifted, cleaned)
    before, after = contact_skating_cm_s(drifted, contacts), contact_skating_cm_s(cleaned, contacts)
    assert before > 20 and after <= 8.0, (before, after)
    # the metric's own contacts also count swing feet passing low at full speed, so it cannot reach ~0
    assert foot_skating_cm_s(cleaned) < foot_skating_cm_s(drifted)
    fps = drifted.fps
    # pinning every sliding stance (also those that slide back slower than the root) costs some smoothness
    assert jerk(cleaned.positions(), fps) <= 1.15 * jerk(drifted.positions(), fps)
    knee_steps_before = np.abs(np.diff(knee_angles_deg(drifted), axis=0)).max()
    knee_steps_after = np.abs(np.diff(knee_angles_deg(cleaned), axis=0)).max()
    # a heel strike held from its first level frame bends the knee a little faster than the capture did
    assert knee_steps_after <= knee_steps_before + 8.0, (knee_steps_before, knee_steps_after)


def test_root_follows_the_stride_then_feet_are_pinned(walk_clip: ClipRef) -> None:
    motion = walk_clip.read()[0]
    stretched = with_stretched_root_path(motion, 1.25)
    contacts = detect_contacts(stretched)
    moved = adjust_root_speed(stretched, contacts, tolerance=0.25, stray_legs=10.0)
    assert np.array_equal(moved.rotations, stretched.rotations)
    assert contact_skating_cm_s(moved, contacts) < 0.3 * contact_skating_cm_s(stretched, contacts)
    # by default the root strays at most 10 % of the path's length (and 1.5 legs) from the path it was given
    held = adjust_root_speed(stretched, contacts)
    strayed = held.positions()[:, motion.skeleton.pelvis] - stretched.positions()[:, motion.skeleton.pelvis]
    assert np.linalg.norm(strayed[:, [0, 2]], axis=-1).max() <= 0.1 * path_length(stretched) + 1e-6
    assert path_length(moved) == pytest.approx(path_length(motion), rel=0.1)
    cleaned = clean_feet(moved, contacts)
    check_cleaned(stretched, cleaned)
    assert contact_skating_cm_s(cleaned, contacts) <= 2.0
    assert jerk(cleaned.positions(), motion.fps) <= 1.05 * jerk(stretched.positions(), motion.fps)


def test_plant_feet_is_the_three_steps_in_one_pass(dataset_clips: list[ClipRef]) -> None:
    drifted = with_drift(clip_named(dataset_clips, "dataset-2_walk_normal_010").read()[0])
    contacts = detect_contacts(drifted)
    for share in (0.0, 0.5, 1.0):
        steps = (
            clean_feet(adjust_root_speed(drifted, contacts, share), contacts)
            if share
            else clean_feet(drifted)
        )
        planted = plant_feet(drifted, share)
        np.testing.assert_allclose(planted.rotations, steps.rotations, atol=1e-7)  # float rounding only
        np.testing.assert_allclose(planted.translations, steps.translations, atol=1e-7)


def test_held_out_walks_with_sliding(dataset_clips: list[ClipRef]) -> None:
    for stem in ["walk_normal_010", "walk_active_015", "walk_elderly_005", "walk_exhausted_010"]:
        drifted = with_drift(clip_named(dataset_clips, f"dataset-2_{stem}").read()[0])
        contacts = detect_contacts(drifted)
        cleaned = clean_feet(adjust_root_speed(drifted, contacts), contacts)
        check_cleaned(drifted, cleaned)
        assert contact_skating_cm_s(cleaned, contacts) <= 8.0, stem
        assert foot_skating_cm_s(cleaned) < foot_skating_cm_s(drifted), stem
        assert jerk(cleaned.positions(), drifted.fps) <= 1.1 * jerk(drifted.positions(), drifted.fps), stem


def test_standing_still_changes_nothing(walk_clip: ClipRef) -> None:
    motion = walk_clip.read()[0]
    hold = np.zeros(60, dtype=np.int64)  # frame 0, 60 times
    still = Motion(motion.skeleton, motion.rotations[hold], motion.translations[hold], motion.fps)
    contacts = detect_contacts(still)
    assert contacts.all()
    for cleaned in (clean_feet(still), clean_feet(adjust_root_speed(still, contacts), contacts)):
        np.testing.assert_allclose(cleaned.rotations, still.rotations, atol=1e-6)
        np.testing.assert_allclose(cleaned.translations, still.translations, atol=1e-6)


def test_a_stand_whose_planted_feet_sway_leaves_the_pelvis_where_it_is(walk_clip: ClipRef) -> None:
    """The root follows the planted feet only where the pelvis travels: in a stand their sway is the legs'
    IK's to hold (following it, the pelvis of a walk stopped for 2 s glided 14 cm over its planted feet).
    A walk of 2 s, then its last frame held for 2 s with both legs slowly turning (the feet slide)."""
    motion = walk_clip.read()[0]
    frames = np.concatenate([np.arange(60), np.full(60, 59)])  # walk, then stand
    rotations = motion.rotations[frames].copy()
    hips = find_limbs(motion.skeleton).hips
    rotations[60:, hips, 1] += np.linspace(0.0, 0.15, 60)[:, None]  # both legs turn 9 degrees: feet slide
    swaying = Motion(motion.skeleton, rotations, motion.translations[frames], motion.fps)
    contacts = detect_contacts(swaying)
    assert contacts[60:].mean() > 0.9 and contact_skating_cm_s(swaying.slice(60, 120), contacts[60:]) > 1.0
    moved = adjust_root_speed(swaying, contacts).positions()[:, motion.skeleton.pelvis]  # (T, 3)
    assert np.abs(moved[75:] - moved[75]).max() < 1e-6  # still through the stand (the walk's move kept)
    assert np.abs(moved[:60] - swaying.positions()[:60, motion.skeleton.pelvis]).max() > 0.1  # it follows


def test_the_root_strays_from_its_path_within_leg_lengths_however_long_the_clip(walk_clip: ClipRef) -> None:
    """A tenth of the path is a bound only for short clips: the root of a 60 s walk ended 6.7 m short of
    its own end. It strays at most `stray_legs` leg lengths too, as a whole (a smaller share throughout)."""
    motion = walk_clip.read()[0]
    stretched = with_stretched_root_path(motion, 1.25)
    contacts = detect_contacts(stretched)
    leg = leg_length(motion.skeleton, find_limbs(motion.skeleton))
    for legs in (0.25, 0.5):
        held = adjust_root_speed(stretched, contacts, tolerance=1.0, stray_legs=legs)
        pelvis = motion.skeleton.pelvis
        strayed = held.positions()[:, pelvis, [0, 2]] - stretched.positions()[:, pelvis, [0, 2]]
        assert np.linalg.norm(strayed, axis=-1).max() == pytest.approx(legs * leg, rel=1e-6)


def test_lift_to_ground_lifts_sunk_feet_and_nothing_else(walk_clip: ClipRef) -> None:
    """Five frames whose pelvis sinks 3 cm put the feet through the floor: they are lifted to the ground
    level by the legs, and every frame whose toes and ankles are above it stays where it was (within 0.01 cm)."""
    motion = walk_clip.read()[0]
    translations = motion.translations.copy()
    translations[40:45, motion.skeleton.pelvis, 1] -= 3.0 / centimetres_per_unit(motion.skeleton)
    sunk = Motion(motion.skeleton, motion.rotations, translations, motion.fps)
    limbs = find_limbs(sunk.skeleton)
    ground = ground_level(sunk)
    heights = sunk.positions()[:, np.concatenate([limbs.toes, limbs.ankles]), 1]  # (T, 2F)
    lifted = lift_to_ground(sunk)
    after = lifted.positions()[:, np.concatenate([limbs.toes, limbs.ankles]), 1]
    assert heights[40:45].min() < ground - 1.0 / centimetres_per_unit(
        sunk.skeleton
    )  # really through the floor
    assert after.min() >= ground - 1e-6
    above = np.all(heights >= ground, axis=1)
    cm = centimetres_per_unit(sunk.skeleton)
    np.testing.assert_allclose(lifted.positions()[above] * cm, sunk.positions()[above] * cm, atol=0.01)
    np.testing.assert_allclose(lifted.translations, sunk.translations, atol=1e-6)  # the pelvis stays
    check_cleaned(sunk, lifted)


def test_plant_feet_holds_contacts_given_from_elsewhere(
    walk_clip: ClipRef, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Contacts passed in (legs that step as the content does take the content's) are held as well as the
    ones found: none changes nothing, and a stance the detector misses is held when it is given."""
    import elastyle.steps.cleanup as cleanup

    motion = walk_clip.read()[0]
    found = detect_contacts(motion)
    plain = plant_feet(motion, 0.5)
    np.testing.assert_array_equal(plant_feet(motion, 0.5, np.zeros_like(found)).rotations, plain.rotations)
    start, stop = next((a, b) for a, b in mask_runs(found[:, 0]) if a > 0 and b - a >= 10)
    missed = found.copy()
    missed[start:stop, 0] = False  # as if the stance slid too fast to be found
    monkeypatch.setattr(cleanup, "detect_contacts", lambda m, p=None, ground=None: missed.copy())
    toe = find_limbs(motion.skeleton).toes[0]
    middle = slice(start + 2, stop - 2)

    def toe_step_cm(m: Motion) -> float:
        path = m.positions()[middle, toe][:, [0, 2]] * centimetres_per_unit(m.skeleton)
        return float(np.abs(np.diff(path, axis=0)).sum())

    for share in (0.5, 0.0):  # with the root following the legs or not
        unheld, given = plant_feet(motion, share), plant_feet(motion, share, found)
        assert toe_step_cm(given) < 0.5 * toe_step_cm(unheld), share
    with pytest.raises(ValueError, match="contacts must be"):
        plant_feet(motion, 0.5, found[:1])


def test_a_clip_meets_its_own_footing_and_a_higher_floor_lifts_its_feet(walk_clip: ClipRef) -> None:
    """`held_footing`'s floor lies under the clip's own feet, so holding a clip to its own footing changes
    nothing; raised by up to 2 cm over one swing it lifts that foot's lower point there (the toe's or the
    ankle's, whichever is nearer the ground) onto it, eases in and out, and leaves the planted frames alone."""
    motion = walk_clip.read()[0]
    limbs = find_limbs(motion.skeleton)
    contacts, floor, _ = held_footing(motion, np.ones(motion.num_frames, dtype=bool))
    assert contacts.shape == (motion.num_frames, 2) and floor.shape == (motion.num_frames, 2, 2)
    plain = clean_feet(motion, contacts)
    own = clean_feet(motion, contacts, foot_floor=floor)
    np.testing.assert_allclose(own.rotations, plain.rotations, atol=1e-9)  # to rounding
    # the longest swing of the first foot, raised by up to 2 cm (a smooth bump, 0 at its ends)
    start, stop = max(mask_runs(~contacts[:, 0]), key=lambda run: run[1] - run[0])
    raised = floor.copy()
    bump = np.sin(np.linspace(0.0, np.pi, stop - start)) ** 2
    raised[start:stop, 0] += (2.0 / centimetres_per_unit(motion.skeleton)) * bump[:, None]
    lifted = clean_feet(motion, contacts, foot_floor=raised)
    points = np.stack([limbs.toes, limbs.ankles], axis=1)  # (F, 2) as held_footing orders them
    heights = lifted.positions()[:, points, 1]  # (T, F, 2)
    assert np.all(np.max(raised[start:stop, 0] - heights[start:stop, 0], axis=-1) < 1e-6)
    # the planted toe stays where it was, but for the IK's soft reach near a straight leg (millimetres)
    np.testing.assert_allclose(lifted.positions()[contacts[:, 0], limbs.toes[0]],
                               plain.positions()[contacts[:, 0], limbs.toes[0]],
                               atol=0.3 / centimetres_per_unit(motion.skeleton))  # fmt: skip
    step = np.abs(np.diff(heights[:, 0, 0])) * centimetres_per_unit(motion.skeleton)  # toe, cm per frame
    before = np.abs(np.diff(plain.positions()[:, limbs.toes[0], 1])) * centimetres_per_unit(motion.skeleton)
    assert step.max() < before.max() + 1.0  # eased: no jump of the lift's size
    # nowhere held, or no feet: nothing to hold
    _, free, _ = held_footing(motion, np.zeros(motion.num_frames, dtype=bool))
    assert np.all(np.isneginf(free))
    with pytest.raises(ValueError, match="foot_floor must be"):
        clean_feet(motion, contacts, foot_floor=floor[:, :, 0])


def test_single_frame_and_bad_contacts(walk_clip: ClipRef) -> None:
    motion = walk_clip.read()[0].slice(0, 1)
    contacts = detect_contacts(motion)
    assert contacts.shape == (1, 2)
    check_cleaned(motion, clean_feet(motion))
    np.testing.assert_array_equal(adjust_root_speed(motion, contacts).translations, motion.translations)
    with pytest.raises(ValueError, match="contacts must be"):
        clean_feet(motion, np.ones((2, 2), dtype=bool))


def synthetic_walk_bvh(num_frames: int = 60, fps: float = 30.0, speed_m_s: float = 1.0) -> str:
    """A 3-channel BVH in metres, other joint names: planted feet (60 % of a 1 s cycle) swing 8 cm high.

    Hip and knee angles come from planar two-joint IK towards the foot path; feet stay level.
    """
    thigh_m, shin_m, hip_height_m, ankle_height_m, stance = 0.45, 0.45, 0.86, 0.08, 0.6
    lines = []
    for frame in range(num_frames):
        time_s = frame / fps
        root_z = speed_m_s * time_s
        row = [0.0, hip_height_m, root_z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # hip (6 channels), spine
        for phase_offset in (0.0, 0.5):  # left, right
            cycle = time_s + phase_offset
            stance_start_s = np.floor(cycle) - phase_offset
            foot_z = speed_m_s * stance_start_s + speed_m_s * stance / 2
            foot_y = ankle_height_m
            swing = (cycle % 1.0 - stance) / (1 - stance)
            if swing > 0:
                foot_z += speed_m_s * swing * swing * (3 - 2 * swing)
                foot_y += 0.08 * np.sin(np.pi * swing)
            forward, down = foot_z - root_z, foot_y - (hip_height_m - 0.05)
            distance = np.hypot(forward, down)
            bend = np.pi - np.arccos((thigh_m**2 + shin_m**2 - distance**2) / (2 * thigh_m * shin_m))
            # Xrotation turns -Y towards -Z: a leg at angle a points (z, y) = (-sin a, -cos a)
            knee_offset = np.arctan2(shin_m * np.sin(bend), thigh_m + shin_m * np.cos(bend))
            hip_angle = np.arctan2(-forward, -down) - knee_offset
            for angle in (hip_angle, bend, -hip_angle - bend, 0.0):  # thigh, shin, foot, toe
                row += [0.0, float(np.degrees(angle)), 0.0]
        lines.append(" ".join(f"{value:.6f}" for value in row))
    channels = "CHANNELS 3 Zrotation Xrotation Yrotation"
    legs = ""
    for side, x in (("l", 0.1), ("r", -0.1)):
        legs += f"""
  JOINT {side}_thigh
  {{
    OFFSET {x} -0.05 0
    {channels}
    JOINT {side}_shin
    {{
      OFFSET 0 -{thigh_m} 0
      {channels}
      JOINT {side}_foot
      {{
        OFFSET 0 -{shin_m} 0
        {channels}
        JOINT {side}_toe
        {{
          OFFSET 0 -0.06 0.12
          {channels}
          End Site
          {{
            OFFSET 0 0 0.05
          }}
        }}
      }}
    }}
  }}"""
    header = f"""HIERARCHY
ROOT hip
{{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine
  {{
    OFFSET 0 0.1 0
    {channels}
    End Site
    {{
      OFFSET 0 0.4 0
    }}
  }}{legs}
}}
MOTION
Frames: {num_frames}
Frame Time: {1 / fps:.7f}
"""
    return header + "\n".join(lines) + "\n"


def test_three_channel_skeleton_in_metres() -> None:
    motion = parse_bvh(synthetic_walk_bvh().encode(), "synthetic.bvh")[0]
    assert centimetres_per_unit(motion.skeleton) == 100.0
    contacts = detect_contacts(motion)
    assert np.all(np.abs(contacts.mean(axis=0) - 0.6) < 0.15), contacts.mean(axis=0)
    assert contact_skating_cm_s(motion, contacts) < 1.0  # built with planted feet
    assert np.abs(clean_feet(motion, contacts).positions() - motion.positions()).max() < 0.01  # < 1 cm
    sliding = with_stretched_root_path(motion, 1.3)
    assert contact_skating_cm_s(sliding, contacts) > 20
    moved = adjust_root_speed(sliding, contacts)
    for cleaned in (clean_feet(sliding, contacts), clean_feet(moved, contacts)):
        check_cleaned(sliding, cleaned)
        assert contact_skating_cm_s(cleaned, contacts) <= 1.0  # exact heel and toe paths: pinned exactly


def test_two_bone_legs_are_left_alone() -> None:
    motion = parse_bvh(THREE_CHANNEL_BVH.encode(), "tiny.bvh")[0]  # hip -> leg -> foot: no knee to bend
    cleaned = clean_feet(motion)
    np.testing.assert_array_equal(cleaned.rotations, motion.rotations)


def test_contact_hysteresis_matches_its_frame_by_frame_definition() -> None:
    from elastyle.steps.contacts import _hysteresis

    rng = np.random.default_rng(0)
    for _ in range(50):
        enter, stay = rng.random((60, 2)) < 0.1, rng.random((60, 2)) < 0.8
        expected = np.zeros_like(enter)
        expected[0] = enter[0]
        for frame in range(1, 60):
            expected[frame] = enter[frame] | (expected[frame - 1] & stay[frame])
        assert np.array_equal(_hysteresis(enter, stay), expected)


def _reversed(motion: Motion) -> Motion:
    """The clip played backwards: a forward walk becomes a backward walk."""
    return Motion(
        motion.skeleton, motion.rotations[::-1].copy(), motion.translations[::-1].copy(), motion.fps
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("content", "style", "backward"),
    [
        ("run_masculine_005", "run_active_010", False),  # short stance, flight phases
        ("walk_normal_005", "walk_masculine_010", True),  # stance feet slide towards the direction of travel
    ],
)
def test_transfers_of_runs_and_backward_walks_keep_feet_planted(
    dataset_clips: list[ClipRef], content: str, style: str, backward: bool
) -> None:
    """Skate as an independent benchmark measures it (toes within 2 cm of their own floor, no contact
    detector): at most 8 cm/s after the transfer, as on real clips."""
    from elastyle import transfer
    from elastyle.eval.metrics import floor_skating_cm_s

    clips = [clip_named(dataset_clips, f"dataset-2_{name}").read()[0] for name in (content, style)]
    if backward:
        clips = [_reversed(clip) for clip in clips]
    output = transfer(clips[0], clips[1]).motion
    unplanted = transfer(clips[0], clips[1], cleanup=False).motion
    assert floor_skating_cm_s(output) <= 8.0 < floor_skating_cm_s(unplanted)


@pytest.mark.slow
@pytest.mark.parametrize("options", [{"method": "wct"}, {"method": "adain"}, {"fallback_below": 1.0}])
def test_the_statistics_methods_keep_the_contents_footing(
    dataset_clips: list[ClipRef], options: dict[str, object]
) -> None:
    """Where the style's statistics alone colour the content (the statistics methods, the fallback
    everywhere), its legs step as the content's do, so the clean-up holds the content's contacts and its
    feet's clearance: a walk given an exhausted walk's statistics swung its toes 4 cm through the floor
    and skimmed it, 35 cm/s of skate as an independent benchmark measures it (the content: 8)."""
    from elastyle import transfer
    from elastyle.eval.metrics import floor_skating_cm_s

    content, style = (
        clip_named(dataset_clips, f"dataset-2_{name}").read()[0]
        for name in ("walk-turn-left_normal_005", "walk-turn-left_exhausted_005")
    )
    assert floor_skating_cm_s(transfer(content, style, **options).motion) <= floor_skating_cm_s(content)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("content", "style", "before"),
    [
        ("walk_normal_005", "run_active_005", 28.7),  # the run's statistics on the walk's legs
        ("walk-turn-left_normal_010", "walk_exhausted_010", 15.2),  # a turn's legs at a share of their own
    ],
)
def test_legs_that_keep_the_contents_action_hold_its_stance(
    dataset_clips: list[ClipRef], content: str, style: str, before: float
) -> None:
    """Held contacts stay down and pinned: a stance foot under the style's statistics rose 3 to 7 cm
    mid-stance, so its hold (which fades as a foot rises) let it slide; and legs blending two gaits at a
    small share of the content's were pinned at that share only. Skate as an independent benchmark reads
    it, against the content's own (8.1 and 7.3 cm/s)."""
    from elastyle import transfer
    from elastyle.eval.metrics import floor_skating_cm_s

    clips = [clip_named(dataset_clips, f"dataset-2_{name}").read()[0] for name in (content, style)]
    skate = floor_skating_cm_s(transfer(*clips).motion)
    assert skate <= 0.8 * before and skate <= 1.6 * floor_skating_cm_s(clips[0]), skate  # 8.7 and 11.3


@pytest.mark.slow
def test_runs_of_every_style_keep_feet_planted(run_pairs: list[tuple[str, Motion, Motion]]) -> None:
    """Over held-out runs given each style, skate as an independent benchmark measures it: every output at
    most half its unplanted self, the set's median at most 3 cm/s (real runs: about 5)."""
    from elastyle import transfer
    from elastyle.eval.metrics import floor_skating_cm_s

    planted, unplanted = (
        np.array([floor_skating_cm_s(transfer(c, s, cleanup=clean).motion) for _, c, s in run_pairs])
        for clean in (True, False)
    )
    halved = planted <= 0.5 * unplanted  # each pair: the clean-up takes off at least half
    assert np.all(halved), [name for (name, _, _), ok in zip(run_pairs, halved) if not ok]
    assert np.median(planted) <= 3.0, planted  # measured: 0.35 to 0.63 cm/s


def test_a_skeleton_without_toes_is_left_as_it_is() -> None:
    # root -> spine -> chest, which branches: the chest is the pelvis and has a parent
    offsets = np.array([[0, 0, 0], [0, 10, 0], [0, 10, 0], [0, 5, 0], [0, -3, -2], [0, -3, -2.0]])
    skeleton = Skeleton(
        ("root", "spine", "chest", "head", "tail", "tail_tip"), np.array([-1, 0, 1, 2, 2, 4]), offsets
    )
    motion = Motion(skeleton, np.zeros((4, 6, 3)), np.tile(offsets, (4, 1, 1)), 30.0)
    for cleaned in (
        adjust_root_speed(motion, np.zeros((4, 0), dtype=bool)),
        clean_feet(motion),
        plant_feet(motion, 0.5),
        lift_to_ground(motion),
    ):
        np.testing.assert_array_equal(cleaned.translations, motion.translations)
        np.testing.assert_array_equal(cleaned.rotations, motion.rotations)
    contacts, floor, _ = held_footing(motion, np.ones(4, dtype=bool))
    assert contacts.shape == (4, 0) and floor.shape == (4, 0, 2)


def test_knees_do_not_snap_straight_where_the_feet_are_planted(dataset_clips: list[ClipRef]) -> None:
    """A walk given an elderly walk's style: its planted feet pulled a few millimetres further straightened
    a near-straight knee for one frame (169 -> 178 -> 170 degrees, eight times in 8 s); the soft reach keeps
    the knee's angle changing smoothly."""
    from elastyle.pipeline import transfer

    content = clip_named(dataset_clips, "dataset-2_walk_normal_010").read()[0]
    style = clip_named(dataset_clips, "dataset-2_walk_elderly_015").read()[0]
    output = transfer(content, style).motion
    skeleton, positions = output.skeleton, output.positions()
    for side in "LR":
        hip, knee, ankle = (skeleton.index(f"{part}_{side}") for part in ("UpperLeg", "LowerLeg", "Foot"))
        up, down = positions[:, hip] - positions[:, knee], positions[:, ankle] - positions[:, knee]
        cosine = np.sum(up * down, axis=1) / np.linalg.norm(up, axis=1) / np.linalg.norm(down, axis=1)
        angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
        assert np.abs(np.diff(angle, 2)).max() < 15.0, side  # degrees per frame squared (before: 16.7)


def test_leg_ik_reaches_its_targets_bending_knees_the_way_the_clip_does() -> None:
    """A synthetic leg (two 40 cm bones) whose knee bends 30 degrees forward for 50 frames, then from 8
    degrees backward to 8 forward: bent to 40 and 60 degrees, every knee comes out forward by as much, and
    every ankle on its target. Bending in the leg's own plane bent the backward knees backward; blending that
    plane with the clip's flipped the knee at 3 degrees and missed the targets by up to 1.8 cm."""
    from elastyle.core.rotations import to_matrix
    from elastyle.steps.leg_ik import leg_ik

    bends = np.radians(np.concatenate([np.full(50, 30.0), np.linspace(-8.0, 8.0, 10)]))  # (T,) forward > 0
    thigh_turns, knee_turns = (
        to_matrix(np.outer(bends / 2, [1.0, 0, 0])),
        to_matrix(np.outer(-bends / 2, [1.0, 0, 0])),
    )
    down = np.array([0.0, -40.0, 0.0])
    world = np.zeros((len(bends), 4, 3, 3))
    world[:, 0], world[:, 1], world[:, 2], world[:, 3] = np.eye(3), thigh_turns, knee_turns, knee_turns
    positions = np.zeros((len(bends), 4, 3))  # (T, 4, 3): pelvis, hip, knee, ankle
    positions[:, 2] = thigh_turns @ down
    positions[:, 3] = positions[:, 2] + knee_turns @ down
    line = positions[:, 3] / np.linalg.norm(positions[:, 3], axis=1, keepdims=True)
    for degrees in (40.0, 60.0):
        targets = (line * 80.0 * np.cos(np.radians(degrees) / 2))[:, None]  # (T, 1, 3)
        local = to_matrix(leg_ik(world, positions, np.array([0]), np.array([[1, 2, 3]]), targets))
        knee = local[:, 0, 0] @ down
        ankle = knee + local[:, 0, 0] @ local[:, 0, 1] @ down
        np.testing.assert_allclose(ankle, targets[:, 0], atol=1e-9)
        forward = 40.0 * np.sin(np.radians(degrees) / 2)  # the knee's offset from the hip-ankle line
        np.testing.assert_allclose(-knee[:, 2], forward, atol=1e-6)  # forward is -Z in this leg's turns


def test_a_near_straight_knee_bends_the_way_the_clip_bends_it(dataset_clips: list[ClipRef]) -> None:
    """A raise of both hands given a youthful raise's style stands on straight legs (the decoded knee a
    hair off the hip-ankle line, either side); the clean-up's IK bent the left knee in that hair's plane,
    backwards by up to 3.5 cm for a few frames, three times in 2.5 s (the knee's jerk 19 times the
    content's). Near straight, the knee now bends in the clip's plane."""
    from elastyle.pipeline import transfer

    content = clip_named(dataset_clips, "dataset-2_raise-up-both-hands_normal_055").read()[0]
    style = clip_named(dataset_clips, "dataset-2_raise-up-both-hands_youthful_025").read()[0]
    skeleton = content.skeleton
    output = transfer(content, style).motion
    for side in "LR":
        hip, knee, ankle = (skeleton.index(f"{part}_{side}") for part in ("UpperLeg", "LowerLeg", "Foot"))
        offsets = {}
        for name, clip in (("content", content), ("output", output)):
            positions = clip.positions()
            line = positions[:, ankle] - positions[:, hip]
            line /= np.linalg.norm(line, axis=1, keepdims=True)
            to_knee = positions[:, knee] - positions[:, hip]
            offsets[name] = to_knee - np.sum(to_knee * line, axis=1, keepdims=True) * line  # (T, 3) cm
        forward = offsets["content"].mean(axis=0) / np.linalg.norm(offsets["content"].mean(axis=0))
        assert np.min(offsets["output"] @ forward) > 0.5, side  # forward throughout (before: -3.5 cm)
        knee_jerk = [np.abs(np.diff(offsets[name], 3, axis=0)).mean() for name in ("content", "output")]
        assert knee_jerk[1] < 3 * knee_jerk[0], side


def test_feet_stay_on_the_contents_floor_under_another_actions_statistics(
    dataset_clips: list[ClipRef],
) -> None:
    """A run given a walk's style keeps its legs' action with the walk's statistics, which lowered the feet
    and the clip's own ground level with them: a toe sank 3 cm below the run's floor for three frames."""
    from elastyle.core.body import find_limbs
    from elastyle.pipeline import transfer

    content = clip_named(dataset_clips, "dataset-2_run_normal_005").read()[0]
    style = clip_named(dataset_clips, "dataset-2_walk_masculine_005").read()[0]
    output = transfer(content, style).motion
    toes = find_limbs(output.skeleton).toes
    sink = ground_level(content) - output.positions()[:, toes, 1].min()  # cm: the dataset's unit
    assert sink < 1.5  # SINK_CM below the floor as the output reads the content (before: 3.0)


def test_a_walk_that_stops_and_sets_off_again_does_not_sink(dataset_clips: list[ClipRef]) -> None:
    """A held-out walk slowed to a 3 s stop and eased back to its pace, given a masculine walk's style:
    where it set off again, a contact of the content's held on while the styled foot stepped on, and the
    pelvis sank to reach it (28 cm below the output without the clean-up; a similar clip of a review sank
    from 90 to 13 cm). The clean-up lowers it by at most a tenth of the leg each pass."""
    from elastyle.core.body import leg_length
    from elastyle.pipeline import transfer

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0]
    contacts = detect_contacts(walk)
    both = np.flatnonzero(np.all(contacts, axis=1))
    stop = int(both[np.argmin(np.abs(both - walk.num_frames // 2))])  # both feet down, near the middle
    ease = np.sin(np.pi / 2 * np.arange(60) / 60)  # (60,) 0 to 1: a deceleration over 2 s
    times = np.concatenate([
        np.arange(stop - 30), stop - 30 + 30 * ease, np.full(90, float(stop)), stop + 30 * (1 - ease[::-1]),
        np.arange(stop + 30, walk.num_frames),
    ])  # fmt: skip
    content = walk.sample(times)
    style = clip_named(dataset_clips, "dataset-2_walk_masculine_010").read()[0]
    cleaned, plain = (transfer(content, style, cleanup=flag).motion for flag in (True, False))
    pelvis = content.skeleton.pelvis
    sink = np.max(plain.positions()[:, pelvis, 1] - cleaned.positions()[:, pelvis, 1])  # cm
    assert sink < 0.2 * leg_length(content.skeleton, find_limbs(content.skeleton))  # 8.3 cm (before: 28.4)
