"""Training batches: windows of normalised features sampled over every clip, with time augmentations.

Features are per frame (docs/method.md, "Features"), so a clip played backwards has its features
backwards, and a clip played at another speed has its features resampled along time: both
augmentations act on the feature windows directly, without re-encoding.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.resample import interpolate_rows
from elastyle.types import Float32Array, IntArray


def sample_windows(
    clips: Sequence[Float32Array],
    window: int,
    count: int,
    rng: np.random.Generator,
    speed: float = 1.0,
    reverse_share: float = 0.0,
) -> Float32Array:
    """`count` windows (B, C, W) drawn uniformly over every start frame of every clip (T_i, C) that is
    long enough.

    speed: each window covers round(W * speed) source frames, resampled linearly to W frames.
    reverse_share: the share of windows played backwards.
    """
    source = max(2, int(round(window * speed)))
    starts_per_clip = np.array([max(c.shape[0] - source + 1, 0) for c in clips])
    cumulative = np.cumsum(starts_per_clip)
    if cumulative[-1] == 0:
        raise ValueError(f"no clip has {source} frames")
    picks = rng.integers(0, cumulative[-1], size=count)
    clip_index = np.searchsorted(cumulative, picks, side="right")
    starts = picks - (cumulative[clip_index] - starts_per_clip[clip_index])
    positions = np.linspace(0, source - 1, window)  # (W,) source frames of the window's frames
    batch = []
    for index, start in zip(clip_index, starts):
        rows = clips[index][start : start + source]
        batch.append(rows if source == window else interpolate_rows(rows, positions))
    windows = np.stack(batch).astype(np.float32)  # (B, W, C)
    backwards = rng.random(count) < reverse_share
    windows[backwards] = windows[backwards, ::-1]
    return np.ascontiguousarray(windows.transpose(0, 2, 1))  # (B, C, W)


def perturb_windows(
    windows: Float32Array,
    share: float,
    scale: float,
    groups: IntArray,
    low: Float32Array,
    high: Float32Array,
    rng: np.random.Generator,
) -> Float32Array:
    """Windows (B, C, W) of normalised features with random per-joint offsets on a `share` of them: poses
    the recorded clips never hold, within the ranges they do.

    In a perturbed window each joint (the channels sharing a `groups` (C,) id: a joint's exp map, the
    pelvis's sway and height) is moved with probability one half, by an offset that drifts linearly from
    one draw to another over the window (normal, `scale` standard deviations of each channel), then every
    channel is clipped to its recorded range [low, high] (C,). A new array; the others are copies.
    """
    windows = windows.copy()
    count, channels, width = windows.shape
    chosen = np.flatnonzero(rng.random(count) < share)
    if len(chosen) == 0:
        return windows
    num_groups = int(groups.max()) + 1
    moved = (rng.random((len(chosen), num_groups)) < 0.5)[:, groups]  # (K, C)
    ends = rng.normal(0.0, scale, size=(2, len(chosen), channels)) * moved  # (2, K, C)
    ramp = np.linspace(0.0, 1.0, width, dtype=np.float32)  # (W,)
    offsets = ends[0, ..., None] * (1 - ramp) + ends[1, ..., None] * ramp  # (K, C, W)
    windows[chosen] = np.clip(windows[chosen] + offsets, low[:, None], high[:, None])
    return windows


def draw_speed(rng: np.random.Generator, share: float, speed_range: tuple[float, float]) -> float:
    """A batch's playback speed: 1 with probability 1 - share, else log-uniform over speed_range."""
    if rng.random() >= share:
        return 1.0
    low, high = np.log(speed_range[0]), np.log(speed_range[1])
    return float(np.exp(rng.uniform(low, high)))
