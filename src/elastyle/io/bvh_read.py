"""BVH reading: text to a `Motion` and its `BvhLayout` (degrees and Euler angles end in `io.euler`).

BVH rotation channels are intrinsic Euler angles in the order the CHANNELS line lists them, so a joint
with `Zrotation Xrotation Yrotation` is `Rotation.from_euler("ZXY", degrees)`. Position channels replace
the joint's OFFSET for that frame.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton
from elastyle.errors import BvhError
from elastyle.io.bvh_layout import POSITION_CHANNELS, ROTATION_CHANNELS, BvhLayout, channel_columns
from elastyle.io.euler import euler_to_rotvec
from elastyle.io.files import input_problem
from elastyle.types import FloatArray

# Values elastyle accepts: positions and angles far inside float32 (the model computes in float32), and
# frame rates from one frame a minute to 10 kHz.
LARGEST_VALUE = 1e9
MIN_FRAME_TIME_S = 1e-4
MAX_FRAME_TIME_S = 60.0


class _Lines:
    """Tokenised lines of the HIERARCHY block with their 1-based line numbers."""

    def __init__(self, path: str, lines: list[str]) -> None:
        self.path = path
        self.lines = lines
        self.index = 0

    def next_tokens(self, what: str) -> tuple[list[str], int]:
        while self.index < len(self.lines):
            tokens = self.lines[self.index].split()
            self.index += 1
            if tokens:
                return tokens, self.index
        raise BvhError(self.path, f"file ends inside HIERARCHY (expected {what})", self.index)


def read_bvh(path: str | os.PathLike[str]) -> tuple[Motion, BvhLayout]:
    """Read a BVH file into a `Motion` and the `BvhLayout` that `write_bvh` needs to reproduce it."""
    return parse_bvh(read_input(path), str(path))


def _newline(text: str) -> str:
    """A file's line ending: Windows tools' "\r\n", classic Mac OS's "\r" alone, or "\n"."""
    if "\r\n" in text:
        return "\r\n"
    return "\r" if "\r" in text and "\n" not in text else "\n"


def _indent(text: str) -> str:
    """A file's indentation of one hierarchy level: the leading blanks of its first OFFSET line (the root's,
    one level in; none where the file indents nothing), a tab for a file without one."""
    for line in text.splitlines():
        stripped = line.lstrip(" \t")
        if stripped.startswith("OFFSET"):
            return line[: len(line) - len(stripped)]
        if stripped.startswith("MOTION"):
            break
    return "\t"


def read_input(path: str | os.PathLike[str]) -> bytes:
    """A file's bytes, once `io.files.input_problem` has found nothing against reading it (a `BvhError`
    naming the file otherwise)."""
    problem = input_problem(path)
    if problem is not None:
        raise BvhError(str(path), problem)
    try:
        return Path(path).read_bytes()
    except OSError as error:
        raise BvhError(str(path), f"cannot read: {error.strerror or error}") from None


def parse_bvh(data: bytes, name: str) -> tuple[Motion, BvhLayout]:
    """Parse BVH bytes; `name` is used in error messages."""
    if not data.strip():
        raise BvhError(name, "empty file")
    if data.startswith(b"PK\x03\x04"):
        inside = (
            ": name one clip inside it (ARCHIVE.zip/folder/clip.bvh)" if name.lower().endswith(".zip") else ""
        )
        raise BvhError(name, f"a zip archive, not a BVH file{inside}")
    if data.startswith(
        (b"\xff\xfe", b"\xfe\xff")
    ):  # UTF-16 with its byte-order mark (PowerShell's '>' writes it)
        try:
            text, encoding = data.decode("utf-16"), "utf-16"
        except UnicodeDecodeError:
            raise BvhError(name, "marked as UTF-16 text, but not readable as such") from None
    elif b"\x00" in data[:4096]:
        raise BvhError(name, "binary data, not a BVH text file")
    else:
        try:
            text, encoding = data.decode("utf-8"), "utf-8"
        except UnicodeDecodeError:
            text, encoding = data.decode("latin-1"), "latin-1"
    if text.startswith("\ufeff"):  # a UTF-8 byte-order mark, as some Windows tools write: kept when written
        text, encoding = text[1:], "utf-8-sig"
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    reader = _Lines(name, lines)
    tokens, line = reader.next_tokens("HIERARCHY")
    if tokens[0].upper() != "HIERARCHY":
        raise BvhError(name, f"not a BVH file: starts with {tokens[0][:20]!r}, expected HIERARCHY", line)
    skeleton, channels = _parse_hierarchy(reader)
    motion_values, frame_time_s = _parse_motion(reader, sum(len(c) for c in channels))
    fps = frame_rate(frame_time_s)
    motion = _motion_from_channels(name, skeleton, channels, motion_values, fps)
    wrap, low = _angle_range(channels, motion_values)
    layout = BvhLayout(
        tuple(channels), frame_time_s, first_values=_first_values(channels, motion_values),
        angles_wrap=wrap, angles_low=low, newline=_newline(text), encoding=encoding, indent=_indent(text),
    )  # fmt: skip
    return motion, layout


