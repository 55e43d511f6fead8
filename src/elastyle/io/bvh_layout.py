"""The layout of a BVH file beyond its motion: each joint's channels in file order, the frame time, the up
axis and the first frame's channel values."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from elastyle.core.skeleton import Skeleton

ROTATION_CHANNELS = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}
POSITION_CHANNELS = {"Xposition": 0, "Yposition": 1, "Zposition": 2}


class BvhLayout(NamedTuple):
    """What a BVH file needs beyond the motion itself, so `write_bvh` reproduces its layout.

    channels: per joint (J,), the channel names in file order (3 or 6 of them, or none).
    frame_time_s: the file's frame time, seconds.
    up: the file's up axis ("y" or "z", `core.up`): a clip read from a file standing along +Z is turned to
        +Y up, and turned back where it is written in this layout.
    first_values: per joint (J,), its channels' values in the file's first frame (channel order; empty
        without frames): a clip written in this layout starts each continuous rotation channel on the same
        turn (within 180 degrees of the file's first value), so its curves lie where the file's do.
    angles_wrap: whether the file's rotation channels jump by a turn where an angle crosses the end of
        their range (-180 to 180 degrees, as many exporters write them, or 0 to 360: `angles_low`) rather
        than running on continuously: a clip written in this layout does the same. Either way the file's
        own motion is written with the file's numbers, where the file's Euler angles are the usual
        solution (the middle angle within -90 to 90 degrees: the same rotation past it is written as the
        other solution).
    angles_low: where a wrapping file's angles start, -180 or 0 degrees.
    newline: the file's line ending, "\n", "\r\n" (Windows tools') or "\r" (classic Mac OS's), which a
             clip written in it keeps.
    indent: the file's indentation of one level of the hierarchy (a tab, some spaces, or none), kept likewise.
    encoding: the file's text encoding, "utf-8", "utf-8-sig" (with a byte-order mark), "utf-16" (with its
        byte-order mark; written in the machine's byte order, little-endian on x86 and ARM) or "latin-1" (a
        file that is not UTF-8), kept likewise.
    """

    channels: tuple[tuple[str, ...], ...]
    frame_time_s: float
    up: str = "y"
    first_values: tuple[tuple[float, ...], ...] = ()
    angles_wrap: bool = False
    angles_low: float = -180.0
    newline: str = "\n"
    encoding: str = "utf-8"
    indent: str = "\t"

    @staticmethod
    def default(skeleton: Skeleton, fps: float, moving: Sequence[int] = ()) -> BvhLayout:
        """A 6-channel root and 3-channel ZXY joints, for clips that came from no BVH file; the joints in
        `moving` (whose translations are animated) get position channels too."""
        placed = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
        joint = ("Zrotation", "Xrotation", "Yrotation")
        channels = tuple(placed if j == 0 or j in moving else joint for j in range(skeleton.num_joints))
        return BvhLayout(channels, 1.0 / fps)


def channel_columns(
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
            if channel in POSITION_CHANNELS:
                positions.append((joint, POSITION_CHANNELS[channel], column))
            else:
                order += ROTATION_CHANNELS[channel]
                rotation_columns.append(column)
            column += 1
        if order:
            joints, columns = by_order.setdefault(order, ([], []))
            joints.append(joint)
            columns.append(rotation_columns)
    return positions, by_order


def first_rotation_values(layout: BvhLayout, joints: Sequence[int]) -> list[list[float]] | None:
    """Each joint's (J_o,) rotation channel values in the file's first frame, in channel order; None where
    the layout records none (a clip from no file)."""
    if len(layout.first_values) != len(layout.channels):
        return None
    return [
        [
            value
            for channel, value in zip(layout.channels[j], layout.first_values[j])
            if channel in ROTATION_CHANNELS
        ]
        for j in joints
    ]
