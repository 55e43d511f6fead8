"""The elastic patch search (METHOD.md section 4, steps 3 to 6).

Content patches of L frames are compared, after resampling each candidate source length L' to L
frames, with every style window of L frames by cosine similarity. Two placements of the result:

* sequential (default): output patch i spans output frames [iL, (i+1)L) and consumes content frames
  [u_i, u_i + L'_i); u_{i+1} = u_i + L'_i, so the content is read at the matched stretch and the output
  takes the style's pace;
* fixed (the report read literally): content patch i sits at content frames [iL, (i+1)L), the stretch
  only affects which style window is chosen, and the output keeps the content's timeline.

The half-shifted second sequence spans from the centre of one elastic patch to the centre of the next.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from elastyle.types import BoolArray, Float32Array, FloatArray, IntArray


@dataclass(frozen=True)
class Patch:
    """One matched patch: content frames [content_start, content_start + content_frames) are replaced by
    the style window starting at library frame `style_start` (L frames). similarity: cosine, [-1, 1]."""

    content_start: float
    content_frames: float
    style_start: int
    similarity: float


def sample_windows(
    latents: FloatArray, starts: npt.ArrayLike, lengths: npt.ArrayLike, count: int
) -> FloatArray:
    """For each of Q spans, `count` frames evenly covering latents[start : start + length]: (Q, count, Z).

    Linear between frames, held at the clip's ends. starts, lengths: (Q,) in frames.
    """
    starts = np.asarray(starts, dtype=np.float64)[:, None]
    lengths = np.asarray(lengths, dtype=np.float64)[:, None]
    positions = np.clip(starts + (np.arange(count) + 0.5) * (lengths / count) - 0.5, 0, latents.shape[0] - 1)
    lower = np.floor(positions).astype(np.int64)  # (Q, count)
    upper = np.minimum(lower + 1, latents.shape[0] - 1)
    weight = (positions - lower)[..., None]
    return (1 - weight) * latents[lower] + weight * latents[upper]


class StyleWindows:
    """Every L-frame window of a whitened style library (stride 1), for cosine similarity.

    The windows are never materialised (an (N, L*Z) matrix would be L times the library): a query's
    dot product with window n is the sum over its frames k of frame products q_k . s_(n+k), so one
    matrix product of the query frames with the library's frames, then L shifted additions, gives all
    windows at once. The library is processed in chunks of frames, so memory stays bounded.

    valid: (N,) False for windows that would cross from one library clip into the next.
    """

    CHUNK_FRAMES = 4096

    def __init__(self, white_library: FloatArray, clip_starts: IntArray, patch_frames: int) -> None:
        total = white_library.shape[0]
        self.patch_frames = patch_frames
        self.frames: Float32Array = np.ascontiguousarray(white_library, dtype=np.float32)  # (T_s, Z)
        self.num_windows = max(total - patch_frames + 1, 0)
        energy = np.concatenate([[0.0], np.cumsum(np.sum(white_library.astype(np.float64) ** 2, axis=1))])
        self.norms = np.sqrt(np.maximum(energy[patch_frames:] - energy[:-patch_frames], 0.0))  # (N,)
        ends = np.append(clip_starts[1:], total)
        valid = np.zeros(self.num_windows, dtype=bool)
        for start, end in zip(clip_starts, ends):
            valid[start : max(start, end - patch_frames + 1)] = True
        self.valid: BoolArray = valid

    def similarities(self, queries: FloatArray) -> Float32Array:
        """Cosine similarity (Q, N) of queries (Q, L, Z) with every window; -inf where a window is invalid."""
        count, length, width = queries.shape
        flat = queries.reshape(count, -1)
        unit = (flat / np.maximum(np.linalg.norm(flat, axis=1, keepdims=True), 1e-8)).astype(np.float32)
        query_frames = unit.reshape(count * length, width)  # (Q*L, Z)
        dots = np.zeros((count, self.num_windows), dtype=np.float32)
        for first in range(0, self.num_windows, self.CHUNK_FRAMES):
            last = min(first + self.CHUNK_FRAMES, self.num_windows)
            products = (query_frames @ self.frames[first : last + length - 1].T).reshape(count, length, -1)
            for k in range(length):  # window n's frame k is library frame n + k
                dots[:, first:last] += products[:, k, k : k + last - first]
        similarity = dots / np.maximum(self.norms, 1e-8).astype(np.float32)
        similarity[:, ~self.valid] = -np.inf
        return similarity

    def best(self, queries: FloatArray) -> tuple[IntArray, FloatArray]:
        """For queries (Q, L, Z): the best window index (Q,) and its cosine similarity (Q,)."""
        similarity = self.similarities(queries)
        index = np.argmax(similarity, axis=1)
        return index, similarity[np.arange(len(index)), index].astype(np.float64)


def search_sequential(
    white_content: FloatArray, windows: StyleWindows, source_lengths: IntArray
) -> tuple[list[Patch], list[Patch]]:
    """Greedy sequential elastic search: (elastic patches, half-shifted patches)."""
    patch_frames = windows.patch_frames
    num_frames = white_content.shape[0]
    patches: list[Patch] = []
    cursor = 0.0
    while cursor < num_frames or not patches:
        queries = sample_windows(
            white_content, np.full(len(source_lengths), cursor), source_lengths, patch_frames
        )
        index, similarity = windows.best(queries)
        choice = int(np.argmax(similarity))
        patches.append(
            Patch(cursor, float(source_lengths[choice]), int(index[choice]), float(similarity[choice]))
        )
        cursor += float(source_lengths[choice])
    return patches, _half_shifted(white_content, windows, patches)


def search_fixed(
    white_content: FloatArray, windows: StyleWindows, source_lengths: IntArray
) -> tuple[list[Patch], list[Patch]]:
    """The literal placement: patches on the content's own grid, stretch used only for matching."""
    patch_frames = windows.patch_frames
    num_patches = max(1, int(np.ceil(white_content.shape[0] / patch_frames)))
    patches = []
    for i in range(num_patches):
        centre = (i + 0.5) * patch_frames
        queries = sample_windows(white_content, centre - source_lengths / 2, source_lengths, patch_frames)
        index, similarity = windows.best(queries)
        choice = int(np.argmax(similarity))
        # placed at the content's grid: consumes exactly L content frames whatever the stretch
        patches.append(
            Patch(i * patch_frames, float(patch_frames), int(index[choice]), float(similarity[choice]))
        )
    return patches, _half_shifted(white_content, windows, patches)


def _half_shifted(white_content: FloatArray, windows: StyleWindows, patches: list[Patch]) -> list[Patch]:
    """Patches from the centre of each patch to the centre of the next (fixed length), searched without stretch."""
    spans = [
        (a.content_start + a.content_frames / 2, (a.content_frames + b.content_frames) / 2)
        for a, b in zip(patches[:-1], patches[1:])
    ]
    if not spans:
        return []
    starts, lengths = np.array(spans).T
    queries = sample_windows(white_content, starts, lengths, windows.patch_frames)
    index, similarity = windows.best(queries)
    return [Patch(s, n, int(i), float(v)) for (s, n), i, v in zip(spans, index, similarity)]
