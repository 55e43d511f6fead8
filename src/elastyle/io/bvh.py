"""BVH reading and writing: the only place with Euler angles and degrees.

BVH rotation channels are intrinsic Euler angles in the order the CHANNELS line lists them, so a joint
with `Zrotation Xrotation Yrotation` is `Rotation.from_euler("ZXY", degrees)`. Position channels replace
the joint's OFFSET for that frame.
"""

from __future__ import annotations

import io
import math
import os
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.rotations import from_quat, quat_multiply, to_matrix
from elastyle.core.skeleton import Skeleton
from elastyle.errors import BvhError
from elastyle.io.files import write_text_atomic
from elastyle.types import FloatArray

_ROTATION_CHANNELS = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}
_POSITION_CHANNELS = {"Xposition": 0, "Yposition": 1, "Zposition": 2}


class BvhLayout(NamedTuple):
    """What a BVH file needs beyond the motion itself, so `write_bvh` reproduces its layout.

    channels: per joint (J,), the channel names in file order (3 or 6 of them, or none).
    frame_time_s: the file's frame time, seconds.
    """

    channels: tuple[tuple[str, ...], ...]
    frame_time_s: float

    @staticmethod
    def default(skeleton: Skeleton, fps: float) -> BvhLayout:
        """A 6-channel root and 3-channel ZXY joints, for clips that came from no file."""
        root = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
        joint = ("Zrotation", "Xrotation", "Yrotation")
        channels = tuple(root if j == 0 else joint for j in range(skeleton.num_joints))
        return BvhLayout(channels, 1.0 / fps)


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
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise BvhError(name, "no such file") from None
    except IsADirectoryError:
        raise BvhError(name, "is a directory, not a BVH file") from None
    except OSError as error:
        raise BvhError(name, f"cannot read: {error.strerror or error}") from None
    return parse_bvh(data, name)


