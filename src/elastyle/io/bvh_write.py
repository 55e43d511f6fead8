"""BVH writing: a `Motion` in a `BvhLayout` (the input's hierarchy, channel orders and End Sites)."""

from __future__ import annotations

import io
import logging
import os
from pathlib import Path

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.roots import moved_joints
from elastyle.core.skeleton import Skeleton
from elastyle.core.up import turned_back
from elastyle.errors import BvhError, SkeletonMismatchError, UsageError
from elastyle.io.bvh_layout import POSITION_CHANNELS, BvhLayout, channel_columns, first_rotation_values
from elastyle.io.bvh_read import frame_rate
from elastyle.io.euler import rotvec_to_euler
from elastyle.io.files import write_bytes_atomic
from elastyle.types import FloatArray

log = logging.getLogger(__name__)


def bvh_text(motion: Motion, layout: BvhLayout | None = None) -> str:
    """The BVH text of a clip, in `layout` (hierarchy, channel orders, End Sites, up axis) when given; a
    joint that moves in the clip but has no position channels in the layout gets them (`placed_layout`)."""
    skeleton = motion.skeleton
    if layout is not None and len(layout.channels) != skeleton.num_joints:
        raise SkeletonMismatchError(
            f"the layout is a file's of {len(layout.channels)} joints, the clip has {skeleton.num_joints}: write "
            "a clip in the layout of the file it was read from (read_bvh's), or without one"
        )
    layout = (
        placed_layout(motion, layout)[0]
        if layout
        else BvhLayout.default(skeleton, motion.fps, _animated_joints(motion))
    )
    motion = turned_back(motion, layout.up)  # as its file stands (clips are read turned to +Y up)
    out = io.StringIO()
    out.write("HIERARCHY\n")
    written = _write_joint(out, skeleton, layout, 0, 0)  # the joints in file order
    out.write(f"MOTION\nFrames: {motion.num_frames}\nFrame Time: {_frame_time(motion.fps, layout)}\n")
    out.write(_format_rows(_channel_values(motion, layout, written)))
    text = out.getvalue()
    return text if layout.newline == "\n" else text.replace("\n", layout.newline)


def _frame_time(fps: float, layout: BvhLayout) -> str:
    """The Frame Time line's number: the layout's file's own where the clip keeps its frame rate (as the file
    wrote it, 0.00833333 staying so), else the rate's to seven decimals (1/30 s: 0.0333333)."""
    own = _number(layout.frame_time_s, 10)
    # the reader takes 0.00833333 s (and 0.008333) for 120 fps: where it reads the clip's rate, the file's text
    if frame_rate(layout.frame_time_s) == fps and float(own) == layout.frame_time_s:
        return own
    return f"{1.0 / fps:.7f}"


def _number(value: float, decimals: int, pad: bool = False) -> str:
    """A number as its shortest text that reads back the same, to at most `decimals` decimals (all of them
    where `pad`), no exponent and no sign on zero."""
    text = (
        f"{float(value):.{decimals}f}"
        if pad
        else np.format_float_positional(float(value), precision=decimals, unique=True, trim="-")
    )
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def bvh_bytes(motion: Motion, layout: BvhLayout | None = None) -> bytes:
    """`bvh_text` encoded as the layout's file was (UTF-8 where that cannot hold a name, or without one)."""
    text = bvh_text(motion, layout)
    try:
        return text.encode(layout.encoding if layout is not None else "utf-8")
    except UnicodeEncodeError:
        return text.encode("utf-8")


def _animated_joints(motion: Motion) -> list[int]:
    """Joints below the root whose local translations (T, J, 3) leave their bone offsets in some frame (a
    joint that moves, or a root some exporter placed below a static joint): they need position channels."""
    away = np.abs(motion.translations[:, 1:] - motion.skeleton.offsets[1:])  # (T, J - 1, 3)
    return [joint + 1 for joint in np.flatnonzero(np.any(away > 1e-9, axis=(0, 2))).tolist()]


