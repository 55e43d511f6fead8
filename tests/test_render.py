"""Rendering clips to GIF/MP4: projection and timing helpers by hand, real clips drawn into real files."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from elastyle.core.motion import Motion
from elastyle.errors import ElastyleError, OutputError, UsageError
from elastyle.io.bvh_read import read_bvh
from elastyle.io.dataset import ClipRef
from elastyle.viewer.render import (
    PANEL_PX,
    bones,
    joint_sides,
    project,
    render_clips,
    sample_positions,
)
from elastyle.viewer.render import (
    _gif_durations_ms as gif_durations_ms,
)
from tests.conftest import clip_named

pytest.importorskip("matplotlib", reason="rendering needs the [render] extra (matplotlib)")
Image = pytest.importorskip("PIL.Image", reason="rendering needs the [render] extra (Pillow)")

CLIP_FRAMES = {
    "dataset-2_walk_normal_005": 20,
    "dataset-2_walk_exhausted_005": 18,
    "dataset-2_run_normal_001": 22,
}


def test_projection_keeps_y_up_and_ground_level() -> None:
    up = project(np.array([[0.0, 100.0, 0.0]]))[0]
    assert up[0] == pytest.approx(0.0) and up[1] > 90  # straight up on screen
    nearer = project(np.array([[0.0, 0.0, 50.0]]))[0]  # +Z (towards the camera) sits lower on screen
    assert nearer[1] < 0


def test_skeleton_drawing_helpers(three_channel_bvh: Path) -> None:
    skeleton = read_bvh(three_channel_bvh)[0].skeleton
    assert bones(skeleton).tolist() == [[0, 1], [0, 2], [2, 3], [0, 4], [4, 5]]
    assert joint_sides(skeleton).tolist() == [0, 0, 1, 1, 2, 2]


def test_sampling_holds_the_last_frame() -> None:
    positions = np.arange(3, dtype=np.float64)[:, None, None] * np.ones((3, 2, 3))  # (3, 2, 3)
    sampled = sample_positions(positions, 10.0, np.array([0.0, 0.05, 0.2, 5.0]))
    np.testing.assert_allclose(sampled[:, 0, 0], [0.0, 0.5, 2.0, 2.0])


def test_gif_delays_stay_on_the_clock() -> None:
    delays = gif_durations_ms(30, 30.0)
    assert set(delays) <= {30, 40} and sum(delays) == 1000


def test_tiny_clip_renders_and_refuses_to_overwrite(three_channel_bvh: Path, tmp_path: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    out = tmp_path / "tiny.gif"
    assert render_clips([motion], ["tiny.bvh"], out, fps=30, progress=False) == 1
    before = out.read_bytes()
    with pytest.raises(OutputError, match="already exists"):
        render_clips([motion], ["tiny.bvh"], out, fps=30, progress=False)
    assert out.read_bytes() == before
    render_clips([motion, motion], ["a.bvh", "b.bvh"], out, fps=30, force=True, progress=False)
    assert Image.open(out).size == (2 * PANEL_PX[0], PANEL_PX[1])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.gif", "tiny_xyz.bvh"]  # no temporary files


def test_bad_outputs_are_refused_before_work(three_channel_bvh: Path, tmp_path: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    with pytest.raises(UsageError, match=r"out\.avi: unknown video format"):
        render_clips([motion], ["tiny.bvh"], tmp_path / "out.avi", progress=False)
    with pytest.raises(OutputError, match="does not exist"):
        render_clips([motion], ["tiny.bvh"], tmp_path / "missing" / "out.gif", progress=False)
    with pytest.raises(ElastyleError, match="GIF players slow down"):
        render_clips([motion], ["tiny.bvh"], tmp_path / "fast.gif", fps=120, progress=False)
    with pytest.raises(ElastyleError, match="no clips"):
        render_clips([], [], tmp_path / "none.gif", progress=False)


def test_missing_extra_names_the_install_command(
    three_channel_bvh: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # makes `import imageio_ffmpeg` fail
    with pytest.raises(ElastyleError, match=r"pip install 'elastyle\[render\]'"):
        render_clips([motion], ["tiny.bvh"], tmp_path / "out.mp4", progress=False)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(ElastyleError, match=r"matplotlib and Pillow.*pip install 'elastyle\[render\]'"):
        render_clips([motion], ["tiny.bvh"], tmp_path / "out.gif", progress=False)
    assert not list(tmp_path.glob("out*"))


@pytest.fixture(scope="module")
def short_clips(dataset_clips: list[ClipRef]) -> list[tuple[Motion, str]]:
    clips = []
    for stem, frames in CLIP_FRAMES.items():
        motion = clip_named(dataset_clips, stem).read()[0]
        clips.append((motion.slice(0, frames), stem + ".bvh"))
    return clips


def test_real_clips_render_side_by_side_to_gif(short_clips: list[tuple[Motion, str]], tmp_path: Path) -> None:
    motions, labels = [m for m, _ in short_clips], [label for _, label in short_clips]
    out = tmp_path / "three.gif"
    assert render_clips(motions, labels, out, progress=False) == 22  # the longest clip; the others hold
    gif = Image.open(out)
    assert gif.n_frames == 22 and gif.size == (3 * PANEL_PX[0], PANEL_PX[1])
    for frame in (0, 19, 21):
        gif.seek(frame)
        pixels = np.asarray(gif.convert("RGB"), dtype=np.float64)  # (H, W, 3)
        assert 30 <= gif.info["duration"] <= 40
        for panel in range(3):
            area = pixels[:, panel * PANEL_PX[0] : (panel + 1) * PANEL_PX[0]]
            assert area.var() > 0
            # bones of both sides are drawn: strongly blue (left) and strongly red (right) pixels
            assert np.sum((area[..., 2] > 150) & (area[..., 0] < 80)) > 20
            assert np.sum((area[..., 0] > 150) & (area[..., 2] < 80)) > 20
    with pytest.raises(OutputError, match="already exists"):
        render_clips(motions, labels, out, progress=False)


def test_a_clip_on_another_floor_is_drawn_as_on_its_own(
    short_clips: list[tuple[Motion, str]], tmp_path: Path
) -> None:
    """Each panel is drawn about its clip's own ground: a rig whose origin is at its pelvis (its floor 89 cm
    below y = 0) was drawn half out of its panel."""
    from elastyle.core.ground import raised

    motion, label = short_clips[0]
    frames = []
    for name, clip in (("own.gif", motion), ("low.gif", raised(motion, -89.0))):
        render_clips([clip], [label], tmp_path / name, progress=False)
        gif = Image.open(tmp_path / name)
        gif.seek(gif.n_frames - 1)
        frames.append(np.asarray(gif.convert("RGB"), dtype=np.float64))
    assert np.abs(frames[0] - frames[1]).max() < 1e-9


def test_real_clips_render_to_mp4(short_clips: list[tuple[Motion, str]], tmp_path: Path) -> None:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="MP4 output needs imageio-ffmpeg")
    motions, labels = [m for m, _ in short_clips], [label for _, label in short_clips]
    out = tmp_path / "three.mp4"
    assert render_clips(motions, labels, out, fps=30, progress=False) == 22
    assert out.read_bytes()[4:8] == b"ftyp"
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert tuple(meta["size"]) == (3 * PANEL_PX[0], PANEL_PX[1])
    assert sum(1 for _ in reader) == 22


def test_render_command_writes_once(three_channel_bvh: Path, tmp_path: Path) -> None:
    import argparse

    from elastyle.cli.view import add_view_commands

    parser = argparse.ArgumentParser(prog="elastyle")
    add_view_commands(parser.add_subparsers(dest="command", required=True))
    out = tmp_path / "cli.gif"
    args = parser.parse_args(
        ["render", str(three_channel_bvh), "-o", str(out), "--fps", "20", "--no-progress"]
    )
    assert args.run(args) == 0 and Image.open(out).n_frames == 1
    with pytest.raises(OutputError, match="already exists"):
        args.run(args)
    args = parser.parse_args(["render", str(three_channel_bvh), "-o", str(three_channel_bvh), "--force"])
    with pytest.raises(OutputError, match="would overwrite"):
        args.run(args)
