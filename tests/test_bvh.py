"""BVH reading and writing: hand-made fixtures with hand-checkable answers, and real dataset clips."""

from __future__ import annotations

import random
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from elastyle import BvhError, Motion, read_bvh, write_bvh
from elastyle.io.bvh_read import parse_bvh
from elastyle.io.bvh_write import bvh_bytes, bvh_text
from tests.conftest import THREE_CHANNEL_BVH


def test_three_channel_fixture_has_hand_checkable_positions(three_channel_bvh: Path) -> None:
    motion, layout = read_bvh(three_channel_bvh)
    assert motion.skeleton.names == ("pelvis", "spine", "LeftLeg", "LeftFoot", "RightLeg", "RightFoot")
    assert layout.channels[1] == ("Xrotation", "Yrotation", "Zrotation")
    assert motion.fps == pytest.approx(120, rel=1e-4)
    positions = motion.positions()
    np.testing.assert_allclose(positions[0, 3], [3, 10, 0], atol=1e-9)
    # frame 1: pelvis rotated 90 degrees about X, so the spine (0, 10, 0) points along +Z
    np.testing.assert_allclose(positions[1, 1], [1, 20, 10], atol=1e-9)
    # frame 2: pelvis yaw 90 degrees about Y: the left leg offset (3, 0, 0) goes to (0, 0, -3)
    np.testing.assert_allclose(positions[2, 2], [2, 20, -3], atol=1e-9)