def _angle_range(channels: list[tuple[str, ...]], values: FloatArray) -> tuple[bool, float]:
    """Whether a rotation channel of the file's values (T, total channels) jumps by over half a turn from
    one frame to the next (angles kept within one turn, wrapping where they cross its end), and where that
    turn starts: 0 degrees where no angle is negative, else -180."""
    rotation = np.array([channel in ROTATION_CHANNELS for joint in channels for channel in joint], dtype=bool)
    angles = values[:, rotation] if len(values) else values
    wrap = bool(len(angles) > 1 and np.any(np.abs(np.diff(angles, axis=0)) > 180.0))
    return wrap, 0.0 if wrap and np.min(angles) >= 0 else -180.0


def _first_values(channels: list[tuple[str, ...]], values: FloatArray) -> tuple[tuple[float, ...], ...]:
    """Each joint's channel values (J,) in the first frame of the file's values (T, total channels)."""
    if not len(values):
        return ()
    ends = np.cumsum([len(c) for c in channels])
    row = values[0].tolist()
    return tuple(tuple(row[end - len(c) : end]) for c, end in zip(channels, ends))


def frame_rate(frame_time_s: float) -> float:
    """Frames per second of a frame time, whole when it is within 1e-4 of whole ('Frame Time: 0.0333333'
    and float32 keyframe times mean 30 fps)."""
    fps = 1.0 / frame_time_s
    return float(round(fps)) if abs(fps - round(fps)) < 1e-4 * fps else fps


def _parse_hierarchy(reader: _Lines) -> tuple[Skeleton, list[tuple[str, ...]]]:
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    end_sites: dict[int, list[float]] = {}
    channels: list[tuple[str, ...]] = []
    stack: list[int] = []  # joint indices of open braces; -2 marks an End Site
    path = reader.path

    def parse_offset(expected_owner: str) -> list[float]:
        tokens, line = reader.next_tokens("OFFSET")
        if tokens[0].upper() != "OFFSET" or len(tokens) != 4:
            raise BvhError(
                path, f"expected 'OFFSET x y z' for {expected_owner}, got {' '.join(tokens)[:60]!r}", line
            )
        return [_parse_float(path, t, line) for t in tokens[1:]]

    def expect_brace(line_tokens: tuple[list[str], int]) -> None:
        tokens, line = line_tokens
        if tokens != ["{"]:
            raise BvhError(path, f"expected '{{', got {' '.join(tokens)[:60]!r}", line)

    tokens, line = reader.next_tokens("ROOT")
    if tokens[0].upper() != "ROOT" or len(tokens) < 2:
        raise BvhError(path, f"expected 'ROOT name', got {' '.join(tokens)[:60]!r}", line)
    pending: tuple[str, int, int] | None = (" ".join(tokens[1:]), -1, line)
    while True:
        if pending is not None:
            joint_name, parent, line = pending
            pending = None
            if joint_name in names:
                raise BvhError(path, f"duplicate joint name {joint_name!r}", line)
            expect_brace(reader.next_tokens("{"))
            joint = len(names)
            names.append(joint_name)
            parents.append(parent)
            offsets.append(parse_offset(joint_name))
            tokens, line = reader.next_tokens("CHANNELS")
            if tokens[0].upper() != "CHANNELS":
                raise BvhError(path, f"expected CHANNELS for joint {joint_name!r}", line)
            channels.append(_parse_channels(path, tokens, line, joint_name))
            stack.append(joint)
            continue
        tokens, line = reader.next_tokens("JOINT, End Site or '}'")
        keyword = tokens[0].upper()
        if keyword == "JOINT" and len(tokens) >= 2:
            if not stack or stack[-1] < 0:
                raise BvhError(path, "JOINT outside a joint", line)
            pending = (" ".join(tokens[1:]), stack[-1], line)
        elif keyword == "END":
            if not stack or stack[-1] < 0:
                raise BvhError(path, "End Site outside a joint", line)
            expect_brace(reader.next_tokens("{"))
            end_sites[stack[-1]] = parse_offset("End Site")
            stack.append(-2)
        elif tokens == ["}"]:
            stack.pop()
            if not stack:
                break
        elif keyword == "MOTION":
            raise BvhError(path, "MOTION before the hierarchy's braces are closed", line)
        else:
            raise BvhError(path, f"unexpected {' '.join(tokens)[:60]!r} in HIERARCHY", line)
    end_site_array = np.full((len(names), 3), np.nan)
    for joint, offset in end_sites.items():
        end_site_array[joint] = offset
    skeleton = Skeleton(tuple(names), np.array(parents, dtype=np.int64), np.array(offsets), end_site_array)
    return skeleton, channels


