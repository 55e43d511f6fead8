"""Writing a clip in the format its output name asks for: `.bvh` (the content's own layout) or `.glb`."""

from __future__ import annotations

import os
from pathlib import Path

from elastyle.core.motion import Motion
from elastyle.errors import UsageError
from elastyle.io.bvh_layout import BvhLayout

OUTPUT_SUFFIXES = (".bvh", ".glb")


def check_output_format(path: str | os.PathLike[str]) -> None:
    """A `UsageError` for an output name elastyle cannot write (never a BVH under another name)."""
    suffix = Path(path).suffix.lower()
    if suffix not in OUTPUT_SUFFIXES:
        raise UsageError(
            f"{path}: unknown output format {suffix or '(no extension)'!r}; name it .bvh or .glb (glTF 2.0)"
        )


def write_clip(
    path: str | os.PathLike[str],
    motion: Motion,
    layout: BvhLayout | None = None,
    force: bool = False,
    inputs: tuple[str, ...] = (),
) -> None:
    """Write `motion` as BVH (in `layout`) or binary glTF, by the name's extension."""
    check_output_format(path)
    if Path(path).suffix.lower() == ".glb":
        from elastyle.io.gltf_write import write_glb

        write_glb(path, motion, force=force, inputs=inputs)
    else:
        from elastyle.io.bvh_write import write_bvh

        write_bvh(path, motion, layout, force=force, inputs=inputs)
