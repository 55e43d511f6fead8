"""Along time: the smoothers (a Gaussian low-pass and a moving sum, edges held constant) and per-frame
differences."""

from __future__ import annotations

import numpy as np

from elastyle.types import ArrayT, FloatArray


def smooth(values: FloatArray, sigma_frames: float) -> FloatArray:
    """Gaussian low-pass along time (axis 0) of (T, ...) values; edges held constant.

    The same as scipy.ndimage.gaussian_filter1d(values, sigma, axis=0, mode="nearest") (a test checks),
    written here because importing scipy.ndimage costs about 0.6 s, more than a whole transfer. A kernel
    wider than the clip (a local mean over seconds) is one (T, T) matrix product, the held edges folded in.
    """
    if sigma_frames <= 0 or values.shape[0] < 2:
        return values.copy()
    radius = int(4.0 * sigma_frames + 0.5)
    offsets = np.arange(-radius, radius + 1)
    kernel = np.exp(-0.5 * (offsets / sigma_frames) ** 2)
    kernel /= kernel.sum()
    flat = values.reshape(values.shape[0], -1)  # (T, N)
    if values.shape[0] <= radius + 1:
        return (_covering_weights(kernel, values.shape[0]) @ flat).reshape(values.shape)
    padded = pad_edges(flat, radius, radius)  # (T + 2r, N)
    if flat.shape[1] == 1:  # one series (a share over time): numpy's convolution, twice as fast
        return np.convolve(padded[:, 0], kernel, mode="valid").reshape(values.shape)
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * radius + 1, axis=0)  # (T, N, K)
    return (windows @ kernel).reshape(values.shape)


def smooth_path(values: FloatArray, sigma_frames: float) -> FloatArray:
    """Gaussian low-pass along time (axis 0) of (T, ...) values that travel, such as a root's path or
    heading: the clip is extended past each end by its point reflection about that end (2 x[0] - x[k]; on a
    clip shorter than the kernel's radius, reflected again and again), so steady travel stays where it is
    up to the last frame. The result runs through the first and last values exactly (a step's sway there
    is not smoothed away), and a clip shorter than the radius comes out near the straight line between its
    ends. (Held edges would pull the ends towards the clip's middle by up to the distance travelled in
    about a sigma: a walk's path would start ahead of its pelvis and end behind it.)"""
    if sigma_frames <= 0 or values.shape[0] < 2:
        return values.copy()
    radius = int(4.0 * sigma_frames + 0.5)
    flat = values.reshape(values.shape[0], -1)  # (T, N)
    padded = np.pad(flat, ((radius, radius), (0, 0)), mode="reflect", reflect_type="odd")  # (T + 2r, N)
    return smooth(padded, sigma_frames)[radius : radius + values.shape[0]].reshape(values.shape)


def _covering_weights(kernel: FloatArray, num_frames: int) -> FloatArray:
    """(T, T) weights of a kernel (2r + 1,) of radius r >= T - 1 on a clip of T frames, edges held: row t
    reads frame s at kernel[r + s - t], and the first and last frames also take the kernel beyond them."""
    radius = len(kernel) // 2
    views = np.lib.stride_tricks.sliding_window_view(kernel, num_frames)  # (2r + 2 - T, T)
    weights = views[radius - num_frames + 1 : radius + 1][::-1].copy()  # row t: kernel[r - t : r - t + T]
    below = np.concatenate([[0.0], np.cumsum(kernel)])  # below[i]: the kernel's sum before index i
    rows = np.arange(num_frames)
    weights[:, 0] += below[radius - rows]  # the frames before the clip, held at its first
    weights[:, -1] += below[-1] - below[num_frames + radius - rows]  # after it, held at its last
    return weights


def pad_edges(values: ArrayT, before: int, after: int) -> ArrayT:
    """(T + before + after, ...) values (T, ...) with the first row repeated `before` times ahead and the
    last `after` times behind: np.pad's mode "edge" along time, without its overhead (a few times faster
    on the arrays used here)."""
    padded = np.empty((values.shape[0] + before + after, *values.shape[1:]), dtype=values.dtype)
    padded[before : before + values.shape[0]] = values
    padded[:before] = values[0]
    padded[before + values.shape[0] :] = values[-1]
    return padded  # type: ignore[return-value]


def moving_sum(values: FloatArray, width: int) -> FloatArray:
    """Sum along time (axis 0) of (T, ...) values over `width` frames about each frame, frames
    [t - width // 2, t + (width - 1) // 2], edges held constant: the same as width times
    scipy.ndimage.uniform_filter1d(values, width, axis=0, mode="nearest") (a test checks), without that
    import's cost (see `smooth`)."""
    flat = values.reshape(values.shape[0], -1)  # (T, N)
    padded = pad_edges(flat, width // 2 + 1, (width - 1) // 2)
    padded[0] = 0.0  # the cumulative sum starts from zero
    totals = np.cumsum(padded, axis=0)  # (T + width, N)
    return (totals[width:] - totals[:-width]).reshape(values.shape)


def smoothstep(values: FloatArray) -> FloatArray:
    """Values clipped to [0, 1] and eased: 3 x^2 - 2 x^3, flat at both ends (any shape)."""
    x = np.clip(values, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def frame_steps(values: FloatArray) -> FloatArray:
    """Per-frame change (T, ...) of (T, ...) values by central differences (one-sided at the ends); zero
    for a single frame. Times the frame rate, a velocity."""
    return np.gradient(values, axis=0) if len(values) > 1 else np.zeros_like(values)