def _parse_channels(path: str, tokens: list[str], line: int, joint_name: str) -> tuple[str, ...]:
    try:
        count = int(tokens[1])
    except (IndexError, ValueError):
        raise BvhError(path, f"CHANNELS of {joint_name!r} lacks a channel count", line) from None
    names = tuple(tokens[2:])
    if len(names) != count:
        raise BvhError(path, f"CHANNELS of {joint_name!r} says {count} but lists {len(names)}", line)
    for channel in names:
        if channel not in ROTATION_CHANNELS and channel not in POSITION_CHANNELS:
            raise BvhError(path, f"unknown channel {channel!r} on joint {joint_name!r}", line)
    if len(set(names)) != len(names):
        raise BvhError(path, f"repeated channel on joint {joint_name!r}", line)
    rotation_count = sum(c in ROTATION_CHANNELS for c in names)
    if rotation_count not in (0, 3):
        raise BvhError(
            path, f"joint {joint_name!r} has {rotation_count} rotation channels (need 0 or 3)", line
        )
    return names


def _parse_float(path: str, token: str, line: int) -> float:
    try:
        value = float(token)
    except ValueError:
        raise BvhError(path, f"not a number: {token[:30]!r}", line) from None
    if not math.isfinite(value):
        raise BvhError(path, f"non-finite value {token!r}", line)
    if abs(value) > LARGEST_VALUE:
        raise BvhError(path, f"value beyond {LARGEST_VALUE:g}: {token[:30]!r}", line)
    return value


