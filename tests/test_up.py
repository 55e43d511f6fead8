"""Clips whose files stand along +Z: found, worked on with +Y up, and written back standing along +Z."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastyle import write_bvh
from elastyle.core.motion import Motion
from elastyle.core.up import standing_axis, turned_back, turned_up
from elastyle.errors import ConfigError
from elastyle.io.dataset import ClipRef, read_clip
from tests.conftest import clip_named

CONTENTS = (
    "walk_normal_005", "run_active_010", "walk-turn-left_normal_010", "wave-both-hands_elderly_015",
    "raise-up-left-hand_normal_005", "wave-right-hand_feminine_005",
)  # fmt: skip


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "elastyle.cli", *args], capture_output=True, text=True)


def _z_up_copy(clip: ClipRef, path: Path) -> Path:
    """The clip written as a +Z-up exporter would: the whole clip turned a quarter about X (its root's
    rotation and position), the rest pose as it is."""
    motion, layout = clip.read(up="y")
    write_bvh(path, turned_back(motion, "z"), layout)
    return path


def test_every_content_stands_along_y_and_its_z_up_file_along_z(dataset_clips: list[ClipRef]) -> None:
    for stem in CONTENTS:
        motion = clip_named(dataset_clips, f"dataset-2_{stem}").read(up="y")[0]
        assert standing_axis(motion) == "y", stem
        z_up = turned_back(motion, "z")
        assert standing_axis(z_up) == "z", stem
        assert np.abs(turned_up(z_up, "z").positions() - motion.positions()).max() < 1e-9


def test_a_body_lying_along_z_and_crawling_along_it_stays_y_up(dataset_clips: list[ClipRef]) -> None:
    """A body along +Z whose pelvis travels along that axis lies (a crawl): no standing axis, so +Y."""
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read(up="y")[0]
    lying = turned_back(walk, "z")  # along +Z, travelling along -Y
    pelvis = walk.positions()[:, walk.skeleton.pelvis]
    travelled = np.linalg.norm(pelvis[:, [0, 2]] - pelvis[0, [0, 2]], axis=1)  # (T,) cm
    translations = lying.translations.copy()
    translations[:, 0, 2] += travelled  # now also along its long axis, as far as it walked
    assert standing_axis(Motion(lying.skeleton, lying.rotations, translations, lying.fps)) == "y"


def test_a_z_up_pair_transfers_as_its_y_up_pair_and_is_written_z_up(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    content, style = (
        clip_named(dataset_clips, f"dataset-2_{s}") for s in ("walk_normal_005", "walk_elderly_010")
    )
    z_content, z_style = (_z_up_copy(c, tmp_path / f"z_{c.stem}.bvh") for c in (content, style))
    y_content, y_style = (tmp_path / f"y_{c.stem}.bvh" for c in (content, style))
    y_content.write_bytes(content.data())
    y_style.write_bytes(style.data())
    y_out, z_out = tmp_path / "y_out.bvh", tmp_path / "z_out.bvh"
    assert (
        _cli("transfer", str(y_content), "--style", str(y_style), "-o", str(y_out), "--no-cache").returncode
        == 0
    )
    result = _cli("transfer", str(z_content), "--style", str(z_style), "-o", str(z_out), "--no-cache")
    assert result.returncode == 0, result.stderr
    assert f"note: {z_style} stands along +Z" in result.stderr  # the style is read first
    assert result.stderr.count("stands along +Z") == 1  # one note, though the style stands so too
    ours, layout = read_clip(z_out)
    assert layout.up == "z"
    assert np.abs(ours.positions() - read_clip(y_out)[0].positions()).max() < 1e-6  # the same output
    as_written = read_clip(z_out, up="y")[0].positions()  # the file itself: the body along +Z
    pelvis = as_written[:, ours.skeleton.pelvis]
    assert np.median(as_written.max(axis=1)[:, 2] - pelvis[:, 2]) > 30  # the head above the hips, in cm
    # read as +Y up, the same files give another output (the model reads a body lying on its side)
    told = tmp_path / "told.bvh"
    result = _cli(
        "transfer", str(z_content), "--style", str(z_style), "-o", str(told), "--no-cache", "--up", "y"
    )
    assert result.returncode == 0 and "read with +Z up" not in result.stderr
    assert "its body stands along +Z, but it is read with +Y up as --up says" in result.stderr
    assert read_clip(told, up="y")[0].num_frames != read_clip(z_out, up="y")[0].num_frames


def test_a_z_up_clip_converts_to_a_y_up_gltf_and_reports_its_height(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    pytest.importorskip("pygltflib")
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005")
    z_up = _z_up_copy(walk, tmp_path / "z.bvh")
    glb = tmp_path / "z.glb"
    assert _cli("convert", str(z_up), "-o", str(glb)).returncode == 0
    positions = read_clip(glb)[0].positions()  # glTF: +Y up, metres
    assert np.abs(positions - walk.read()[0].positions() / 100).max() < 1e-4
    y_up = tmp_path / "y.bvh"
    y_up.write_bytes(walk.data())
    infos = [_cli("info", str(path)).stdout for path in (z_up, y_up)]
    assert infos[0].split("height:")[1].split()[0] == infos[1].split("height:")[1].split()[0]
    assert "up:       +Z" in infos[0] and "up:       +Y" in infos[1]


def test_a_stated_up_is_checked_and_read_by_training(
    tmp_path: Path, dataset_clips: list[ClipRef], caplog
) -> None:  # type: ignore[no-untyped-def]
    from elastyle.training.clips import load_motions

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005")
    z_up = _z_up_copy(walk, tmp_path / "z.bvh")
    with pytest.raises(ConfigError, match="up must be one of auto, y, z"):
        read_clip(z_up, up="Z")
    with caplog.at_level("WARNING"):
        read_clip(z_up, up="y")
    assert "its body stands along +Z, but it is read with +Y up as --up says" in caplog.text
    # training reads its clips with the axis it is told
    clips = [ClipRef(str(_z_up_copy(walk, tmp_path / f"z_{take:03d}.bvh"))) for take in range(9)]
    as_filed = load_motions(clips, None, up="y")
    turned = load_motions(clips, None, up="auto")
    raw = read_clip(z_up, up="y")[0]
    assert all(np.array_equal(m.rotations, raw.rotations) for m in as_filed)
    assert all(np.abs(m.positions() - walk.read()[0].positions()).max() < 1e-9 for m in turned)


def test_a_z_up_contents_explain_file_says_it_was_turned(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    import json

    content, style = (
        clip_named(dataset_clips, f"dataset-2_{s}") for s in ("walk_normal_005", "walk_elderly_010")
    )
    z_content = _z_up_copy(content, tmp_path / "z.bvh")
    y_style = tmp_path / "y_style.bvh"
    y_style.write_bytes(style.data())  # a Y-up style with a Z-up content
    explain = tmp_path / "e.json"
    result = _cli("transfer", str(z_content), "--style", str(y_style), "-o", str(tmp_path / "o.bvh"),
                  "--explain", str(explain), "--no-cache")  # fmt: skip
    assert result.returncode == 0, result.stderr
    notes = json.loads(explain.read_text())["notes"]
    assert any("read with +Z up, turned to +Y up" in note for note in notes), notes
