"""The motion clip type: local joint rotations and translations over time, and resampling."""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from elastyle.core.resample import interpolate_rows
from elastyle.core.rotations import lengths, multiply, slerp_resample
from elastyle.core.skeleton import Skeleton, forward_kinematics
from elastyle.errors import BvhError
from elastyle.types import FloatArray, IntArray


@dataclass(frozen=True, eq=False)
class Motion:
    """A clip on one skeleton.

    rotations:    (T, J, 3) local joint rotations as exp maps, radians.
    translations: (T, J, 3) local joint translations in the file's length unit: the animated position
                  channels where a joint has them (the root's world position, for example), else the
                  skeleton's rest offset repeated.
    fps:          frames per second.
    """

    skeleton: Skeleton
    rotations: FloatArray
    translations: FloatArray
    fps: float

    def __post_init__(self) -> None:
        for name in (
            "rotations",
            "translations",
        ):  # lists of numbers as arrays, whole and half-precision as float64
            values = getattr(self, name)
            if not isinstance(values, np.ndarray):
                values = np.asarray(values, dtype=np.float64)
            if values.dtype.kind in "iu" or (values.dtype.kind == "f" and values.dtype.itemsize < 4):
                values = values.astype(np.float64)
            if values.dtype.kind != "f":
                raise ValueError(f"{name} must be real numbers, got {values.dtype} values")
            object.__setattr__(self, name, values)
        num_joints = self.skeleton.num_joints
        if self.rotations.ndim != 3 or self.rotations.shape[1:] != (num_joints, 3):
            raise ValueError(f"rotations must be (T, {num_joints}, 3), got {self.rotations.shape}")
        if self.translations.shape != self.rotations.shape:
            raise ValueError(
                f"translations must match rotations {self.rotations.shape}, got {self.translations.shape}"
            )
        _check_fps(self.fps)

    def __repr__(self) -> str:
        return f"Motion({self.num_frames} frames at {self.fps:g} fps, {self.skeleton!r})"

    @property
    def num_frames(self) -> int:
        """T, the number of frames."""
        return int(self.rotations.shape[0])

    @property
    def duration_s(self) -> float:
        """The clip's length in seconds: its frame count over its frame rate."""
        return self.num_frames / self.fps

    def is_finite(self) -> bool:
        """Whether every rotation and translation is a finite number (nothing NaN or infinite)."""
        return bool(np.all(np.isfinite(self.rotations)) and np.all(np.isfinite(self.translations)))

    def first_non_finite_frame(self) -> int | None:
        """The first frame holding a NaN or infinite rotation or translation, None where every one is finite."""
        bad = ~(
            np.isfinite(self.rotations).all(axis=(1, 2)) & np.isfinite(self.translations).all(axis=(1, 2))
        )
        return int(np.argmax(bad)) if bad.any() else None

    def scaled(self, factor: float) -> Motion:
        """The clip `factor` times as large: its skeleton and every translation (rotations unchanged)."""
        return Motion(self.skeleton.scaled(factor), self.rotations, self.translations * factor, self.fps)

    def renamed(self, names: Sequence[str]) -> Motion:
        """The same clip with its joints named `names` (J,): one skeleton read under another's names."""
        given = (names,) if isinstance(names, str) else tuple(names)
        if isinstance(names, str) or len(given) != self.skeleton.num_joints:
            count = "a string" if isinstance(names, str) else f"{len(given)} names"
            raise ValueError(f"renamed takes one name per joint ({self.skeleton.num_joints}), got {count}")
        return Motion(replace(self.skeleton, names=given), self.rotations, self.translations, self.fps)

    def slice(self, start: int, stop: int) -> Motion:
        """Frames [start, stop) as a new clip."""
        return Motion(self.skeleton, self.rotations[start:stop], self.translations[start:stop], self.fps)

    def world(self, joints: Sequence[int] | IntArray | None = None) -> tuple[FloatArray, FloatArray]:
        """World rotation matrices (T, J, 3, 3) and positions (T, J, 3) by forward kinematics.

        joints: compute only these and their ancestors (the others are NaN); None: every joint.
        """
        return forward_kinematics(self.skeleton, self.rotations, self.translations, joints)

    def positions(self, joints: Sequence[int] | IntArray | None = None) -> FloatArray:
        """World joint positions (T, J, 3) in file units (only `joints` and their ancestors when given)."""
        return self.world(joints)[1]

    def with_joints(self, other: Motion, joints: IntArray, translations: bool = False) -> Motion:
        """This clip with the rotations of `joints` (K,) taken from `other` (the same skeleton and frames);
        their translations too if asked, else this clip's (the root's path, the bones' lengths)."""
        rotations = self.rotations.copy()
        rotations[:, joints] = other.rotations[:, joints]
        moved = self.translations
        if translations:
            moved = moved.copy()
            moved[:, joints] = other.translations[:, joints]
        return Motion(self.skeleton, rotations, moved, self.fps)

    def sample(self, frame_times: FloatArray, fps: float | None = None) -> Motion:
        """The clip at fractional frame indices (N,): slerp for rotations, linear for translations."""
        frame_times = np.clip(np.asarray(frame_times, dtype=np.float64), 0.0, self.num_frames - 1)
        translations = interpolate_rows(self.translations, frame_times)
        rotations = slerp_resample(self.rotations, frame_times)
        return Motion(self.skeleton, rotations, translations, self.fps if fps is None else fps)

    def resample_to_end(self, fps: float) -> tuple[Motion, float]:
        """The clip at about `fps`, its frames spread evenly from its first frame to its very last (so a
        clip read at the other rate ends where this one does), and how many of this clip's frames one of
        the new clip's spans (exactly this clip's frame rate over `fps` where it comes out even)."""
        if abs(fps - self.fps) < 1e-9 or self.num_frames < 2:
            return self.resample(fps), self.fps / fps
        num_frames = max(2, int(round((self.num_frames - 1) * fps / self.fps)) + 1)
        frame_times = np.linspace(0.0, self.num_frames - 1, num_frames)  # (N,) source frame indices
        return self.sample(frame_times, fps), (self.num_frames - 1) / (num_frames - 1)

    def resample(self, fps: float) -> Motion:
        """The same clip at another frame rate; the duration stays (up to one frame)."""
        _check_fps(fps)
        if abs(fps - self.fps) < 1e-9:
            return self
        num_frames = max(1, int(round((self.num_frames - 1) * fps / self.fps)) + 1)
        frame_times = np.arange(num_frames, dtype=np.float64) * (self.fps / fps)  # (N,) source frame indices
        return self.sample(frame_times, fps)


