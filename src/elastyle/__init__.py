"""elastyle: zero-shot motion style transfer with elastic patches.

The public API:
    read_bvh, write_bvh, write_clip, BvhLayout, Motion, Skeleton
                                                        clips in and out (read_bvh: BVH or .glb, also in a
                                                        zip; write_clip: .bvh or .glb by the name)
    transfer, TransferConfig, TransferResult            the transfer (`elastyle.pipeline` shows its steps)
    load_model, prepare_style, StyleLibrary             a model, and a style library encoded once for reuse
    mirror, find_clips, forward_kinematics              data helpers
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from elastyle.core.mirror import mirror
    from elastyle.core.motion import Motion
    from elastyle.core.skeleton import Skeleton, forward_kinematics
    from elastyle.errors import (
        BvhError,
        ClipTooShortError,
        ConfigError,
        DatasetError,
        ElastyleError,
        ModelError,
        OutputError,
        RestPoseError,
        ResultError,
        SkeletonMismatchError,
        UsageError,
    )
    from elastyle.io.bvh_layout import BvhLayout
    from elastyle.io.bvh_write import write_bvh
    from elastyle.io.clip_write import write_clip
    from elastyle.io.dataset import find_clips
    from elastyle.io.dataset import read_clip as read_bvh  # a BVH or .glb file, also inside a zip
    from elastyle.model.file import load_model
    from elastyle.pipeline import TransferResult, transfer
    from elastyle.steps.config import TransferConfig
    from elastyle.steps.library import StyleLibrary, prepare_style


# each public name's module and its name there, imported when the name is first used: `import elastyle` and
# the command line's start load only what they use (and Ctrl-C at start-up is caught as any other)
_PUBLIC = {
    "mirror": ("elastyle.core.mirror", "mirror"),
    "Motion": ("elastyle.core.motion", "Motion"),
    "Skeleton": ("elastyle.core.skeleton", "Skeleton"),
    "forward_kinematics": ("elastyle.core.skeleton", "forward_kinematics"),
    **{
        name: ("elastyle.errors", name)
        for name in (
            "BvhError",
            "ClipTooShortError",
            "ConfigError",
            "DatasetError",
            "ElastyleError",
            "ModelError",
            "OutputError",
            "RestPoseError",
            "ResultError",
            "SkeletonMismatchError",
            "UsageError",
        )
    },
    "BvhLayout": ("elastyle.io.bvh_layout", "BvhLayout"),
    "write_bvh": ("elastyle.io.bvh_write", "write_bvh"),
    "write_clip": ("elastyle.io.clip_write", "write_clip"),
    "find_clips": ("elastyle.io.dataset", "find_clips"),
    "read_bvh": ("elastyle.io.dataset", "read_clip"),
    "load_model": ("elastyle.model.file", "load_model"),
    "TransferResult": ("elastyle.pipeline", "TransferResult"),
    "transfer": ("elastyle.pipeline", "transfer"),
    "TransferConfig": ("elastyle.steps.config", "TransferConfig"),
    "StyleLibrary": ("elastyle.steps.library", "StyleLibrary"),
    "prepare_style": ("elastyle.steps.library", "prepare_style"),
}


# the package's own modules, reachable as attributes as they were before names were loaded when first used
_MODULES = {
    "cli",
    "core",
    "errors",
    "eval",
    "io",
    "model",
    "pipeline",
    "steps",
    "training",
    "types",
    "viewer",
}


def __getattr__(name: str) -> Any:
    if name in _MODULES:
        return importlib.import_module(f"elastyle.{name}")
    if name not in _PUBLIC:
        raise AttributeError(f"module 'elastyle' has no attribute {name!r}")
    module, attribute = _PUBLIC[name]
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC})


__all__ = [
    "BvhError",
    "BvhLayout",
    "ClipTooShortError",
    "ConfigError",
    "DatasetError",
    "ElastyleError",
    "ModelError",
    "Motion",
    "OutputError",
    "Skeleton",
    "RestPoseError",
    "ResultError",
    "SkeletonMismatchError",
    "StyleLibrary",
    "TransferConfig",
    "TransferResult",
    "UsageError",
    "find_clips",
    "forward_kinematics",
    "load_model",
    "mirror",
    "prepare_style",
    "read_bvh",
    "transfer",
    "write_bvh",
    "write_clip",
]
__version__ = "0.1.0"