def test_euler_order_is_intrinsic_per_joint(three_channel_bvh: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    expected = Rotation.from_euler("XYZ", [45, 30, 0], degrees=True).as_rotvec()
    np.testing.assert_allclose(motion.rotations[2, 3], expected, atol=1e-12)
    extrinsic = Rotation.from_euler("xyz", [45, 30, 0], degrees=True).as_rotvec()
    assert not np.allclose(motion.rotations[2, 3], extrinsic, atol=1e-3)


def test_write_keeps_layout_and_round_trips(three_channel_bvh: Path, tmp_path: Path) -> None:
    motion, layout = read_bvh(three_channel_bvh)
    out = tmp_path / "out.bvh"
    write_bvh(out, motion, layout)
    again, layout_again = read_bvh(out)
    assert layout_again.channels == layout.channels
    assert "End Site" in out.read_text()
    np.testing.assert_allclose(again.positions(), motion.positions(), atol=1e-4)


@pytest.mark.parametrize("scale", [1.0, 1e9])  # 1e9: whole parts past the digit-by-digit writer's range
def test_written_numbers_read_like_six_decimals(three_channel_bvh: Path, scale: float) -> None:
    motion, layout = read_bvh(three_channel_bvh)
    values = np.array([0.0, -1e-9, 1.5, -0.5, -10.0, 99999.9999999, -123.4567891, 0.25e-6, 7e-7]) * scale
    frames = np.resize(values, (motion.num_frames, 3))
    translations = motion.translations.copy()
    translations[:, 0] = frames  # the pelvis's position channels are written as they are
    text = bvh_text(Motion(motion.skeleton, motion.rotations, translations, motion.fps), layout)
    rows = text.split("Frame Time:")[1].splitlines()[1:]
    assert len(rows) == motion.num_frames and all("  " not in row and row == row.strip() for row in rows)
    written = [row.split()[:3] for row in rows]
    expected = [[f"{v:.6f}".replace("-0.000000", "0.000000") for v in frame] for frame in frames]
    assert written == expected


def test_tabs_crlf_and_spaces_are_accepted() -> None:
    text = THREE_CHANNEL_BVH.replace("  ", "\t").replace("\n", "\r\n")
    motion, _ = parse_bvh(text.encode(), "crlf.bvh")
    assert motion.num_frames == 3


def test_blank_lines_between_frames_are_read_past() -> None:
    """As other BVH readers do (they were refused as an empty row); a blank line where a frame is missing is
    still the error, on its own line."""
    lines = THREE_CHANNEL_BVH.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    spaced = lines[: first + 1] + ["", "  "] + lines[first + 1 : first + 2] + [""] + lines[first + 2 :]
    motion, _ = parse_bvh("\n".join(spaced).encode(), "spaced.bvh")
    np.testing.assert_array_equal(
        motion.rotations, parse_bvh(THREE_CHANNEL_BVH.encode(), "x.bvh")[0].rotations
    )
    missing = (
        lines[: first + 1] + [""] + lines[first + 2 :]
    )  # the second frame gone, a blank line in its place
    with pytest.raises(BvhError, match=f"missing.bvh:{first + 2}: empty row"):
        parse_bvh("\n".join(missing).encode(), "missing.bvh")
    bad = (
        lines[: first + 1] + [""] + lines[first + 1 : first + 2] + [" ".join(["0"] * 20 + ["nan"])]
    )  # a bad value after a blank
    with pytest.raises(BvhError, match=f"bad.bvh:{first + 4}: NaN or infinite value"):
        parse_bvh("\n".join(bad).encode(), "bad.bvh")


def test_a_file_is_written_with_its_line_endings_encoding_frame_time_and_offsets() -> None:
    # a Windows tool's file came back with Unix line endings, its Frame Time 0.00833333 as 0.0083333 (120.0005 fps)
    # and its offsets at six significant digits (111.97668 as 111.977)
    text = THREE_CHANNEL_BVH.replace("\n", "\r\n")
    text = re.sub(r"Frame Time:\s*\S+", "Frame Time: 0.00833333", text)
    text = re.sub(r"OFFSET\s+\S+", "OFFSET 111.97668", text, count=1)
    motion, layout = parse_bvh(text.encode(), "windows.bvh")
    written = bvh_text(motion, layout)
    assert written.count("\r\n") == written.count("\n") and "\r\n" in written
    assert "Frame Time: 0.00833333\r\n" in written and "OFFSET 111.976680 " in written
    assert "\r" not in bvh_text(*parse_bvh(THREE_CHANNEL_BVH.encode(), "unix.bvh"))  # Unix stays Unix
    # its indentation too (two spaces came back as tabs)
    assert "\n  JOINT spine\n  {\n    OFFSET" in bvh_text(
        *parse_bvh(THREE_CHANNEL_BVH.encode(), "spaces.bvh")
    )
    tabbed = THREE_CHANNEL_BVH.replace("  ", "\t")
    assert "\n\tJOINT spine\n\t{\n\t\tOFFSET" in bvh_text(*parse_bvh(tabbed.encode(), "tabs.bvh"))
    classic = bvh_text(*parse_bvh(THREE_CHANNEL_BVH.replace("\n", "\r").encode(), "mac.bvh"))
    assert "\n" not in classic and classic.count("\r") == THREE_CHANNEL_BVH.count(
        "\n"
    )  # (it came back as "\n")
    latin = parse_bvh(THREE_CHANNEL_BVH.replace("pelvis", "H\u00fcfte").encode("latin-1"), "latin.bvh")
    assert bvh_bytes(*latin).count("H\u00fcfte".encode("latin-1")) == 1  # not re-encoded as UTF-8
    assert bvh_bytes(*parse_bvh(b"\xef\xbb\xbf" + THREE_CHANNEL_BVH.encode(), "bom.bvh")).startswith(
        b"\xef\xbb\xbfHIER"
    )
    # UTF-16 with its byte-order mark, either byte order (was refused as binary data): written UTF-16 too
    for order in ("utf-16-le", "utf-16-be"):
        mark = b"\xff\xfe" if order.endswith("le") else b"\xfe\xff"
        wide, wide_layout = parse_bvh(mark + THREE_CHANNEL_BVH.encode(order), "wide.bvh")
        np.testing.assert_array_equal(
            wide.rotations, parse_bvh(THREE_CHANNEL_BVH.encode(), "x.bvh")[0].rotations
        )
        assert bvh_bytes(wide, wide_layout).decode("utf-16") == bvh_text(wide, wide_layout)
    with pytest.raises(BvhError, match="marked as UTF-16 text, but not readable as such"):
        parse_bvh(b"\xff\xfe" + THREE_CHANNEL_BVH.encode("utf-16-le")[:-1] + b"\x00\xd8", "odd.bvh")
    for own in ("0.016667", "0.008333"):  # six decimals, read as 60 and 120 fps
        six = parse_bvh(
            re.sub(r"Frame Time:\s*\S+", f"Frame Time: {own}", THREE_CHANNEL_BVH).encode(), "six.bvh"
        )
        assert f"Frame Time: {own}\n" in bvh_text(*six)
    resampled = Motion(motion.skeleton, motion.rotations, motion.translations, 30.0)
    assert "Frame Time: 0.0333333\r\n" in bvh_text(resampled, layout)  # another rate: its own time


def test_existing_output_is_not_overwritten_without_force(three_channel_bvh: Path, tmp_path: Path) -> None:
    motion, layout = read_bvh(three_channel_bvh)
    out = tmp_path / "out.bvh"
    out.write_text("mine")
    with pytest.raises(Exception, match="already exists"):
        write_bvh(out, motion, layout)
    assert out.read_text() == "mine"
    write_bvh(out, motion, layout, force=True)
    assert out.read_text().startswith("HIERARCHY")


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda t: t[: t.index("MOTION") - 40], "ends inside HIERARCHY"),
        (lambda t: t.replace("Frames: 3", "Frames: 4"), "Frames: 4"),
        (lambda t: t.replace("0 20 0 0 0 0 0", "0 20 0 0 0 0 0 7", 1), "row has 22 values"),
        (lambda t: t.replace("1 20 0 90", "1 20 0 x90"), "not a number"),
        (lambda t: t.replace("1 20 0 90", "1 20 0 nan"), "NaN or infinite"),
        (lambda t: t.replace("1 20 0 90", "1 20 0 90 0"), "row has 22 values"),
        (lambda t: t.replace("1 20 0 90", "1 20 0\n90", 1), "row has 3 values"),
        (lambda t: t.replace("1 20 0 90", "1 20 0 9,0"), "not a number"),
        (
            lambda t: t.replace(
                "Xrotation Yrotation Zrotation\n    End", "Wrotation Yrotation Zrotation\n    End"
            ),
            "unknown channel",
        ),
        (lambda t: t.replace("JOINT RightLeg", "JOINT LeftLeg"), "duplicate joint name"),
        (lambda t: t.replace("Frames: 3", "Frames: 0"), "no frames"),
        (lambda t: "", "empty file"),
        (lambda t: "hello", "not a BVH file"),
    ],
)
def test_bad_files_raise_one_line_bvh_error(mutate, message: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(BvhError, match=message) as raised:
        parse_bvh(mutate(THREE_CHANNEL_BVH).encode(), "bad.bvh")
    assert "\n" not in str(raised.value)
    assert str(raised.value).startswith("bad.bvh")


def test_numbers_python_reads_are_accepted() -> None:
    """Frame values numpy's fast reader refuses but Python's float() reads (digit separators) still load."""
    motion, _ = parse_bvh(THREE_CHANNEL_BVH.replace("1 20 0 90", "1 20 0 9_0").encode(), "separators.bvh")
    reference, _ = parse_bvh(THREE_CHANNEL_BVH.encode(), "plain.bvh")
    np.testing.assert_array_equal(motion.rotations, reference.rotations)


def test_missing_file_and_directory(tmp_path: Path) -> None:
    with pytest.raises(BvhError, match="no such file"):
        read_bvh(tmp_path / "nope.bvh")
    with pytest.raises(BvhError, match="is a directory"):
        read_bvh(tmp_path)


@pytest.mark.slow
def test_dataset_sample_round_trips_channels_and_positions(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    sample = random.Random(0).sample(dataset_clips, 25)
    for clip in sample:
        motion, layout = clip.read()
        text = bvh_text(motion, layout)
        again, _ = parse_bvh(text.encode(), "again")
        np.testing.assert_allclose(again.positions(), motion.positions(), atol=1e-4, err_msg=clip.name)
        # channels: positions exactly, angles equal as rotations (Euler angles may differ by 360 degrees)
        np.testing.assert_allclose(again.translations, motion.translations, atol=1e-4)
        relative = Rotation.from_rotvec(again.rotations.reshape(-1, 3)).inv() * Rotation.from_rotvec(
            motion.rotations.reshape(-1, 3)
        )
        assert np.degrees(relative.magnitude()).max() < 1e-4, clip.name


def test_a_clip_written_without_a_layout_keeps_its_moving_joints(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    """A clip from code (no file layout) whose joint below the root moves (some of the dataset's clips move
    their Hips below a static joint_Root): that joint gets position channels, so the clip reads back in place."""
    from tests.conftest import clip_named

    motion = clip_named(dataset_clips, "dataset-2_walk_elderly_010").read()[0]
    assert np.ptp(motion.translations[:, 1], axis=0).max() > 100  # the Hips travel below a static root
    again, layout = parse_bvh(bvh_text(motion).encode(), "again")
    assert layout.channels[1][:3] == ("Xposition", "Yposition", "Zposition")
    np.testing.assert_allclose(again.positions(), motion.positions(), atol=1e-4)


def test_dataset_clip_matches_dataset_description(walk_clip) -> None:  # type: ignore[no-untyped-def]
    motion, layout = walk_clip.read()
    assert motion.skeleton.num_joints == 22
    assert all(len(c) == 6 for c in layout.channels)
    assert motion.fps == pytest.approx(30, rel=1e-4)
    positions = motion.positions()
    # a person about 1.5 to 1.9 m tall, standing on the ground (cm)
    assert 140 < positions[:, :, 1].max() - 0 < 190
    assert abs(positions[:, :, 1].min()) < 10


@pytest.mark.parametrize("order", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "ZXZ"])
def test_euler_conversions_match_scipy(order: str) -> None:
    from elastyle.io.euler import euler_to_rotvec, rotvec_to_euler

    rng = np.random.default_rng(0)
    angles = rng.uniform(-180, 180, size=(400, 3))
    angles[:, 1] = rng.uniform(-89, 89, size=400) if len(set(order)) == 3 else rng.uniform(1, 179, size=400)
    angles[:3] = [[0, 0, 0], [10, 90, 20], [30, -90, -40]]  # identity and gimbal lock
    reference = Rotation.from_euler(order, angles, degrees=True)
    ours = euler_to_rotvec(order, angles)
    np.testing.assert_allclose(Rotation.from_rotvec(ours).as_matrix(), reference.as_matrix(), atol=1e-12)
    back = rotvec_to_euler(order, ours)
    np.testing.assert_allclose(
        Rotation.from_euler(order, back, degrees=True).as_matrix(), reference.as_matrix(), atol=1e-9
    )
    np.testing.assert_allclose(back[3:], angles[3:], atol=1e-7)


def test_a_skeleton_listed_out_of_file_order_writes_its_own_motion(
    three_channel_bvh: Path, tmp_path: Path
) -> None:
    """A skeleton built in code may list a joint after joints of another branch: the file's hierarchy is
    depth first, and each joint's channels go with it, so the clip reads back in the same pose."""
    from elastyle.core.motion import Motion
    from elastyle.core.skeleton import Skeleton

    motion = read_bvh(three_channel_bvh)[0]
    skeleton = motion.skeleton
    tip = skeleton.num_joints  # a joint below the spine, listed last, after the legs' branches
    extended = Skeleton(
        (*skeleton.names, "Tip"), np.append(skeleton.parents, skeleton.index("spine")),
        np.vstack([skeleton.offsets, [0.0, 3.0, 0.0]]), np.vstack([skeleton.end_sites, [[0.0, 1.0, 0.0]]]),
    )  # fmt: skip
    turned = np.zeros((motion.num_frames, 1, 3))
    turned[:, 0, 0] = 0.5
    clip = Motion(
        extended, np.concatenate([motion.rotations, turned], axis=1),
        np.concatenate([motion.translations, np.broadcast_to([[[0.0, 3.0, 0.0]]], turned.shape)], axis=1), motion.fps,
    )  # fmt: skip
    write_bvh(tmp_path / "out.bvh", clip)
    back = read_bvh(tmp_path / "out.bvh")[0]
    order = [back.skeleton.index(name) for name in extended.names]
    assert back.skeleton.names != extended.names  # the file lists Tip right after the spine
    np.testing.assert_allclose(back.positions()[:, order], clip.positions(), atol=1e-5)
    np.testing.assert_allclose(back.rotations[:, order[tip]], turned[:, 0], atol=1e-6)


def _frame_values(text: str) -> np.ndarray:
    """The MOTION section's numbers (T, channels) of a BVH text."""
    rows = text.split("Frame Time:")[1].split("\n", 1)[1].strip().split("\n")
    return np.array([[float(value) for value in row.split()] for row in rows])


def _with_values(text: str, values: np.ndarray) -> str:
    """The BVH text with its MOTION section's numbers (T, channels) replaced."""
    head, rest = text.split("Frame Time:")
    time_line = rest.split("\n", 1)[0]
    body = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in values)
    return f"{head}Frame Time:{time_line}\n{body}\n"


@pytest.mark.parametrize("convention", ["wrapped", "from zero", "continuous"])
def test_angles_are_written_as_the_file_writes_them(three_channel_bvh: Path, convention: str) -> None:
    """A file whose angles wrap at 180 degrees is written wrapping where the clip crosses it (one keeping
    them within 0 to 360, wrapping at 360); a file whose angles run on is written continuous from its first
    frame's turn: either way the file's own clip is written with the file's numbers."""
    original = three_channel_bvh.read_text()
    frames = len(_frame_values(original))
    turning = np.linspace(170.0, 190.0, frames)  # the spine's X angle (column 6) crosses 180 degrees
    angles = {
        "wrapped": np.where(turning > 180, turning - 360, turning),
        "from zero": np.linspace(350.0, 370.0, frames) % 360,  # crosses 360, every angle positive
        "continuous": turning + 360.0,
    }[convention]
    values = _frame_values(original)
    values[:, 6] = angles
    if convention == "from zero":  # every angle within 0 to 360, as such a file has them (columns 3 on)
        values[:, 3:] %= 360
    text = _with_values(original, values)
    motion, layout = parse_bvh(text.encode(), "turning.bvh")
    assert layout.angles_wrap == (convention != "continuous")
    assert layout.angles_low == (0.0 if convention == "from zero" else -180.0)
    written = _frame_values(bvh_text(motion, layout))
    np.testing.assert_allclose(written, _frame_values(text), atol=2e-6)
    # a clip from no file: continuous, its first angle within -180 to 180
    default = _frame_values(bvh_text(motion))[:, 6]
    assert np.abs(np.diff(default)).max() < 180 and -180 <= default[0] <= 180


@pytest.mark.slow
def test_dataset_clips_are_written_with_their_own_numbers(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    """The dataset's files keep their angles within -180 to 180 degrees; written in their layout, they
    read as they were (before, angles past a wrap were written a turn apart: 392 of 581 clips)."""
    sample = random.Random(1).sample(dataset_clips, 40)
    wrapping = 0
    for clip in sample:
        motion, layout = clip.read()
        wrapping += layout.angles_wrap
        original = _frame_values(clip.data().decode())
        written = _frame_values(bvh_text(motion, layout))
        close = np.isclose(written, original, atol=2e-6) | np.isclose(np.abs(written), 180.0, atol=2e-6)
        assert np.all(close), clip.name  # (at exactly 180 degrees either sign may come back)
    assert wrapping > 0