def placed_layout(motion: Motion, layout: BvhLayout) -> tuple[BvhLayout, list[int]]:
    """`layout` with position channels added (before its rotation channels) to each joint that moves in the
    clip but has none there, and those joints: a file whose root-motion joint above the pelvis carries the
    translation, the pelvis only rotations, gets the pelvis's moves a transfer makes (the foot clean-up's),
    which were dropped."""
    unplaced = [
        j for j in range(1, len(layout.channels)) if not POSITION_CHANNELS.keys() & set(layout.channels[j])
    ]
    if not unplaced:  # every joint has position channels (the common case): nothing to look at
        return layout, []
    missing = moved_joints(motion, unplaced)
    if not missing:
        return layout, []
    channels = [
        (*POSITION_CHANNELS, *joint_channels) if joint in missing else joint_channels
        for joint, joint_channels in enumerate(layout.channels)
    ]
    first = layout.first_values
    if len(first) == len(layout.channels) and motion.num_frames:
        first = tuple(
            (*motion.translations[0, joint].tolist(), *values) if joint in missing else values
            for joint, values in enumerate(first)
        )
    return layout._replace(channels=tuple(channels), first_values=first), missing


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
    path: str | os.PathLike[str],
    motion: Motion,
    layout: BvhLayout | None = None,
    force: bool = False,
    inputs: tuple[str, ...] = (),
) -> None:
    """Write a clip as BVH, atomically; refuses to replace an existing file unless `force`, to write
    non-finite values, or to replace any of `inputs`. (`elastyle.write_clip` writes .bvh or .glb by the
    name's extension.)"""
    check_clip_argument(motion)
    if Path(path).suffix.lower() in (".glb", ".gltf"):
        raise UsageError(
            f"{path}: write_bvh writes BVH text; for binary glTF name the file .glb and use "
            "elastyle.write_clip(path, motion)"
        )
    refuse_unwritable(path, motion)
    write_bytes_atomic(path, bvh_bytes(motion, layout_for(path, motion, layout)), force=force, inputs=inputs)


def layout_for(path: str | os.PathLike[str], motion: Motion, layout: BvhLayout | None) -> BvhLayout | None:
    """The layout `motion` is written in at `path`: `layout` with position channels where the clip moves a
    joint that has none (`placed_layout`), said in a note naming the file and the joints."""
    if layout is None:
        return None
    if not isinstance(layout, BvhLayout):
        raise TypeError(
            f"the layout must be the BvhLayout read with the clip (elastyle.read_bvh returns (motion, layout)), "
            f"or None, got {type(layout).__name__} {layout!r:.40}"
        )
    layout, placed = placed_layout(motion, layout)
    if placed:
        names = ", ".join(motion.skeleton.names[joint] for joint in placed)
        log.warning(
            "note: %s: %s moves in this clip but had no position channels in the file it came from: written "
            "with them", path, names,
        )  # fmt: skip
    return layout


def check_clip_argument(motion: object) -> None:
    """A `TypeError` saying what to pass where a writer is given something else than a `Motion`."""
    if not isinstance(motion, Motion):
        hint = " (a transfer's result: pass result.motion)" if hasattr(motion, "motion") else ""
        raise TypeError(f"the clip to write must be a Motion, got {type(motion).__name__}{hint}")


def refuse_unwritable(path: str | os.PathLike[str], motion: Motion) -> None:
    """A `BvhError` naming `path` when the clip to be written there has no frames or holds NaN or infinite
    values, or (a BVH file) its skeleton has more than one root: files no reader takes."""
    if motion.num_frames == 0:
        raise BvhError(str(path), "the clip has no frames; nothing written")
    if not motion.is_finite():
        raise BvhError(str(path), "the clip holds NaN or infinite values; nothing written")
    roots = [name for name, parent in zip(motion.skeleton.names, motion.skeleton.parents) if parent < 0]
    if len(roots) > 1 and Path(path).suffix.lower() not in (".glb", ".gltf"):
        raise BvhError(
            str(path),
            f"a BVH file holds one hierarchy, this skeleton has {len(roots)} roots ({', '.join(roots[:4])}); "
            "nothing written (parent them under one joint, or write .glb)",
        )


