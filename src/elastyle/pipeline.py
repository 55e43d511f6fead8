"""The transfer, step by step: a content clip performed in the manner and timing of a style.

Each step is one call into the module that owns it; docs/method.md describes each, with shapes and units.

    read        io.bvh_read.read_bvh                     (the caller: clips in, `Motion`)
    features    model.features.FeatureSpec.encode        rotations -> per-frame features (T, C)
    encode      model.file.StyleModel.encode_motion      features -> latents (T, Z)
    check       model.depth                              a warning if the model cannot represent the content
    whiten      steps.whiten.LatentStats.whiten          content and style latents decorrelated
    match       steps.search.search_sequential / _fixed  elastic patches: stretched content vs style windows,
                steps.search.half_shifted                and the half-shifted sequence between them
                steps.tempo                              searched again about the clip's tempo
                steps.part_action.part_keeps             per body part, how differently the matched windows act
    place       steps.track._cover, _patch_sample        each patch on the content-time grid
    cross-fade  steps.track.style_track                  two half-shifted patch sequences, triangle weights
    colour      steps.whiten.LatentStats.colour          the style's statistics
    retime      steps.timeline                           strength and styles mixed; the output's time map
    decode      steps.decode                             latents -> `Motion`; residual: the content composed
                                                         with the style's change (strength 0 = the content)
    clean up    steps.cleanup.plant_feet                 feet planted by two-joint leg IK, the root following
    keep        steps.keep                               body parts kept as the content performs them: those
                                                         the user names, and legs and spine where the
                                                         matched windows do another action
    write       io.bvh_write.write_bvh                   (the caller)
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from elastyle.core.body import centimetres_per_unit, guessed_unit_note, no_legs_note
from elastyle.core.ground import ground_level, has_feet, raised
from elastyle.core.motion import Motion, check_finite_clip, leading_pose_note
from elastyle.core.parts import body_parts, joint_set, parse_parts, part_joints, sides_guessed
from elastyle.core.resample import interpolate_rows
from elastyle.core.roots import root_carries_pelvis, root_motion_joint
from elastyle.core.threads import one_blas_thread
from elastyle.errors import ClipTooShortError, ConfigError, ResultError
from elastyle.model.depth import depth_warning, reconstruction_error_cm
from elastyle.model.features import RootPath
from elastyle.model.file import StyleModel, as_model
from elastyle.steps.action import (
    action_channels,
    action_layout,
    clip_in_place,
    still_frames,
    walks_backwards,
    walks_sideways,
)
from elastyle.steps.arguments import arms_treated_apart, check_clip_type, check_part_styles, second_schedule
from elastyle.steps.cleanup import lift_to_ground, plant_feet
from elastyle.steps.config import TransferConfig
from elastyle.steps.contacts import held_footing
from elastyle.steps.decode import (
    blend_by_strength,
    compose_residual,
    decode_plain,
    frames_of,
    output_frames,
)
from elastyle.steps.explain import explain
from elastyle.steps.keep import (
    arms_hanging,
    fallback_weights,
    keep_target,
    keep_weights,
    statistics_weights,
)
from elastyle.steps.library import StyleLibrary, as_library
from elastyle.steps.loop import middle_cycle, tiled
from elastyle.steps.root_follow import ground_shift, shifted_pelvis
from elastyle.steps.schedule import Schedule
from elastyle.steps.timeline import content_grid, mix_tracks, on_output_frames, output_content_times
from elastyle.steps.track import MIN_PATCH_FRAMES, requested_patch_frames, style_track
from elastyle.types import FloatArray, IntArray

StyleInput = Motion | Sequence[Motion] | StyleLibrary
# with residual decoding the foot clean-up acts in full from this strength on, and in proportion below it
CLEAN_FULL_STRENGTH = 0.25
SHORT_PATCH_S = 0.5  # patches shorter than this (seconds) get a warning that the output jitters
PIN_FULL_KEEP = 0.2  # legs keeping the content's action are pinned again in full from this share on
LEGS_KEPT_NOTE = 0.5  # a note says so where the legs keep their own action over this share of the output
log = logging.getLogger(__name__)


class TransferResult(NamedTuple):
    """The output clip (the content's skeleton and frame rate) and its explain record."""

    motion: Motion
    explain: dict[str, Any]


@one_blas_thread
def transfer(
    content: Motion,
    style: StyleInput,
    config: TransferConfig | None = None,
    *,
    model: StyleModel | str | os.PathLike[str] | None = None,
    second_style: StyleInput | None = None,
    second_weight: float | str | Schedule | None = None,
    style_names: Sequence[str] | None = None,
    second_style_names: Sequence[str] | None = None,
    part_styles: Mapping[str, StyleInput] | None = None,
    content_name: str = "content",
    **options: Any,
) -> TransferResult:
    """Perform `content` in the manner and timing of `style`.

    style: one clip, several clips (one library), or a prepared `StyleLibrary`.
    config, options: a `TransferConfig` and/or its fields by name (`strength=0.5, method="rigid"`).
    second_style, second_weight: a second library and its share, 0 to 1 (keyframed in content seconds for
        a transition from `style` to `second_style`, constant for a blend), which a second style needs.
    part_styles: body part names (`core.parts`: legs, spine, left-arm, right-arm, arms) and the style
        whose manner those parts take instead (on the output's one clock, which `style` sets).
    model: a `StyleModel` (`load_model`) or a model file's path; None: the model that prepared a given
        `StyleLibrary`, else the shipped model.
    style_names, second_style_names: one name per style clip, for notes and the explain record.
    content_name: the content's name in notes and errors.
    Returns a `TransferResult`: the output clip on the content's skeleton at its frame rate (its length
    follows the style's timing unless `timing="content"`), and the explain record (a dict: the matched
    patches, notes, the output's frame count). Raises `ElastyleError` subclasses for unusable input
    (`SkeletonMismatchError`, `ClipTooShortError`, `ConfigError`, `BvhError` for NaN values), `TypeError`
    where something else than a clip is given. With `loop`, the content is a cycle and so is the output
    (`steps.loop`).
    """
    config = TransferConfig.of(config, **options)
    arguments: dict[str, Any] = dict(
        model=model, second_style=second_style, second_weight=second_weight, style_names=style_names,
        second_style_names=second_style_names, part_styles=part_styles, content_name=content_name,
    )  # fmt: skip
    if config.loop:
        return _looped(content, style, config, **arguments)
    return _transfer(content, style, config, **arguments)[0]


def _looped(content: Motion, style: StyleInput, config: TransferConfig, **arguments: Any) -> TransferResult:
    """`transfer` of a cycle: three cycles end to end transferred, the output the middle one's (`steps.loop`)."""
    check_clip_type(content, "content")
    name = arguments["content_name"]
    if content.num_frames < 2:
        raise ClipTooShortError(f"{name}: {content.num_frames} frame(s); a cycle needs at least 2")
    keyed = [
        option
        for option, schedule in (
            ("strength", config.strength_schedule),
            ("second_weight", second_schedule(arguments["second_style"], arguments["second_weight"])),
        )
        if len(schedule.values) > 1
    ]
    if keyed:
        raise ConfigError(
            f"{name}: loop takes a constant {keyed[0]} (keyframes are times in one reading of the clip)"
        )
    result, content_frames = _transfer(
        tiled(content), style, TransferConfig.of(config, loop=False), **arguments
    )
    loop, start, end, seam = middle_cycle(result.motion, content_frames, content)
    record = dict(result.explain, loop=True, output_frames=loop.num_frames)
    record["model_rate_frames"] = round(
        record["model_rate_frames"] * loop.num_frames / result.motion.num_frames
    )
    cycle_s, start_s = content.duration_s, start / loop.fps
    for entry in [
        *record["styles"],
        *record.get("part_styles", []),
    ]:  # the middle cycle's patches, on its clocks
        entry["patches"] = [
            dict(patch, content_start_s=round(patch["content_start_s"] - cycle_s, 4),
                 output_start_s=round(patch["output_start_s"] - start_s, 4))
            for patch in entry["patches"]
            # a patch lasts its window's length times its stretch on the output's clock
            if start_s - entry["patch_s_used"] * patch.get("stretch", 1.0) < patch["output_start_s"] < end / loop.fps
        ]  # fmt: skip
    note = (
        f"note: {name}: read as a cycle (its last frame runs into its first): transferred three times end to "
        f"end, the output is the middle one's {loop.num_frames} frames, their seam cross-faded over {seam} frames"
    )
    log.info("%s", note)
    record["notes"] = [*record["notes"], note]
    return TransferResult(loop, record)


def _transfer(
    content: Motion,
    style: StyleInput,
    config: TransferConfig,
    *,
    model: StyleModel | str | os.PathLike[str] | None,
    second_style: StyleInput | None,
    second_weight: float | str | Schedule | None,
    style_names: Sequence[str] | None,
    second_style_names: Sequence[str] | None,
    part_styles: Mapping[str, StyleInput] | None,
    content_name: str,
) -> tuple[TransferResult, FloatArray]:
    """`transfer`, and the content frame (T_out,) each output frame shows."""
    check_clip_type(content, "content")
    check_part_styles(part_styles, config.kept_parts)
    change = second_schedule(second_style, second_weight)  # the second style's share over content time
    check_finite_clip(content, content_name)
    if model is None:  # a prepared library's own model, unless another is given
        inputs = (style, second_style, *(part_styles or {}).values())
        model = next((s.model for s in inputs if isinstance(s, StyleLibrary) and s.model is not None), None)
    model = as_model(model)
    renamed = model.check_clip(content, content_name)
    original = content  # the output is on its skeleton
    content = model.on_model_hierarchy(content)  # its joints the model has, and a dropped static root added
    given, (content, size) = content, model.at_model_size(content)  # transferred at the model's size
    notes: list[str] = []  # every note and warning printed, also kept in the explain record
    if renamed is not None:
        _say(notes, renamed)
    unit_note = guessed_unit_note(given.skeleton, content_name)
    # printed once per rig and size in a process (a batch of one rig's clips), kept in every record
    if unit_note is not None:
        _say(notes, unit_note, once=(given.skeleton.names, round(centimetres_per_unit(given.skeleton), 6)))
    pose_note = leading_pose_note(given, content_name)
    if pose_note is not None:
        _say(notes, pose_note)
    legs_note = no_legs_note(content.skeleton, content_name) if config.cleanup else None
    if legs_note is not None:
        _say(notes, legs_note)
    fps = model.fps
    working, per_model_frame = content.resample_to_end(fps)  # ending at the content's last frame
    if working.num_frames < 2:
        at_model_rate = f", {working.num_frames} at the model's {fps:g} fps" if content.fps != fps else ""
        raise ClipTooShortError(
            f"{content_name}: {content.num_frames} frame(s) at {content.fps:g} fps{at_model_rate}; a transfer "
            "needs at least 2"
        )
    libraries = [as_library(model, style, style_names, config.mirror_style, config.reverse_style)]
    patch_frames = min(requested_patch_frames(config, fps), libraries[0].longest_clip)
    if config.method in ("elastic", "rigid") and working.num_frames < patch_frames:
        _say(notes, short_content_note(content_name, content.duration_s, patch_frames / fps))
    for idle, why in config.unread_options(patch_frames, fps):
        _say(notes, f"note: {', '.join(idle)} {'has' if len(idle) == 1 else 'have'} no effect here ({why})",
             once=("idle", tuple(idle), why))  # fmt: skip
    if config.method in ("elastic", "rigid") and config.patch_s < SHORT_PATCH_S:
        _say(notes, (
            f"warning: --patch-s {config.patch_s:g}: windows under {SHORT_PATCH_S:g} s hold less than a stride, so "
            "the output jitters (a walk at 0.2 s: 2.2 times the content's jerk, 1.5 at the default 1 s)"
        ), once=("patch_s", config.patch_s))  # fmt: skip
        if (
            config.method == "elastic"
            and config.stretch > 0
            and len(config.source_lengths(patch_frames, fps)) == 1
        ):
            _say(notes, (
                f"note: --patch-s {config.patch_s:g}: patches of {patch_frames} frames at the model's {fps:g} fps (at "
                f"least {MIN_PATCH_FRAMES}) reach no other whole length within --stretch, so each is read at its own "
                "and the output keeps the content's timing"
            ), once=("patch_s frames", config.patch_s))  # fmt: skip
    if second_style is not None:
        if change.times_s[0] >= content.duration_s and change.values[0] == 0:
            _say(notes, (
                f"note: {content_name}: the change to the second style starts at {change.times_s[0]:g} s, after "
                f"the clip's end ({content.duration_s:.2f} s): it does not show"
            ))  # fmt: skip
        libraries.append(
            as_library(model, second_style, second_style_names, config.mirror_style, config.reverse_style)
        )
    kept = part_joints(content.skeleton, config.kept_parts, content_name)  # (K,) joints kept as performed
    if arms_treated_apart(config.kept_parts, part_styles) and sides_guessed(content.skeleton):
        _say(notes, (
            f"warning: {content_name}: no joint names say left or right and its rest pose does not stand, so "
            "the arm its file lists first is taken for the left one (left-arm and right-arm may be swapped)"
        ))  # fmt: skip
    by_part = [
        (part_joints(content.skeleton, parse_parts(names, "part_styles"), content_name),
         as_library(model, part_style, None, config.mirror_style, config.reverse_style))
        for names, part_style in (part_styles or {}).items()
    ]  # fmt: skip
    # how the style clips were read, said as they were (`as_library`, `steps.cache.load_library`), recorded
    for library in [*libraries, *(part_library for _, part_library in by_part)]:
        notes += [note for note in library.notes if note not in notes]
    styled_joints = np.concatenate([joints for joints, _ in by_part]) if by_part else np.zeros(0, np.int64)
    if len(joint_set(styled_joints)) < len(styled_joints):
        raise ConfigError(
            f"{content_name}: a body part is given two styles (part_styles); give each part one"
        )

    # on the floor of the model's takes (the model reads the pelvis's height above y = 0); back at the end
    world = working.world()  # (T, J, 3, 3), (T, J, 3): for the floor, the depth check and the action channels
    lift = model.floor_lift(working, world[1])  # model units
    content, working = raised(content, lift), raised(working, lift)
    world = (world[0], world[1] + np.array([0.0, lift, 0.0]))
    # features and encode: the content's latents (T, Z) and the root path a transfer keeps
    content_latents, root = model.encode_motion(working)
    # check that the model can represent this content (a warning when far worse than its held-out takes)
    error_cm = reconstruction_error_cm(model, working, content_latents, root, world[1])
    warning = depth_warning(model, error_cm, content_name)
    if warning is not None:
        _say(notes, warning)
    # whiten, match, place, cross-fade and colour: one track per style library on a content-time grid
    grid = content_grid(working.num_frames)  # (G,) content frames
    actions = action_channels(working, world)  # (T, A) what the body does, matched beside the latents
    in_place = clip_in_place(working, world)  # its feet slide under a pelvis that stays: nothing to pin
    walk_said = True  # a note on the content's walk already says why its legs may keep their own action
    if not config.reverse_style and walks_backwards(actions):
        _say(notes, (
            f"note: {content_name} walks backwards; the style's forward steps will not match its legs, which "
            "then keep their own action: --reverse-style adds the style clips played backwards"
        ))  # fmt: skip
    elif walks_sideways(actions):
        _say(notes, (
            f"note: {content_name} walks sideways; the style's steps will match its legs only where the style "
            "clips step sideways too, elsewhere its legs keep their own action and pace (the style shows in "
            "the upper body)"
        ))  # fmt: skip
    else:
        walk_said = False
    layout = action_layout(working.skeleton)  # which action columns say what, each body part's
    still = still_frames(actions, layout, fps)  # (T,) a stop or an idle: no pace to take
    tracks = [
        style_track(content_latents, actions, library, grid, config, fps, layout, still)
        for library in libraries
    ]
    # retime: strength and shares mix the tracks; the mixed rate gives each output frame's content time
    grid_s = grid / fps
    strength = config.strength_schedule.at(grid_s)
    shares = [np.ones_like(grid)]
    if second_style is not None:
        mix = change.at(grid_s)
        shares = [1 - mix, mix]
    content_on_grid = interpolate_rows(content_latents, grid)  # (G, Z)
    latents, log_rate = mix_tracks(content_on_grid, strength, tracks, shares)
    if "legs" in config.kept_parts:  # legs performed as in the content set its pace, as kept legs always do
        log_rate = np.zeros_like(log_rate)
    content_time = output_content_times(grid, log_rate)  # (T_out,) content frames
    # parts styled by another library: their own track, on the same timeline, joint by joint
    part_tracks = []  # (joints, track) of each part styled by another library
    part_latents = []
    for joints, library in by_part:
        track = style_track(content_latents, actions, library, grid, config, fps, layout, still)
        part_latents.append(mix_tracks(content_on_grid, strength, [track], [np.ones_like(grid)])[0])
        part_tracks.append((joints, track))
    # decode on the output's timeline, the root path read at the same content times: the styled latents,
    # each part's, and for residual decoding the content's own (the model's reading of it), in one pass
    residual = config.decode != "plain"
    root_out = root.sample(content_time)
    styled, *decoded = _decoded(
        model, [latents, *part_latents, *([content_on_grid] if residual else [])], grid, content_time,
        root_out, config,
    )  # fmt: skip
    for (joints, _), part in zip(part_tracks, decoded):
        styled = styled.with_joints(part, joints)
    _check_finite(styled, "decoding", content_name)
    positions, content_frames = output_frames(
        content_time, per_model_frame, content.num_frames, config.timing
    )
    strength_out = config.strength_schedule.at(content_frames / content.fps)  # (N,)
    # each clip read once at the output's frames: the decoded styled clip, the content, and for residual
    # decoding the model's reading of the content on the same timeline
    styled_at, content_at = frames_of(styled, positions), frames_of(content, content_frames)
    base_at = None
    if config.decode == "plain":  # the report's output: the decoded clip, on the content's own skeleton
        motion = Motion(content.skeleton, styled_at.rotations, styled_at.translations, content.fps)
        clean_share = np.ones_like(strength_out)  # the report's clean-up, whatever the strength
    else:
        base_at = frames_of(decoded[-1], positions)
        motion = compose_residual(styled_at, base_at, content_at, strength_out, config.residual_smooth_s)
        # the feet planted in full from a small strength on (none at 0, where the output is the content):
        # a clean-up blended in by the strength itself left half-styled strides half pinned, sliding
        clean_share = np.clip(strength_out / CLEAN_FULL_STRENGTH, 0.0, 1.0)
    # body parts that keep the content's action: kept ones throughout, the others where the style does
    # another. Their target carries the style's posture and statistics as far as the strength goes, so they
    # keep the content's action at every strength; plain decoding keeps it only as far as the strength goes
    # (at strength 0 its output stays the model's reading)
    keep = keep_weights(tracks, shares, part_tracks, content.skeleton, grid, content_time, positions, kept)
    automatic = joint_set(set(range(content.skeleton.num_joints)) - set(kept.tolist()))
    legs = body_parts(content.skeleton).get("legs", np.zeros(0, dtype=np.int64))
    automatic_legs = joint_set(set(legs.tolist()) & set(automatic.tolist()))
    # the root follows the style's stride only where the legs take it: where they keep the content's action
    # they keep its path too (legs that took a standing clip's statistics walked 10 % short). Read before
    # plain decoding's strength scales the keep: the clean-up itself is blended in by the strength
    legs_keep = (
        np.max(keep[:, automatic_legs], axis=1) if len(automatic_legs) else np.zeros(len(keep))
    )  # (N,)
    kept_share = float(np.mean(legs_keep > 0.5)) if len(legs_keep) else 0.0
    if kept_share >= LEGS_KEPT_NOTE and not walk_said:
        _say(notes, (
            f"note: {content_name}: its legs keep their own action over {100 * kept_share:.0f} % of the clip (they "
            "act otherwise than in the style's windows: another pace, gait or turn, or no steps), so the style shows "
            "above them there"
        ))  # fmt: skip
    root_share = config.root_follows_legs * (1 - legs_keep)  # (N,)
    # ... and as far as the strength goes: fading out, the pelvis comes back to the content's path over planted
    # feet (blended back with the clean-up below strength 0.25, a stride's move slid the feet 75 to 150 cm/s)
    root_applied = np.clip(strength_out, 0.0, 1.0)  # (N,)
    _by_strength(keep, automatic, strength_out, config.decode)
    lowest_ground = _lowest_ground(working, world[1])  # none without feet
    root_moved = np.zeros((len(strength_out), 3))  # (N, 3) world: the clean-up's ground move of the pelvis
    if config.cleanup:
        # on the content's floor (toes the style's statistics swing through it are lifted); where the style's
        # statistics alone colour the content (the fallback, the statistics methods) its legs step as the
        # content's do, so its contacts hold too and its feet's clearance of the ground
        on_statistics = fallback_weights(tracks, shares, grid, content_time, positions) > 0.5  # (N,)
        held = held_footing(content_at, on_statistics) if np.any(on_statistics) else None
        also, floor, ceiling = held if held is not None else (None, None, None)
        cleaned = blend_by_strength(
            motion,
            plant_feet(
                motion, root_share, also, floor, lowest_ground, root_applied, ceiling, needed=clean_share > 0,
                in_place=in_place,
            ),
            clean_share,
        )  # fmt: skip
        root_moved = ground_shift(motion, cleaned)
        motion = cleaned
    if np.any(keep > 0):
        reference = content_at if base_at is None else base_at
        unstyled = joint_set([*kept, *styled_joints])  # kept, or styled by another library
        colour = config.kept_statistics * statistics_weights(
            tracks, shares, content.skeleton, grid, content_time, positions, unstyled
        )  # (N, J) the style's statistics on legs that keep the content's action where the style does another
        coloured_at = None
        if np.any(colour > 0):
            statistics = TransferConfig.of(config, method="wct")
            coloured_tracks = [
                style_track(content_latents, actions, s, grid, statistics, fps) for s in libraries
            ]
            coloured, _ = mix_tracks(content_on_grid, strength, coloured_tracks, shares)
            if base_at is None:  # the statistics' change is to the model's reading
                coloured_decoded, base = _decoded(
                    model, [coloured, content_on_grid], grid, content_time, root_out, config
                )
                reference = frames_of(base, positions)
            else:
                [coloured_decoded] = _decoded(model, [coloured], grid, content_time, root_out, config)
            coloured_at = frames_of(coloured_decoded, positions)
        posture = keep_weights(
            tracks, shares, part_tracks, content.skeleton, grid, content_time, positions, kept, "posture"
        )  # (N, J), read as the keep is
        _by_strength(posture, automatic, strength_out, config.decode)
        target = keep_target(content_at, styled_at, reference, posture, strength_out, coloured_at, colour)
        if np.any(root_moved) and content.skeleton.pelvis not in kept:
            # on the path the clean-up gave the root: the content's own place, which the path following the
            # stride has left behind, let a long take's stand slide 80 cm as its legs came to keep its action
            target = shifted_pelvis(target, root_moved)
        target = arms_hanging(target, motion, content_at, keep, kept)
        motion = blend_by_strength(motion, target, keep)
        if config.cleanup and (coloured_at is not None or np.any(keep[:, automatic_legs] > 0)):
            # where the legs keep the content's stepping, the content's own contacts hold as well, and its
            # feet's clearance of the ground: the statistics change how the legs move, not when the feet
            # land nor whether a swinging foot skims the floor; nor the pelvis's height (lowered to reach
            # the pins, a run given a walk's statistics crouched 6 cm below both clips)
            kept_legs = np.max(keep[:, legs], axis=1) > 0.5  # (N,)
            also, floor, ceiling = held_footing(content_at, kept_legs)  # (N, F), (N, F, 2) twice
            if coloured_at is not None:  # coloured legs: the whole clean-up again
                motion = blend_by_strength(
                    motion,
                    plant_feet(
                        motion,
                        root_share,
                        also,
                        floor,
                        lowest_ground,
                        root_applied,
                        ceiling,
                        1 - legs_keep,
                        clean_share > 0,
                        in_place,
                        root_moved,  # the two clean-ups' moves of the root together within its bound
                    ),  # fmt: skip
                    clean_share,
                )
            else:
                # legs that keep the content's action (a turn matched against straight windows) mix two
                # gaits, whose stance feet slide: pinned again as far as they keep it, the root left where
                # the clean-up put it (moving it again would shift the whole path), and kept above the ground
                # in full from a small share on: a blend of two gaits slides whatever its share (a turning
                # walk's legs at 0.09 of its own turn slid a planted foot 13 cm)
                pin_share = np.clip(legs_keep / PIN_FULL_KEEP, 0.0, 1.0) * clean_share  # the strength once
                pinned = plant_feet(
                    motion,
                    0.0,
                    also,
                    floor,
                    lowest_ground,
                    foot_ceiling=ceiling,
                    lowering_share=1 - legs_keep,
                    needed=pin_share > 0,
                    in_place=in_place,
                )
                motion = blend_by_strength(motion, pinned, pin_share)
                lifted = (keep > 0) * clean_share[:, None]  # (N, J); the lift turns leg joints only
                motion = blend_by_strength(
                    motion, lift_to_ground(motion, lowest_ground, np.any(lifted[:, legs] > 0, axis=1)), lifted
                )
            motion = motion.with_joints(content_at, kept, translations=True)  # kept parts stay the content's
    _check_finite(motion, "foot clean-up" if config.cleanup else "decoding", content_name)
    record = explain(tracks, libraries, content_time, fps, config)
    record["notes"] = [*notes, *record["notes"]]
    if second_style is not None:  # each style's share over content time: the transition or blend
        record["second_weight"] = {"times_s": list(change.times_s), "values": list(change.values)}
    if part_tracks:
        part_record = explain(
            [t for _, t in part_tracks], [lib for _, lib in by_part], content_time, fps, config
        )
        record["notes"] += [note for note in part_record["notes"] if note not in record["notes"]]
        record["part_styles"] = [
            {"parts": list(parse_parts(names, "part_styles")), **entry}
            for names, entry in zip((part_styles or {}).keys(), part_record["styles"])
        ]
    if size != 1.0 or lift != 0.0:  # back to the content's own floor and size, on its own skeleton
        translations = raised(motion, -lift).translations / size
        given_at = frames_of(given, content_frames)  # where the output is the content, exactly its values
        exact = strength_out <= 0
        translations[exact] = given_at.translations[exact]
        translations[:, kept] = given_at.translations[:, kept]
        motion = Motion(given.skeleton, motion.rotations, translations, motion.fps)
    original_at = frames_of(original, content_frames)
    motion = model.on_clip_hierarchy(motion, original_at)  # on the content's skeleton
    # a root-motion joint above the pelvis (a game rig's) carries the pelvis's new place, as in the content
    root_joint = root_motion_joint(original)
    if root_joint is not None:
        motion = root_carries_pelvis(motion, original_at, root_joint)
    record["output_frames"] = motion.num_frames  # as written, at the content's frame rate
    record["output_fps"] = motion.fps
    record["content_reconstruction_cm"] = round(error_cm, 3)
    return TransferResult(motion, record), content_frames


SINK_CM = 1.0  # the clean-up lets toes stand at most this far below the content's ground


def _by_strength(weights: FloatArray, automatic: IntArray, strength: FloatArray, decode: str) -> None:
    """Per-joint weights (N, J) of the content's kept action, in place, as far as the strength (N,) goes at
    the automatic joints (A,): plain decoding keeps the content's action only as far as the strength goes
    (at strength 0 its output stays the model's reading); residual decoding at strength 0 is the content
    already, to the last bit."""
    if decode == "plain":
        weights[:, automatic] *= np.clip(strength, 0.0, 1.0)[:, None]
    else:
        weights[np.ix_(strength <= 0, automatic)] = 0.0


def _lowest_ground(content: Motion, positions: FloatArray) -> float | None:
    """The lowest toes' ground level (file units) the clean-up lets an output stand on: `SINK_CM` below the
    content's (the floor the output walks on; positions (T, J, 3) of its frames). Statistics that lower
    the feet lower a clip's own ground level (the 5th percentile of its toe heights): a walk's statistics on
    a run's legs had a foot 3 cm through the floor, and an exhausted walk's on a walk swung the toes 4 cm
    through it, its stance then read as a foot in the air. None without feet."""
    if not has_feet(content):
        return None
    return ground_level(content, positions) - SINK_CM / centimetres_per_unit(content.skeleton)


def _decoded(
    model: StyleModel,
    latents: Sequence[FloatArray],
    grid: FloatArray,
    content_time: FloatArray,
    root: RootPath,
    config: TransferConfig,
) -> list[Motion]:
    """Latent tracks (G, Z) on the content-time grid, each decoded on the output's timeline (content_time
    (T_out,)) on the root path read at the same times."""
    on_output = [on_output_frames(track, grid, content_time) for track in latents]
    return decode_plain(model, on_output, root, config.smooth_s)


def short_content_note(content_name: str, duration_s: float, patch_s: float) -> str:
    """The note for a content shorter than one patch of `patch_s` seconds."""
    return (
        f"note: {content_name}: {duration_s:.2f} s, shorter than one patch ({patch_s:.2f} s): the whole "
        "clip is matched as one stretched window, so it takes the style's manner only roughly and its length "
        "follows that window's stretch (a cycle that loops: --loop reads it as one, three times over)"
    )


_SAID_ONCE: set[object] = set()  # the keys of notes printed once per process


def _say(notes: list[str], text: str, once: object = None) -> None:
    """Print a note or warning (stderr, through logging) and keep it for the explain record; with a key
    `once`, printed only the first time that key comes in this process (kept in the record every time)."""
    if once is None or once not in _SAID_ONCE:
        log.warning("%s", text)
        if once is not None:
            _SAID_ONCE.add(once)
    notes.append(text)


def _check_finite(motion: Motion, step: str, content_name: str) -> None:
    """A `ResultError` naming the step when a result holds NaN or infinite values: nothing is written."""
    if not motion.is_finite():
        raise ResultError(f"{content_name}: the {step} produced NaN or infinite values; nothing written")
