"""The output's timeline: style tracks mixed by strength and share, and the time map they imply.

docs/method.md, "Output timeline". Every track is a function of content time c on a grid (G,) of content
frames. Weights w_k(c) (strength times each style's share) mix the tracks' latents with the content's own,
and their log rates: the output plays content time at rate r(c) = exp(sum_k w_k(c) log r_k(c)), so output
time t(c) = integral of r(c) dc. Sampling the inverse map at whole output frames gives the content time of
every output frame, where the mixed latents, the root path and the content are read.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastyle.core.resample import interpolate_rows
from elastyle.steps.track import StyleTrack
from elastyle.types import FloatArray

GRID_STEP = 0.5  # content frames between evaluations of each style's track


def content_grid(num_frames: int) -> FloatArray:
    """Grid times (G,) in content frames, every GRID_STEP from the first frame to the last."""
    return np.arange(0, num_frames - 1 + 1e-9, GRID_STEP)


def mix_tracks(
    content_on_grid: FloatArray,
    strength: FloatArray,
    tracks: Sequence[StyleTrack],
    shares: Sequence[FloatArray],
) -> tuple[FloatArray, FloatArray]:
    """Latents (G, Z) and log rate (G,): the content's latents on the grid (G, Z) weighted 1 - strength (G,),
    each track weighted strength x its share (G,) (shares sum to 1)."""
    latents = (1 - strength)[:, None] * content_on_grid
    log_rate = np.zeros(content_on_grid.shape[0])
    for track, share in zip(tracks, shares):
        weight = strength * share
        latents += weight[:, None] * track.latents
        log_rate += weight * track.log_rate
    return latents, log_rate


ENDING_FRAMES = 30.0  # the output frames over which the map's last fraction of a frame is spread


def output_content_times(grid: FloatArray, log_rate: FloatArray) -> FloatArray:
    """Content time (T_out,), in content frames, of every output frame under the rate exp(log_rate).

    The map's length rounds to a whole number of output frames: its last `ENDING_FRAMES` are played a
    little faster or slower (by at most half a frame over them), so the last output frame reads the
    content's last frame at the pace of the frames before it. (Cut at the last whole frame, the clip ended
    up to a frame before the content does, and a frame added past that end repeated the last pose: a hitch
    where the clip loops or blends on.)"""
    rate = np.exp(log_rate)
    output_time = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(grid))])
    total = output_time[-1]
    frames = max(int(np.floor(total + 0.5)), 1 if total > 0 else 0)  # output frames after the first
    start = max(total - ENDING_FRAMES, 0.0)  # where the ending begins
    if total > 0 and frames > start:
        ending = output_time > start
        output_time[ending] = start + (output_time[ending] - start) * (frames - start) / (total - start)
    return np.interp(np.arange(frames + 1), output_time, grid)


def on_output_frames(values: FloatArray, grid: FloatArray, content_time: FloatArray) -> FloatArray:
    """Rows of grid values (G, ...) at the output frames' content times (T_out,) -> (T_out, ...)."""
    return interpolate_rows(values, np.interp(content_time, grid, np.arange(len(grid))))
