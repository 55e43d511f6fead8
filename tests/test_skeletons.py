"""Legs and sides on any skeleton: the same real walk under other naming schemes (CMU, 3ds Max biped,
camel-case, Blender's .l/.r) and with no side names at all gives the same legs, the same planted feet
and the same cadence; a skeleton without legs says so instead of measuring nothing in silence."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastyle import write_bvh
from elastyle.core.body import find_limbs
from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.eval.metrics import cadence_steps_s
from elastyle.io.dataset import ClipRef
from elastyle.steps.cleanup import clean_feet
from tests.conftest import THREE_CHANNEL_BVH, clip_named

CMU = {
    "joint_Root": "Root", "Hips": "Hips", "Spine": "LowerBack", "Chest": "Spine1", "Neck": "Neck", "Head": "Head",
    "Shoulder_L": "LeftShoulder", "UpperArm_L": "LeftArm", "LowerArm_L": "LeftForeArm", "Hand_L": "LeftHand",
    "Shoulder_R": "RightShoulder", "UpperArm_R": "RightArm", "LowerArm_R": "RightForeArm", "Hand_R": "RightHand",
    "UpperLeg_L": "LeftUpLeg", "LowerLeg_L": "LeftLeg", "Foot_L": "LeftFoot", "Toes_L": "LeftToeBase",
    "UpperLeg_R": "RightUpLeg", "LowerLeg_R": "RightLeg", "Foot_R": "RightFoot", "Toes_R": "RightToeBase",
}  # fmt: skip


def _biped(name: str) -> str:
    side = " L" if name.endswith("_L") else " R" if name.endswith("_R") else ""
    return "Bip01 " + name.removesuffix("_L").removesuffix("_R") + side


SCHEMES = {
    "cmu": lambda n: CMU[n],
    "biped": _biped,
    "camel": lambda n: n.replace("_L", "L").replace("_R", "R"),
    "blender": lambda n: n.replace("_L", ".l").replace("_R", ".r"),
    "unnamed": None,
}


def _renamed(motion: Motion, scheme: str) -> Motion:
    skeleton = motion.skeleton
    rename = SCHEMES[scheme]
    names = (
        tuple(f"j{i}" for i in range(skeleton.num_joints))
        if rename is None
        else tuple(map(rename, skeleton.names))
    )
    other = Skeleton(names, skeleton.parents, skeleton.offsets, skeleton.end_sites)
    return Motion(other, motion.rotations, motion.translations, motion.fps)


@pytest.fixture(scope="module")
def walk(dataset_clips: list[ClipRef]) -> Motion:
    return clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0]


@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_legs_feet_and_cadence_on_any_naming(walk: Motion, scheme: str) -> None:
    other = _renamed(walk, scheme)
    ours, theirs = find_limbs(walk.skeleton), find_limbs(other.skeleton)
    for field in ("toes", "ankles", "hips", "hands"):
        np.testing.assert_array_equal(getattr(theirs, field), getattr(ours, field), err_msg=field)
    assert cadence_steps_s(other) == pytest.approx(cadence_steps_s(walk))
    np.testing.assert_allclose(clean_feet(other).positions(), clean_feet(walk).positions(), atol=1e-9)
    if scheme != "unnamed":  # names give mirror pairs too (mirroring and the style library's mirrors)
        np.testing.assert_array_equal(other.skeleton.mirror_pairs(), walk.skeleton.mirror_pairs())


def test_a_skeleton_without_legs_says_so(tmp_path: Path) -> None:
    from elastyle import read_bvh

    good = tmp_path / "good.bvh"
    good.write_text(THREE_CHANNEL_BVH)
    motion = read_bvh(good)[0]
    keep = [0]  # the root alone, and a single chain above it: nothing to stand on
    chain = Skeleton(
        tuple(motion.skeleton.names[j] for j in keep), motion.skeleton.parents[keep], motion.skeleton.offsets[keep],
        motion.skeleton.end_sites[keep],
    )  # fmt: skip
    armless = Motion(chain, motion.rotations[:, keep], motion.translations[:, keep], motion.fps)
    path = tmp_path / "stick.bvh"
    write_bvh(path, armless)
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "eval", str(path), "--content", str(path), "--style", str(path)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "no legs found" in result.stderr and "stick.bvh" in result.stderr


REFEREE = Path(__file__).resolve().parents[2] / "shared" / "referee"


@pytest.mark.slow
def test_eval_skating_agrees_with_the_independent_referee(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """elastyle's floor-based skate against the referee's own code on ten transfer outputs (within 10 %)."""
    if not (REFEREE / "metrics.py").exists():
        pytest.skip(f"the referee is not at {REFEREE}")
    sys.path.insert(0, str(REFEREE))
    try:
        import bvh as referee_bvh  # the referee's own reader and metrics, nothing of elastyle's
        import metrics as referee_metrics
    finally:
        sys.path.remove(str(REFEREE))
    from elastyle import read_bvh, transfer
    from elastyle.eval.metrics import floor_skating_cm_s

    contents = ["walk_normal_005", "walk-turn-left_normal_010", "run_normal_005", "raise-up-left-hand_normal_005",
                "walk_normal_010"]  # fmt: skip
    styles = ["walk_elderly_010", "run_active_020"]
    for content_name in contents:
        content, layout = clip_named(dataset_clips, f"dataset-2_{content_name}").read()
        for style_name in styles:
            style = clip_named(dataset_clips, f"dataset-2_{style_name}").read()[0]
            path = tmp_path / f"{content_name}_{style_name}.bvh"
            write_bvh(path, transfer(content, style).motion, layout)
            ours = floor_skating_cm_s(read_bvh(path)[0])
            theirs = referee_metrics.foot_skate(referee_bvh.read_bvh(str(path)))["skate"]
            assert ours == pytest.approx(theirs, rel=0.1, abs=0.05), path.name
