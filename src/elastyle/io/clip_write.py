"""Writing a clip in the format its output name asks for: `.bvh` (the content's own layout) or `.glb`."""

from __future__ import annotations

import os
from pathlib import Path

from elastyle.core.motion import Motion
from elastyle.errors import UsageError
from elastyle.io.bvh_layout import BvhLayout
from elastyle.io.bvh_write import bvh_bytes, check_clip_argument, layout_for, refuse_unwritable
from elastyle.io.files import write_bytes_atomic

OUTPUT_SUFFIXES = (".bvh", ".glb")


def check_output_format(path: str | os.PathLike[str]) -> None:
    """A `UsageError` for an output name elastyle cannot write (never a BVH under another name)."""
    suffix = Path(path).suffix.lower()
    if suffix not in OUTPUT_SUFFIXES:
        raise UsageError(
            f"{path}: unknown output format {suffix or '(no extension)'!r}; name it .bvh or .glb (glTF 2.0)"
        )


def clip_bytes(path: str | os.PathLike[str], motion: Motion, layout: BvhLayout | None = None) -> bytes:
    """The file `path` would hold for `motion`: BVH (in `layout`) or binary glTF, by the name's extension.
    Refuses what no reader takes (`refuse_unwritable`), naming `path`."""
    check_clip_argument(motion)
    check_output_format(path)
    refuse_unwritable(path, motion)
    if Path(path).suffix.lower() == ".glb":
        from elastyle.io.gltf_write import glb_bytes

        return glb_bytes(motion)
    return bvh_bytes(motion, layout_for(path, motion, layout))


def write_clip(
    path: str | os.PathLike[str],
    motion: Motion,
    layout: BvhLayout | None = None,
    force: bool = False,
    inputs: tuple[str, ...] = (),
) -> None:
    """Write `motion` as BVH (in `layout`) or binary glTF, by the name's extension, atomically; refuses to
    replace an existing file unless `force`, or any of `inputs`."""
    write_bytes_atomic(path, clip_bytes(path, motion, layout), force=force, inputs=inputs)
