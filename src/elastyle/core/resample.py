"""The one interpolation helper: rows of an array at fractional positions along its first axis.

Resampling a clip, reading a latent track at fractional frames, retiming a root path and stretching a
training window all go through `interpolate_rows` (rotations through `slerp_resample`, which shares its
`bracket`).
"""

from __future__ import annotations

import numpy as np

from elastyle.types import ArrayT, FloatArray


def bracket(positions: FloatArray, length: int) -> tuple[np.ndarray, np.ndarray, FloatArray]:
    """For fractional positions (G,) on an axis of `length` rows: lower and upper row indices (G,) and the
    upper row's weight (G,), positions clamped to [0, length - 1] (values held past the ends)."""
    # np.minimum / np.maximum: np.clip costs more on arrays this small
    positions = np.minimum(np.maximum(np.asarray(positions, dtype=np.float64), 0.0), length - 1)
    lower = np.floor(positions).astype(np.int64)
    upper = np.minimum(lower + 1, length - 1)
    return lower, upper, positions - lower


def interpolate_rows(values: ArrayT, positions: FloatArray) -> ArrayT:
    """Rows of values (N, ...) at fractional positions (G,), linearly -> (G, ...), held past the ends."""
    lower, upper, weight = bracket(positions, values.shape[0])
    weight = weight.reshape(-1, *([1] * (values.ndim - 1))).astype(values.dtype)
    return (1 - weight) * values[lower] + weight * values[upper]  # type: ignore[return-value]