def _check_fps(fps: object) -> None:
    """A `ValueError` unless `fps` is a positive finite number (not a bool, a string or an array)."""
    if isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not 0 < float(fps) < np.inf:
        raise ValueError(f"fps must be a positive finite number, got {fps!r}")


def check_finite_clip(motion: Motion, name: str) -> None:
    """A `BvhError` naming the clip and its first frame holding NaN or infinite values, if any (a clip built
    in code: a file's reader refuses such values itself)."""
    frame = motion.first_non_finite_frame()
    if frame is not None:
        raise BvhError(name, f"NaN or infinite values, first at frame {frame}")


# a first frame some joint turns LEADING_POSE_DEG or more from, LEADING_POSE_FACTOR times as far as in any
# later step of the clip, is a pose exported before the motion
LEADING_POSE_DEG = 60.0
LEADING_POSE_FACTOR = 4.0


def leading_pose_note(motion: Motion, name: str) -> str | None:
    """A note where a clip's first frame is a pose apart from its motion (a T-pose or bind pose that many
    exporters write as frame 0): some joint turns over `LEADING_POSE_DEG` from it to the next frame, and
    `LEADING_POSE_FACTOR` times as far as in any later step; None otherwise."""
    if motion.num_frames < 3:
        return None

    def largest_steps(start: int, stop: int) -> FloatArray:
        """(stop - start,) the largest joint turn (degrees) from each frame in [start, stop) to the next."""
        turns = multiply(-motion.rotations[start:stop], motion.rotations[start + 1 : stop + 1])  # (n, J, 3)
        return np.degrees(lengths(turns)).max(axis=1)

    first = float(largest_steps(0, 1)[0])
    if first < LEADING_POSE_DEG:  # most clips: the later steps need not be read
        return None
    if first < LEADING_POSE_FACTOR * float(largest_steps(1, motion.num_frames - 1).max()):
        return None
    return (
        f"note: {name}: its first frame is a pose apart from its motion (a joint turns {first:.0f} degrees from "
        "it to the next frame): a T-pose or bind pose exported before the motion? It is read as a "
        "frame of the clip; trim it from the file if it is not one"
    )
