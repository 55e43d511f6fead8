"""elastyle: zero-shot motion style transfer with elastic patches.

The public API:
    read_bvh, write_bvh, write_clip, BvhLayout, Motion, Skeleton
                                                        clips in and out (read_bvh: BVH or .glb, also in a
                                                        zip; write_clip: .bvh or .glb by the name)
    transfer, TransferConfig, TransferResult            the transfer (`elastyle.pipeline` shows its steps)
    load_model, prepare_style, StyleLibrary             a model, and a style library encoded once for reuse
    mirror, find_clips, forward_kinematics              data helpers
"""

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
from elastyle.io.dataset import read_clip as read_bvh  # a BVH or .glb file, also a path inside a zip archive
from elastyle.model.file import load_model
from elastyle.pipeline import TransferResult, transfer
from elastyle.steps.config import TransferConfig
from elastyle.steps.library import StyleLibrary, prepare_style

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
