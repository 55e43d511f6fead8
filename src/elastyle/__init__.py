"""elastyle: zero-shot motion style transfer with elastic patches.

The public API:
    read_bvh, write_bvh, Motion, Skeleton   clips in and out
    mirror, find_clips                      data helpers
    load_model, transfer                    style transfer (see `elastyle.transfer`)
"""

from elastyle.errors import (
    BvhError,
    ClipTooShortError,
    DatasetError,
    ElastyleError,
    ModelError,
    OutputError,
    SkeletonMismatchError,
)
from elastyle.io.bvh import BvhLayout, read_bvh, write_bvh
from elastyle.io.dataset import find_clips
from elastyle.core.mirror import mirror
from elastyle.core.motion import Motion
from elastyle.core.skeleton import Skeleton, forward_kinematics

__all__ = [
    "BvhError",
    "BvhLayout",
    "ClipTooShortError",
    "DatasetError",
    "ElastyleError",
    "ModelError",
    "Motion",
    "OutputError",
    "Skeleton",
    "SkeletonMismatchError",
    "find_clips",
    "forward_kinematics",
    "mirror",
    "read_bvh",
    "write_bvh",
]
__version__ = "0.1.0"