def _write_joint(
    out: io.StringIO, skeleton: Skeleton, layout: BvhLayout, joint: int, depth: int
) -> list[int]:
    """The hierarchy below `joint`, depth first, with an explicit stack (any depth, no recursion limit); the
    joints in the order written (a skeleton built in code may list its joints in another)."""
    written: list[int] = []
    stack: list[tuple[int, int, bool]] = [(joint, depth, True)]  # (joint, depth, opening)
    while stack:
        joint, depth, opening = stack.pop()
        unit = layout.indent
        indent = unit * depth
        if not opening:
            if not np.any(np.isnan(skeleton.end_sites[joint])):
                out.write(f"{indent}{unit}End Site\n{indent}{unit}{{\n")
                out.write(
                    f"{indent}{unit}{unit}OFFSET {_format_vector(skeleton.end_sites[joint])}\n{indent}{unit}}}\n"
                )
            out.write(f"{indent}}}\n")
            continue
        written.append(joint)
        keyword = "ROOT" if skeleton.parents[joint] < 0 else "JOINT"
        out.write(f"{indent}{keyword} {skeleton.names[joint]}\n{indent}{{\n")
        out.write(f"{indent}{unit}OFFSET {_format_vector(skeleton.offsets[joint])}\n")
        channels = layout.channels[joint]
        out.write(f"{indent}{unit}CHANNELS {len(channels)}{''.join(' ' + c for c in channels)}\n")
        stack.append((joint, depth, False))
        stack.extend((child, depth + 1, True) for child in reversed(list(skeleton.children(joint))))
    return written


def _format_vector(vector: FloatArray) -> str:
    """An offset's three numbers with six decimals, as most files write them, or more where the value needs
    them to read back the same (six significant digits had written 111.97668 as 111.977)."""
    return " ".join(_six_decimals(v) for v in vector)


def _six_decimals(value: float) -> str:
    text, longer = (_number(value, decimals, pad=True) for decimals in (6, 8))
    return longer if float(text) != value and float(longer) == value else text


def _channel_values(motion: Motion, layout: BvhLayout, written: list[int]) -> FloatArray:
    """Frame data (T, total channels) of the joints in `written` order (the file's), each in its layout's
    channel order; angles within the layout's file's turn (-180 to 180 or 0 to 360 degrees) where it wraps
    them, else continuous along time from the turn of its first frame."""
    values = np.zeros((motion.num_frames, sum(len(c) for c in layout.channels)))
    positions, by_order = channel_columns([layout.channels[joint] for joint in written])
    for at, axis, column in positions:
        values[:, column] = motion.translations[:, written[at], axis]
    for order, (at_joints, columns) in by_order.items():  # every joint of one Euler order at once
        joints = [written[at] for at in at_joints]
        angles_deg = rotvec_to_euler(order, motion.rotations[:, joints])  # (T, J_order, 3)
        if layout.angles_wrap and layout.angles_low == 0:  # a file keeping its angles within 0 to 360
            angles_deg = np.mod(angles_deg, 360.0)
        if not layout.angles_wrap:  # else as rotvec_to_euler gives them, within -180 to 180
            angles_deg = np.unwrap(angles_deg, period=360.0, axis=0)
            first = first_rotation_values(layout, joints)
            if first is not None and len(angles_deg):  # whole turns towards the file's first frame
                angles_deg += 360.0 * np.round((np.array(first) - angles_deg[0]) / 360.0)
        values[:, np.array(columns)] = angles_deg
    return values