def _parse_motion(reader: _Lines, num_channels: int) -> tuple[FloatArray, float]:
    path = reader.path
    tokens, line = reader.next_tokens("MOTION")
    if tokens[0].upper() != "MOTION":
        raise BvhError(path, f"expected MOTION after the hierarchy, got {' '.join(tokens)[:60]!r}", line)
    tokens, line = reader.next_tokens("Frames:")
    if tokens[0].lower() != "frames:" or len(tokens) != 2:
        raise BvhError(path, "expected 'Frames: N'", line)
    try:
        num_frames = int(tokens[1])
    except ValueError:
        raise BvhError(path, f"frame count is not an integer: {tokens[1][:30]!r}", line) from None
    if num_frames <= 0:
        raise BvhError(path, f"no frames (Frames: {tokens[1]})", line)
    tokens, line = reader.next_tokens("Frame Time:")
    if [t.lower() for t in tokens[:2]] != ["frame", "time:"] or len(tokens) != 3:
        raise BvhError(path, "expected 'Frame Time: seconds'", line)
    frame_time_s = _parse_float(path, tokens[2], line)
    if not MIN_FRAME_TIME_S <= frame_time_s <= MAX_FRAME_TIME_S:
        raise BvhError(
            path,
            f"frame time must lie between {MIN_FRAME_TIME_S:g} and {MAX_FRAME_TIME_S:g} s, got {tokens[2]}",
            line,
        )
    first_row_line = reader.index + 1
    rows = reader.lines[reader.index :]
    while rows and not rows[-1].strip():
        rows.pop()
    row_lines = list(range(first_row_line, first_row_line + max(len(rows), 1)))  # each row's line number
    if len(rows) != num_frames and sum(1 for row in rows if row.strip()) == num_frames:
        # blank lines between frames (an editor's or a script's), read past as other BVH readers do
        row_lines = [line for line, row in zip(row_lines, rows) if row.strip()]
        rows = [row for row in rows if row.strip()]
    if len(rows) != num_frames:
        _raise_row_problem(path, rows, row_lines, num_frames, num_channels)
    try:
        # numpy's C reader: faster than float() on split tokens; raises on a bad token or a row of another
        # length, and it skips blank rows (caught by the shape check)
        values = np.loadtxt(rows, dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        values = _values_token_by_token(path, rows, row_lines, num_channels)
    if values.shape != (num_frames, num_channels):
        _raise_row_problem(path, rows, row_lines, num_frames, num_channels)
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero(~np.all(np.isfinite(values), axis=1))[0])
        raise BvhError(path, "NaN or infinite value in frame data", row_lines[row])
    beyond = np.abs(values) > LARGEST_VALUE
    if np.any(beyond):
        row = int(np.flatnonzero(np.any(beyond, axis=1))[0])
        raise BvhError(path, f"value beyond {LARGEST_VALUE:g} in frame data", row_lines[row])
    return values, frame_time_s


def _row_problem(row: str, num_channels: int) -> str | None:
    count = len(row.split())
    if count == num_channels:
        return None
    return "empty row" if count == 0 else f"row has {count} values, the hierarchy needs {num_channels}"


def _raise_row_problem(
    path: str, rows: list[str], row_lines: list[int], num_frames: int, num_channels: int
) -> None:
    """The `BvhError` for frame rows (each on its line of `row_lines`) that do not make the frames: the first
    row without the hierarchy's channel count, else the count of rows against the Frames line's."""
    for row, line in zip(rows, row_lines):
        problem = _row_problem(row, num_channels)
        if problem:
            raise BvhError(path, problem, line)
    hint = "truncated?" if len(rows) < num_frames else "more rows than the Frames line counts"
    raise BvhError(path, f"'Frames: {num_frames}' but {len(rows)} rows of frame data ({hint})", row_lines[0])


def _values_token_by_token(path: str, rows: list[str], row_lines: list[int], num_channels: int) -> FloatArray:
    """Frame values (T, C) read with Python's float(), after numpy's reader refused them: the first bad
    row or token gets its error, and spellings float() accepts but numpy does not (such as '1_000') load."""
    values = []
    for row, line in zip(rows, row_lines):
        problem = _row_problem(row, num_channels)
        if problem:
            raise BvhError(path, problem, line)
        values.append([_parse_float(path, token, line) for token in row.split()])
    return np.array(values, dtype=np.float64)


def _motion_from_channels(
    path: str, skeleton: Skeleton, channels: list[tuple[str, ...]], values: FloatArray, fps: float
) -> Motion:
    num_frames = values.shape[0]
    num_joints = skeleton.num_joints
    translations = np.broadcast_to(skeleton.offsets, (num_frames, num_joints, 3)).copy()
    rotations = np.zeros((num_frames, num_joints, 3))
    positions, by_order = channel_columns(channels)
    for joint, axis, column in positions:
        translations[:, joint, axis] = values[:, column]
    for order, (joints, columns) in by_order.items():
        angles_deg = values[:, np.array(columns)]  # (T, J_order, 3)
        rotations[:, joints] = euler_to_rotvec(order, angles_deg)
    return Motion(skeleton, rotations, translations, fps)
