"""Figures of one transfer (`elastyle eval OUT --content C --style S`)."""

from __future__ import annotations

import numpy as np

from elastyle.core.motion import Motion
from elastyle.eval.metrics import (
    arm_swing_hz,
    cadence_steps_s,
    centimetres_per_unit,
    floor_skating_cm_s,
    foot_skating_cm_s,
    jerk,
    timing_error,
)

STILL_JERK_CM_S3 = (
    1.0  # a content whose joints' mean jerk is below this (cm/s^3) holds still; motion: 1e3 to 1e5
)


def bone_length_error_cm(motion: Motion, reference: Motion) -> float:
    """Largest difference (cm) between a bone's length in `motion` and in `reference` (first frames), each
    clip in its own length unit."""
    parents = motion.skeleton.parents
    children = np.flatnonzero(parents >= 0)
    ours = motion.positions() * centimetres_per_unit(motion.skeleton)
    theirs = reference.positions()[:1] * centimetres_per_unit(reference.skeleton)
    length = np.linalg.norm(ours[:, children] - ours[:, parents[children]], axis=-1)  # (T, J-1)
    expected = np.linalg.norm(theirs[:, children] - theirs[:, parents[children]], axis=-1)
    # the pelvis's own translation is animated: leave out bones from joints above it
    keep = children > motion.skeleton.pelvis
    if not np.any(keep):  # no bones below the pelvis: nothing to measure
        return 0.0
    return float(np.abs(length - expected)[:, keep].max())


def transfer_figures(output: Motion, content: Motion, style: Motion) -> dict[str, float]:
    positions = {
        name: m.positions() for name, m in (("output", output), ("content", content), ("style", style))
    }
    cadence = {
        name: cadence_steps_s(m, positions[name])
        for name, m in (("output", output), ("content", content), ("style", style))
    }
    figures = {f"cadence_{name}_steps_s": value for name, value in cadence.items()}
    figures["timing_error"] = timing_error(cadence["output"], cadence["content"], cadence["style"])
    for name, motion in (("output", output), ("content", content), ("style", style)):
        figures[f"arm_swing_{name}_hz"] = arm_swing_hz(motion, positions[name])
        figures[f"skating_{name}_cm_s"] = floor_skating_cm_s(motion, positions[name])
        figures[f"skating_own_contacts_{name}_cm_s"] = foot_skating_cm_s(motion, positions[name])
    content_jerk = jerk(positions["content"] * centimetres_per_unit(content.skeleton), content.fps)
    output_jerk = jerk(positions["output"] * centimetres_per_unit(output.skeleton), output.fps)
    # a content that holds still has no jitter to compare with (its jerk is rounding): n/a
    figures["jitter_vs_content"] = (
        output_jerk / content_jerk if content_jerk > STILL_JERK_CM_S3 else float("nan")
    )
    figures["bone_length_error_cm"] = bone_length_error_cm(output, content)
    figures["duration_output_s"] = output.duration_s
    figures["duration_content_s"] = content.duration_s
    return figures