def parse_bvh(data: bytes, name: str) -> tuple[Motion, BvhLayout]:
    """Parse BVH bytes; `name` is used in error messages."""
    if not data.strip():
        raise BvhError(name, "empty file")
    if b"\x00" in data[:4096]:
        raise BvhError(name, "binary data, not a BVH text file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    reader = _Lines(name, lines)
    tokens, line = reader.next_tokens("HIERARCHY")
    if tokens[0].upper() != "HIERARCHY":
        raise BvhError(name, f"not a BVH file: starts with {tokens[0][:20]!r}, expected HIERARCHY", line)
    skeleton, channels = _parse_hierarchy(reader)
    motion_values, frame_time_s = _parse_motion(reader, sum(len(c) for c in channels))
    fps = 1.0 / frame_time_s
    if abs(fps - round(fps)) < 1e-4 * fps:  # 'Frame Time: 0.0333333' means 30 fps
        fps = float(round(fps))
    motion = _motion_from_channels(name, skeleton, channels, motion_values, fps)
    return motion, BvhLayout(tuple(channels), frame_time_s)


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
        if channel not in _ROTATION_CHANNELS and channel not in _POSITION_CHANNELS:
            raise BvhError(path, f"unknown channel {channel!r} on joint {joint_name!r}", line)
    if len(set(names)) != len(names):
        raise BvhError(path, f"repeated channel on joint {joint_name!r}", line)
    rotation_count = sum(c in _ROTATION_CHANNELS for c in names)
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
        raise BvhError(path, "no frames (Frames: 0)", line)
    tokens, line = reader.next_tokens("Frame Time:")
    if [t.lower() for t in tokens[:2]] != ["frame", "time:"] or len(tokens) != 3:
        raise BvhError(path, "expected 'Frame Time: seconds'", line)
    frame_time_s = _parse_float(path, tokens[2], line)
    if frame_time_s <= 0:
        raise BvhError(path, f"frame time must be positive, got {tokens[2]}", line)
    first_row_line = reader.index + 1
    rows = reader.lines[reader.index :]
    while rows and not rows[-1].strip():
        rows.pop()
    if len(rows) != num_frames:
        _raise_row_problem(path, rows, first_row_line, num_frames, num_channels)
    try:
        # numpy's C reader: faster than float() on split tokens; raises on a bad token or a row of another
        # length, and it skips blank rows (caught by the shape check)
        values = np.loadtxt(rows, dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        values = _values_token_by_token(path, rows, first_row_line, num_channels)
    if values.shape != (num_frames, num_channels):
        _raise_row_problem(path, rows, first_row_line, num_frames, num_channels)
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero(~np.all(np.isfinite(values), axis=1))[0])
        raise BvhError(path, "NaN or infinite value in frame data", first_row_line + row)
    return values, frame_time_s


def _row_problem(row: str, num_channels: int) -> str | None:
    count = len(row.split())
    if count == num_channels:
        return None
    return "empty row" if count == 0 else f"row has {count} values, the hierarchy needs {num_channels}"


def _raise_row_problem(
    path: str, rows: list[str], first_line: int, num_frames: int, num_channels: int
) -> None:
    for row_index, row in enumerate(rows):
        problem = _row_problem(row, num_channels)
        if problem:
            raise BvhError(path, problem, first_line + row_index)
    raise BvhError(
        path, f"'Frames: {num_frames}' but {len(rows)} rows of frame data (truncated?)", first_line
    )


def _values_token_by_token(path: str, rows: list[str], first_line: int, num_channels: int) -> FloatArray:
    """Frame values (T, C) read with Python's float(), after numpy's reader refused them: the first bad
    row or token gets its error, and spellings float() accepts but numpy does not (such as '1_000') load."""
    values = []
    for row_index, row in enumerate(rows):
        problem = _row_problem(row, num_channels)
        if problem:
            raise BvhError(path, problem, first_line + row_index)
        values.append([_parse_float(path, token, first_line + row_index) for token in row.split()])
    return np.array(values, dtype=np.float64)


def _channel_columns(
    channels: list[tuple[str, ...]] | tuple[tuple[str, ...], ...],
) -> tuple[list[tuple[int, int, int]], dict[str, tuple[list[int], list[list[int]]]]]:
    """Where each joint's channels sit in a frame row: position channels as (joint, axis, column), and the
    rotation channels grouped by Euler order as {order: (joints, their 3 columns each)}."""
    positions: list[tuple[int, int, int]] = []
    by_order: dict[str, tuple[list[int], list[list[int]]]] = {}
    column = 0
    for joint, joint_channels in enumerate(channels):
        rotation_columns: list[int] = []
        order = ""
        for channel in joint_channels:
            if channel in _POSITION_CHANNELS:
                positions.append((joint, _POSITION_CHANNELS[channel], column))
            else:
                order += _ROTATION_CHANNELS[channel]
                rotation_columns.append(column)
            column += 1
        if order:
            joints, columns = by_order.setdefault(order, ([], []))
            joints.append(joint)
            columns.append(rotation_columns)
    return positions, by_order


def _motion_from_channels(
    path: str, skeleton: Skeleton, channels: list[tuple[str, ...]], values: FloatArray, fps: float
) -> Motion:
    num_frames = values.shape[0]
    num_joints = skeleton.num_joints
    translations = np.broadcast_to(skeleton.offsets, (num_frames, num_joints, 3)).copy()
    rotations = np.zeros((num_frames, num_joints, 3))
    positions, by_order = _channel_columns(channels)
    for joint, axis, column in positions:
        translations[:, joint, axis] = values[:, column]
    for order, (joints, columns) in by_order.items():
        angles_deg = values[:, np.array(columns)]  # (T, J_order, 3)
        rotations[:, joints] = euler_to_rotvec(order, angles_deg)
    return Motion(skeleton, rotations, translations, fps)


_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


def euler_to_rotvec(order: str, angles_deg: FloatArray) -> FloatArray:
    """Intrinsic Euler angles (..., 3) in degrees, axes in `order` (e.g. 'ZXY') -> exp maps (..., 3).

    The product of the three axis quaternions, q = q1 q2 q3: numpy on whole arrays, several times faster
    than scipy's `from_euler`, which the tests use as the reference.
    """
    half = np.radians(angles_deg) / 2
    quat = np.zeros((*angles_deg.shape[:-1], 4))
    quat[..., 3] = 1.0
    for position, axis in enumerate(order):
        axis_quat = np.zeros_like(quat)
        axis_quat[..., _AXIS_INDEX[axis]] = np.sin(half[..., position])
        axis_quat[..., 3] = np.cos(half[..., position])
        quat = quat_multiply(quat, axis_quat)
    return from_quat(np.where(quat[..., 3:] < 0, -quat, quat))


def rotvec_to_euler(order: str, rotvecs: FloatArray) -> FloatArray:
    """Exp maps (..., 3) -> intrinsic Euler angles (..., 3) in degrees for a three-axis `order`.

    Closed form for the six Tait-Bryan orders, with the middle angle in [-90, 90]; frames at gimbal lock
    (and any other order) go through scipy.
    """
    first, second, third = (_AXIS_INDEX[a] for a in order)
    if len({first, second, third}) != 3:
        from scipy.spatial.transform import Rotation  # imported only here: it takes about 0.7 s

        return (
            Rotation.from_rotvec(rotvecs.reshape(-1, 3)).as_euler(order, degrees=True).reshape(rotvecs.shape)
        )
    matrix = to_matrix(rotvecs)
    parity = 1.0 if (first, second, third) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    sine = np.clip(parity * matrix[..., first, third], -1.0, 1.0)
    angles = np.stack(
        [
            np.arctan2(-parity * matrix[..., second, third], matrix[..., third, third]),
            np.arcsin(sine),
            np.arctan2(-parity * matrix[..., first, second], matrix[..., first, first]),
        ],
        axis=-1,
    )
    locked = np.abs(sine) > 1 - 1e-9
    if np.any(locked):
        from scipy.spatial.transform import Rotation

        with warnings.catch_warnings():  # at gimbal lock scipy picks one of the equal answers: fine
            warnings.simplefilter("ignore", UserWarning)
            angles[locked] = np.radians(Rotation.from_rotvec(rotvecs[locked]).as_euler(order, degrees=True))
    return np.degrees(angles)


def bvh_text(motion: Motion, layout: BvhLayout | None = None) -> str:
    """The BVH text of a clip, in `layout` (hierarchy, channel orders, End Sites) when given."""
    skeleton = motion.skeleton
    layout = layout or BvhLayout.default(skeleton, motion.fps)
    if len(layout.channels) != skeleton.num_joints:
        raise ValueError(f"layout has {len(layout.channels)} joints, the clip {skeleton.num_joints}")
    out = io.StringIO()
    out.write("HIERARCHY\n")
    _write_joint(out, skeleton, layout, 0, 0)
    out.write(f"MOTION\nFrames: {motion.num_frames}\nFrame Time: {1.0 / motion.fps:.7f}\n")
    out.write(_format_rows(_channel_values(motion, layout)))
    return out.getvalue()


def _format_rows(values: FloatArray) -> str:
    """Frame data (T, C) as text: each value like '%.6f' (no sign on a zero), one space between values,
    one line per frame.

    Built digit by digit on whole columns of values (about six times faster than Python's formatting):
    every value gets fixed slots for a sign, the largest value's count of whole digits, the point, six
    decimals and a separator; slots a value does not use hold NUL bytes, removed at the end.
    """
    flat = values.ravel()
    scaled = np.rint(np.abs(flat) * 1e6)  # millionths
    if flat.size == 0 or not np.all(scaled < 1e15):  # whole parts of 1e9 or more (past uint32), or not finite
        row_format = " ".join(["%.6f"] * values.shape[1])
        return "".join(row_format % tuple(row) + "\n" for row in values.tolist())
    whole = np.floor((scaled + 0.5) * 1e-6)
    fraction = (scaled - whole * 1e6).astype(np.uint32)
    whole = whole.astype(np.uint32)
    places = len(str(int(whole.max())))
    width = places + 9
    slots = np.empty((flat.size, width), dtype=np.uint8).T  # (width, N): slot by slot, value-major bytes
    slots[0] = ord("-") * ((flat < 0) & (scaled > 0))
    quotient = whole
    for place in range(places):  # whole digits from the units leftwards; leading zeros become NUL
        higher = quotient // 10  # numpy divides by a constant quickly; % would be several times slower
        digit = quotient - 10 * higher + ord("0")
        slots[places - place] = digit if place == 0 else digit * (quotient > 0)
        quotient = higher
    slots[places + 1] = ord(".")
    quotient = fraction
    for place in range(6):
        higher = quotient // 10
        slots[places + 7 - place] = quotient - 10 * higher + ord("0")
        quotient = higher
    slots[-1] = ord(" ")
    slots[-1, values.shape[1] - 1 :: values.shape[1]] = ord("\n")
    return slots.T.tobytes().translate(None, b"\0").decode("ascii")


def write_bvh(
    path: str | os.PathLike[str], motion: Motion, layout: BvhLayout | None = None, force: bool = False
) -> None:
    """Write a clip as BVH, atomically; refuses to replace an existing file unless `force`."""
    write_text_atomic(path, bvh_text(motion, layout), force=force)


def _write_joint(out: io.StringIO, skeleton: Skeleton, layout: BvhLayout, joint: int, depth: int) -> None:
    indent = "\t" * depth
    keyword = "ROOT" if skeleton.parents[joint] < 0 else "JOINT"
    out.write(f"{indent}{keyword} {skeleton.names[joint]}\n{indent}{{\n")
    out.write(f"{indent}\tOFFSET {_format_vector(skeleton.offsets[joint])}\n")
    channels = layout.channels[joint]
    out.write(f"{indent}\tCHANNELS {len(channels)}{''.join(' ' + c for c in channels)}\n")
    for child in skeleton.children(joint):
        _write_joint(out, skeleton, layout, child, depth + 1)
    if not np.any(np.isnan(skeleton.end_sites[joint])):
        out.write(f"{indent}\tEnd Site\n{indent}\t{{\n")
        out.write(f"{indent}\t\tOFFSET {_format_vector(skeleton.end_sites[joint])}\n{indent}\t}}\n")
    out.write(f"{indent}}}\n")


def _format_vector(vector: FloatArray) -> str:
    return " ".join(f"{v:.6g}" for v in vector)


def _channel_values(motion: Motion, layout: BvhLayout) -> FloatArray:
    """Frame data (T, total channels) in the layout's channel order; angles continuous along time."""
    values = np.zeros((motion.num_frames, sum(len(c) for c in layout.channels)))
    positions, by_order = _channel_columns(layout.channels)
    for joint, axis, column in positions:
        values[:, column] = motion.translations[:, joint, axis]
    for order, (joints, columns) in by_order.items():  # every joint of one Euler order at once
        angles_deg = rotvec_to_euler(order, motion.rotations[:, joints])  # (T, J_order, 3)
        values[:, np.array(columns)] = np.unwrap(angles_deg, period=360.0, axis=0)
    return values
