"""The elastic patch search (docs/method.md, "Transfer", steps 4 to 7).

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

from collections.abc import Callable, Iterator
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from elastyle.core.resample import bracket, interpolate_rows
from elastyle.types import BoolArray, Float32Array, FloatArray, IntArray


class Patch(NamedTuple):
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
    positions = span_positions(starts, lengths, count, np.arange(count))
    return interpolate_rows(latents, positions.ravel()).reshape(*positions.shape, -1)  # (Q, count, Z)


def span_positions(starts: npt.ArrayLike, lengths: npt.ArrayLike, count: int, frames: IntArray) -> FloatArray:
    """Where frames (F,) of `count` evenly covering each span [start, start + length) (Q,) read: (Q, F)
    fractional frame positions (frame k at the centre of the span's k-th of `count` equal parts)."""
    starts = np.atleast_1d(np.asarray(starts, dtype=np.float64))[:, None]
    lengths = np.atleast_1d(np.asarray(lengths, dtype=np.float64))[:, None]
    return starts + (frames + 0.5) * (lengths / count) - 0.5


def window_rows(patches: list[Patch], patch_frames: int, library_frames: int) -> IntArray:
    """(P, L) the library frames of each patch's style window, held at the library's last frame."""
    rows = np.array([p.style_start for p in patches], dtype=np.int64)[:, None] + np.arange(patch_frames)
    return np.minimum(rows, library_frames - 1)


def patch_windows(
    content: FloatArray, library: FloatArray, patches: list[Patch], patch_frames: int, columns: IntArray
) -> tuple[FloatArray, FloatArray]:
    """Per-frame values columns (K,) of each patch's content span, stretched to `patch_frames` L, and of
    its style window: content (T, A) and library (N, A) give two (P, L, K) arrays."""
    if not patches:
        return np.zeros((0, patch_frames, len(columns))), np.zeros((0, patch_frames, len(columns)))
    starts, frames = np.array([(p.content_start, p.content_frames) for p in patches]).T
    spans = sample_windows(content[:, columns], starts, frames, patch_frames)  # (P, L, K)
    return spans, library[window_rows(patches, patch_frames, len(library))][:, :, columns]


def mean_gap(content: FloatArray, library: FloatArray, patches: list[Patch], patch_frames: int) -> FloatArray:
    """(P,) per patch, the distance between the mean of per-frame values over its content span, content
    (T, K), and over its style window, library (N, K) (for K = 1, the absolute difference)."""
    columns = np.arange(content.shape[1])
    spans, windows = patch_windows(content, library, patches, patch_frames, columns)  # (P, L, K) each
    return np.linalg.norm(spans.mean(axis=1) - windows.mean(axis=1), axis=1)


class StyleWindows:
    """Every L-frame window of a whitened style library (stride 1), for cosine similarity with content spans.

    A query is a content span read at L evenly spaced positions, each between two content frames (t and
    t + 1, weights 1 - a and a). Its dot product with window n is therefore a weighted sum, over the
    compared frames f, of the products of those two content frames with library frame n + f. So a call
    multiplies the content frames its queries read (r rows, a few more than the longest span) with the
    library once, G (r, N), and each query gathers its 2 Lc weighted rows of G, each shifted by its f: the
    arithmetic of r content frames against the library instead of Q L' (every query's every frame), and
    no window is materialised (an (N, L*Z) matrix would be L times the library). Queries go in groups of
    nearby spans and the library in chunks of windows, so the products stay a few megabytes.

    frame_step: windows are compared on every `frame_step`-th frame of theirs (frames n, n + s, ... of
    window n; the queries' frames 0, s, ...): a step of 2 halves the arithmetic, but among near-equal
    windows it picks others than every frame would (`TransferConfig.match_step_s`: off by default).

    valid: (N,) False for windows that would cross from one library clip into the next.
    handicap: (N,) what a window's similarity must exceed another's by to be taken before it (the mirror
    of a style clip held to one side: `steps.library.MIRROR_HANDICAP`); `best` ranks by similarity minus
    handicap and returns that score, `similarity` turns it back.
    """

    CHUNK_BYTES = 4 << 20  # products and gathered rows per chunk of windows ...
    MIN_CHUNK_WINDOWS = 256  # ... but at least this many windows per chunk
    GROUP_ROWS = 1024  # queries are taken in groups of at most this many gathered rows (2 per frame)

    def __init__(
        self,
        white_library: FloatArray,
        clip_starts: IntArray,
        patch_frames: int,
        frame_step: int = 1,
        handicap: FloatArray | None = None,
    ) -> None:
        total = white_library.shape[0]
        self.patch_frames = patch_frames
        self.frame_step = frame_step
        self.frames: Float32Array = np.ascontiguousarray(white_library, dtype=np.float32)  # (T_s, Z)
        self._columns: Float32Array = np.ascontiguousarray(self.frames.T)  # (Z, T_s)
        self.num_windows = max(total - patch_frames + 1, 0)
        energy = np.sum(white_library.astype(np.float64) ** 2, axis=1)  # (T_s,)
        norms = np.sqrt(
            sum(energy[k : k + self.num_windows] for k in range(0, patch_frames, frame_step))
        )  # (N,) over the frames compared
        self.inverse_norms: Float32Array = (1.0 / np.maximum(norms, 1e-8)).astype(np.float32)
        ends = np.append(clip_starts[1:], total)
        valid = np.zeros(self.num_windows, dtype=bool)
        for start, end in zip(clip_starts, ends):
            valid[start : max(start, end - patch_frames + 1)] = True
        self.valid: BoolArray = valid
        self._invalid: BoolArray = ~valid
        self.handicap: Float32Array | None = (
            None
            if handicap is None or not np.any(handicap)
            else np.asarray(handicap[: self.num_windows], dtype=np.float32)
        )

    def similarity(self, index: IntArray, score: FloatArray) -> FloatArray:
        """The cosine similarity (Q,) of windows index (Q,) that `best` ranked with `score` (Q,)."""
        if self.handicap is None:
            return np.asarray(score, dtype=np.float64)
        return np.asarray(score, dtype=np.float64) + self.handicap[index]

    @property
    def compared_frames(self) -> int:
        """Frames of a window that are compared: every `frame_step`-th of its L."""
        return -(-self.patch_frames // self.frame_step)

    def _similarity_chunks(
        self, content: FloatArray, starts: npt.ArrayLike, lengths: npt.ArrayLike, excluded: Exclusion | None
    ) -> Iterator[tuple[IntArray, int, int, Float32Array]]:
        """(queries (q,) of a group, first, last, cosine similarity (q, last - first) of those queries with
        windows first..last-1, less each window's handicap); -inf where a window is invalid or `excluded`
        (first, last, queries) marks it."""
        compared = np.arange(self.compared_frames) * self.frame_step  # (Lc,) the compared frames f
        positions = span_positions(starts, lengths, self.patch_frames, compared)  # (Q, Lc)
        lower, upper, weight = bracket(positions.ravel(), content.shape[0])  # (Q * Lc,) each
        lower, upper = lower.reshape(positions.shape), upper.reshape(positions.shape)  # (Q, Lc)
        weight = weight.reshape(positions.shape)
        span = int(compared[-1])  # window n's last compared frame is library frame n + span
        group = max(1, self.GROUP_ROWS // (2 * len(compared)))
        for begin in range(0, len(positions), group):
            queries = np.arange(begin, min(begin + group, len(positions)))
            low, high = lower[queries], upper[queries]  # (q, Lc)
            first_row = int(low.min())
            rows = content[first_row : int(high.max()) + 1].astype(np.float32)  # (r, Z) the frames read
            share = weight[queries].astype(np.float32)  # (q, Lc)
            low, high = low - first_row, high - first_row  # rows of `rows`
            # each query's length: |(1 - a) c_t + a c_u|^2 over its frames, from the frames' products (r, r)
            frame_products = rows @ rows.T
            squared = np.sum(
                (1 - share) ** 2 * frame_products[low, low]
                + 2 * share * (1 - share) * frame_products[low, high]
                + share**2 * frame_products[high, high],
                axis=1,
            )  # (q,)
            inverse_lengths = 1 / np.maximum(np.sqrt(squared), 1e-8)  # (q,)
            gathered_rows = np.concatenate([low, high], axis=1)  # (q, 2 Lc) rows of the products
            offsets = np.concatenate([compared, compared])  # (2 Lc,) each row's shift
            weights = np.concatenate([1 - share, share], axis=1)[:, None, :]  # (q, 1, 2 Lc)
            per_window = 4 * max(len(queries) * 2 * len(compared), len(rows))
            chunk = max(self.MIN_CHUNK_WINDOWS, self.CHUNK_BYTES // per_window)
            for first in range(0, self.num_windows, chunk):
                last = min(first + chunk, self.num_windows)
                products = rows @ self._columns[:, first : last + span]  # (r, last - first + span)
                item, row = products.itemsize, products.shape[1]
                shifted = np.ndarray(  # [t, f, n] = products[t, f + n] (as_strided without its overhead)
                    (len(rows), span + 1, last - first), products.dtype, buffer=products,
                    strides=(row * item, item, item),
                )  # fmt: skip
                dots = (weights @ shifted[gathered_rows, offsets])[:, 0]  # (q, last - first)
                dots *= inverse_lengths[:, None]
                dots *= self.inverse_norms[first:last]
                if self.handicap is not None:
                    dots -= self.handicap[first:last]
                np.copyto(dots, np.float32(-np.inf), where=self._invalid[first:last])
                if excluded is not None:
                    np.copyto(dots, np.float32(-np.inf), where=excluded(first, last, queries))
                yield queries, first, last, dots

    def similarities(
        self, content: FloatArray, starts: npt.ArrayLike, lengths: npt.ArrayLike
    ) -> Float32Array:
        """Cosine similarity (Q, N) of the content (T, Z) spans [start, start + length) (Q,), each read at L
        frames (`sample_windows`), with every window (over the compared frames); -inf where a window is
        invalid."""
        count = len(np.atleast_1d(starts))
        similarity = np.full((count, self.num_windows), -np.inf, dtype=np.float32)
        for queries, first, last, dots in self._similarity_chunks(content, starts, lengths, None):
            similarity[queries, first:last] = dots
        if self.handicap is not None:
            similarity += self.handicap
        return similarity

    def best(
        self,
        content: FloatArray,
        starts: npt.ArrayLike,
        lengths: npt.ArrayLike,
        excluded: Exclusion | None = None,
    ) -> tuple[IntArray, FloatArray]:
        """For the content (T, Z) spans [start, start + length) (Q,), each read at L frames: the best window
        index (Q,) and its score (Q,), its cosine similarity less its handicap (`similarity` gives it back),
        among the windows `excluded` (first, last, queries (q,)) -> (q, last - first) does not mark for each
        query.

        Reduced chunk by chunk, so many queries against a long library never hold a (Q, N) matrix.
        """
        count = len(np.atleast_1d(starts))
        index = np.zeros(count, dtype=np.int64)
        value = np.full(count, -np.inf)
        for queries, first, _, dots in self._similarity_chunks(content, starts, lengths, excluded):
            local = np.argmax(dots, axis=1)
            local_value = dots[np.arange(len(queries)), local]
            better = local_value > value[queries]
            index[queries[better]] = first + local[better]
            value[queries[better]] = local_value[better]
        unmatched = ~np.isfinite(value)  # every window excluded for these queries: the best of all instead
        if excluded is not None and np.any(unmatched):
            index[unmatched], value[unmatched] = self.best(
                content, np.atleast_1d(starts)[unmatched], np.atleast_1d(lengths)[unmatched]
            )
        return index, value


# (first, last, queries (q,)) -> (q, last - first): the windows each of those queries may not take
Exclusion = Callable[[int, int, IntArray], BoolArray]
# a mirrored window whose hands' sidedness differs from the content's by more (legs) is not taken
SIDE_CHANGE_LEGS = 0.3


class SideGuard(NamedTuple):
    """Mirrored style windows are taken only where they keep the content's sidedness: a one-handed action
    matched against the mirror of the style's would switch hands, and a still content matched against a
    mirrored one-handed window would raise the other hand.

    content: (T, 3) per content frame, one hand's place minus the other's (legs, heading frame);
    windows: (N, 3) the same over each library window (its mean); mirrored: (N,) windows of mirrored clips.
    Where the mean over a query's span and a mirrored window's differ by more than `SIDE_CHANGE_LEGS`, that
    window is excluded for that query.
    """

    content: FloatArray
    windows: FloatArray
    mirrored: BoolArray

    def excluded(self, spans: FloatArray) -> Exclusion:
        """The exclusion for Q queries whose content spans have the mean sides spans (Q, 3)."""
        # |s - w|^2 > d^2  <=>  |w|^2 - 2 s.w > d^2 - |s|^2: one small product per chunk and a comparison
        limits = SIDE_CHANGE_LEGS**2 - np.einsum("qk,qk->q", spans, spans)  # (Q,)

        def chunk(first: int, last: int, queries: IntArray) -> BoolArray:
            mirrored = self.mirrored[first:last]
            if not np.any(mirrored):
                return np.zeros((len(queries), last - first), dtype=bool)
            sides = self.windows[first:last]  # (n, 3)
            gaps = spans[queries] @ (-2 * sides.T)  # (q, n)
            gaps += np.einsum("nk,nk->n", sides, sides)
            return (gaps > limits[queries, None]) & mirrored

        return chunk


def guard_exclusion(
    guard: SideGuard | None, starts: npt.ArrayLike, lengths: npt.ArrayLike, count: int
) -> Exclusion | None:
    """The guard's exclusion for content spans [start, start + length) (Q,) read at `count` frames, from
    each span's mean sides; None without a guard."""
    if guard is None:
        return None
    return guard.excluded(sample_windows(guard.content, starts, lengths, count).mean(axis=1))


STILL_SHARE = 0.9  # a patch whose content frames are still for at least this share is read unstretched


def search_sequential(
    white_content: FloatArray,
    windows: StyleWindows,
    source_lengths: IntArray,
    guard: SideGuard | None = None,
    still: BoolArray | None = None,
) -> list[Patch]:
    """Greedy sequential elastic search: the elastic patches (their half-shifted sequence: `half_shifted`);
    mirrored windows only where `guard` allows them. still: (T,) content frames where the body holds still
    (`steps.action.still_frames`): a patch over such frames is read at its own length, since a stop or an
    idle has no pace to take (every stretch of it looks alike, so the best match's would be chance)."""
    patch_frames = windows.patch_frames
    num_frames = white_content.shape[0]
    patches: list[Patch] = []
    still_before = np.concatenate([[0], np.cumsum(still)]).tolist() if still is not None else None
    cursor = 0.0
    while cursor < num_frames or not patches:
        lengths = source_lengths
        first, end = (
            int(cursor),
            min(int(cursor) + patch_frames, num_frames),
        )  # the patch's frames unstretched
        if still_before is not None and end > first:
            if (still_before[end] - still_before[first]) / (end - first) >= STILL_SHARE:
                lengths = np.array([patch_frames])
        starts = np.full(len(lengths), cursor)
        excluded = guard_exclusion(guard, starts, lengths, patch_frames)
        index, score = windows.best(white_content, starts, lengths, excluded)
        choice = int(np.argmax(score))
        similarity = windows.similarity(index[choice : choice + 1], score[choice : choice + 1])[0]
        patches.append(Patch(cursor, float(lengths[choice]), int(index[choice]), float(similarity)))
        cursor += float(lengths[choice])
    return patches


def search_fixed(
    white_content: FloatArray, windows: StyleWindows, source_lengths: IntArray, guard: SideGuard | None = None
) -> list[Patch]:
    """The literal placement: patches on the content's own grid, stretch used only for matching.

    Every patch is known beforehand, so all patches and stretches are searched in one batch (their
    half-shifted sequence: `half_shifted`).
    """
    patch_frames = windows.patch_frames
    num_patches = max(1, int(np.ceil(white_content.shape[0] / patch_frames)))
    centres = (np.arange(num_patches) + 0.5) * patch_frames  # (P,)
    lengths = np.tile(source_lengths, num_patches)  # (P * S,)
    starts = np.repeat(centres, len(source_lengths)) - lengths / 2
    excluded = guard_exclusion(guard, starts, lengths, patch_frames)
    index, score = windows.best(white_content, starts, lengths, excluded)
    index, score = index.reshape(num_patches, -1), score.reshape(num_patches, -1)  # (P, S)
    similarity = windows.similarity(index, score)
    choice = np.argmax(score, axis=1)
    # placed at the content's grid: consumes exactly L content frames whatever the stretch
    return [
        Patch(i * patch_frames, float(patch_frames), int(index[i, c]), float(similarity[i, c]))
        for i, c in enumerate(choice)
    ]


def half_shifted(
    white_content: FloatArray, windows: StyleWindows, patches: list[Patch], guard: SideGuard | None = None
) -> list[Patch]:
    """Patches from the centre of each patch to the centre of the next (fixed length), searched without stretch."""
    spans = [
        (a.content_start + a.content_frames / 2, (a.content_frames + b.content_frames) / 2)
        for a, b in zip(patches[:-1], patches[1:])
    ]
    if not spans:
        return []
    starts, lengths = np.array(spans).T
    excluded = guard_exclusion(guard, starts, lengths, windows.patch_frames)
    index, score = windows.best(white_content, starts, lengths, excluded)
    similarity = windows.similarity(index, score)
    return [Patch(s, n, int(i), float(v)) for (s, n), i, v in zip(spans, index, similarity)]
