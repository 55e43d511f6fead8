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

from elastyle.core.resample import interpolate_rows
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
    starts = np.asarray(starts, dtype=np.float64)[:, None]
    lengths = np.asarray(lengths, dtype=np.float64)[:, None]
    positions = starts + (np.arange(count) + 0.5) * (lengths / count) - 0.5
    return interpolate_rows(latents, positions.ravel()).reshape(*positions.shape, -1)  # (Q, count, Z)


def patch_windows(
    content: FloatArray, library: FloatArray, patches: list[Patch], patch_frames: int, columns: IntArray
) -> tuple[FloatArray, FloatArray]:
    """Per-frame values columns (K,) of each patch's content span, stretched to `patch_frames` L, and of
    its style window: content (T, A) and library (N, A) give two (P, L, K) arrays."""
    if not patches:
        return np.zeros((0, patch_frames, len(columns))), np.zeros((0, patch_frames, len(columns)))
    starts, frames = np.array([(p.content_start, p.content_frames) for p in patches]).T
    spans = sample_windows(content[:, columns], starts, frames, patch_frames)  # (P, L, K)
    rows = np.array([p.style_start for p in patches])[:, None] + np.arange(patch_frames)  # (P, L)
    return spans, library[np.minimum(rows, len(library) - 1)][:, :, columns]


def mean_gap(content: FloatArray, library: FloatArray, patches: list[Patch], patch_frames: int) -> FloatArray:
    """(P,) per patch, the distance between the mean of per-frame values over its content span, content
    (T, K), and over its style window, library (N, K) (for K = 1, the absolute difference)."""
    columns = np.arange(content.shape[1])
    spans, windows = patch_windows(content, library, patches, patch_frames, columns)  # (P, L, K) each
    return np.linalg.norm(spans.mean(axis=1) - windows.mean(axis=1), axis=1)


class StyleWindows:
    """Every L-frame window of a whitened style library (stride 1), for cosine similarity.

    The windows are never materialised (an (N, L*Z) matrix would be L times the library). A window's dot
    product with a query is a sum over blocks of B frames: query block b (B*Z values) times the library's
    B frames from n + bB on. With the library stored as overlapping B-frame columns (B*Z, T_s), one matrix
    product of the query blocks with those columns, then a sum over ceil(L/B) shifted views, gives every
    window at once. B trades the product's inner size (B*Z, larger runs nearer the machine's peak) against its rows
    (Q * ceil(L/B)): it is chosen per call from the number of queries. The library is processed in chunks,
    so the products stay a few megabytes.

    frame_step: windows are compared on every `frame_step`-th frame of theirs (frames n, n + s, ... of
    window n; the queries' frames 0, s, ...): a step of 2 halves the arithmetic, but among near-equal
    windows it picks others than every frame would (`TransferConfig.match_step_s`: off by default).

    valid: (N,) False for windows that would cross from one library clip into the next.
    """

    PRODUCT_ROWS = 96  # the block size is the smallest giving at most this many query-block rows
    CHUNK_BYTES = 4 << 20  # products per chunk of windows ...
    MIN_CHUNK_WINDOWS = 256  # ... but at least this many windows per chunk
    BLOCKED_BYTES = 64 << 20  # the largest block-row copy of the library kept in memory

    def __init__(
        self, white_library: FloatArray, clip_starts: IntArray, patch_frames: int, frame_step: int = 1
    ) -> None:
        total = white_library.shape[0]
        self.patch_frames = patch_frames
        self.frame_step = frame_step
        self.frames: Float32Array = np.ascontiguousarray(white_library, dtype=np.float32)  # (T_s, Z)
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
        self._blocked: dict[int, Float32Array] = {}

    @property
    def compared_frames(self) -> int:
        """Frames of a window that are compared: every `frame_step`-th of its L."""
        return -(-self.patch_frames // self.frame_step)

    def block_frames(self, num_queries: int) -> int:
        """Compared frames per block B for a call with this many queries: the fewest giving at most
        `PRODUCT_ROWS` query-block rows (so many queries get whole windows)."""
        length = self.compared_frames
        for block in range(1, length + 1):
            if num_queries * -(-length // block) <= self.PRODUCT_ROWS:
                return block
        return length

    def block_columns(self, block: int, first: int, stop: int) -> Float32Array:
        """Library rows [first, stop) as B-frame blocks, one per column: column n holds frames n, n + s, ..
        n + s(B - 1) for the frame step s (B*Z, stop - first), zeros past the library's end (columns make
        the products' small-row GEMM faster than rows would). The whole copy is cached when it is at most
        `BLOCKED_BYTES`; otherwise columns are built per call (for many queries, whose product costs more)."""
        if block * self.frames.nbytes > self.BLOCKED_BYTES:
            return self._build_columns(block, first, stop)
        if block not in self._blocked:
            self._blocked[block] = self._build_columns(block, 0, self.frames.shape[0])
        return self._blocked[block][:, first:stop]

    def _build_columns(self, block: int, first: int, stop: int) -> Float32Array:
        total, width = self.frames.shape
        reach = self.frame_step * (block - 1) + 1  # library frames a block spans
        frames = self.frames[first : min(stop + reach - 1, total)]
        padding = stop + reach - 1 - first - frames.shape[0]
        if padding > 0:
            frames = np.concatenate([frames, np.zeros((padding, width), np.float32)])
        rows = np.lib.stride_tricks.sliding_window_view(frames, reach, axis=0)  # (stop - first, Z, reach)
        rows = rows[:, :, :: self.frame_step]  # (stop - first, Z, B)
        return np.ascontiguousarray(rows.transpose(2, 1, 0)).reshape(block * width, stop - first)

    def _similarity_chunks(
        self, queries: FloatArray, block: int | None, excluded: Exclusion | None = None
    ) -> Iterator[tuple[int, int, Float32Array]]:
        """(first, last, cosine similarity (Q, last - first) of the queries with windows first..last-1);
        -inf where a window is invalid or `excluded` (first, last) marks it for a query."""
        queries = queries[:, :: self.frame_step]  # the compared frames
        count, length, width = queries.shape
        block = block or self.block_frames(count)
        num_blocks = -(-length // block)
        # unit queries, with zero frames padding the last block
        unit = np.zeros((count, num_blocks * block, width), dtype=np.float32)
        unit[:, :length] = queries
        unit /= np.maximum(np.sqrt(np.einsum("qfz,qfz->q", unit, unit)), 1e-8)[:, None, None]
        query_blocks = unit.reshape(count * num_blocks, block * width)
        shift = block * self.frame_step  # library frames from one block of a window to its next
        span = (num_blocks - 1) * shift  # window n's last block starts at library frame n + span
        # the products, and block columns built per chunk, stay within CHUNK_BYTES each
        chunk = max(self.MIN_CHUNK_WINDOWS, self.CHUNK_BYTES // (4 * max(count * num_blocks, block * width)))
        for first in range(0, self.num_windows, chunk):
            last = min(first + chunk, self.num_windows)
            columns = self.block_columns(block, first, last + span)  # (B*Z, last - first + span)
            products = query_blocks @ columns  # (Q * num_blocks, last - first + span)
            # window n's block b is library row n + bsB: a strided view (Q, num_blocks, n) of the products
            item, row = products.itemsize, products.shape[1]
            shifted = np.ndarray(  # as_strided's view without its Python overhead (tens of us per call)
                (count, num_blocks, last - first),
                products.dtype,
                buffer=products,
                strides=(num_blocks * row * item, (row + shift) * item, item),
            )
            dots = shifted.sum(axis=1)  # (Q, last - first), a new array
            dots *= self.inverse_norms[first:last]
            np.copyto(dots, np.float32(-np.inf), where=self._invalid[first:last])
            if excluded is not None:
                np.copyto(dots, np.float32(-np.inf), where=excluded(first, last))
            yield first, last, dots

    def similarities(self, queries: FloatArray, block: int | None = None) -> Float32Array:
        """Cosine similarity (Q, N) of queries (Q, L, Z) with every window (over the compared frames); -inf
        where a window is invalid.

        block: compared frames per block B (default: `block_frames`); any B gives the same result.
        """
        chunks = [dots for _, _, dots in self._similarity_chunks(queries, block)]
        return np.concatenate(chunks, axis=1) if chunks else np.zeros((len(queries), 0), np.float32)

    def best(self, queries: FloatArray, excluded: Exclusion | None = None) -> tuple[IntArray, FloatArray]:
        """For queries (Q, L, Z): the best window index (Q,) and its cosine similarity (Q,), among the
        windows `excluded` (first, last) -> (Q, last - first) does not mark for each query.

        Reduced chunk by chunk, so many queries against a long library never hold a (Q, N) matrix.
        """
        index = np.zeros(len(queries), dtype=np.int64)
        value = np.full(len(queries), -np.inf)
        rows = np.arange(len(queries))
        for first, _, dots in self._similarity_chunks(queries, None, excluded):
            local = np.argmax(dots, axis=1)
            local_value = dots[rows, local]
            better = local_value > value
            index[better] = first + local[better]
            value[better] = local_value[better]
        unmatched = ~np.isfinite(value)  # every window excluded for these queries: the best of all instead
        if excluded is not None and np.any(unmatched):
            index[unmatched], value[unmatched] = self.best(queries[unmatched])
        return index, value


# (first, last) -> (Q, last - first): the windows a query may not take
Exclusion = Callable[[int, int], BoolArray]
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
        """The exclusion for Q queries whose content spans have the mean sides spans (Q, 3) (`sampled`)."""
        span_energy = np.sum(spans**2, axis=1)[:, None]  # (Q, 1)

        def chunk(first: int, last: int) -> BoolArray:
            mirrored = self.mirrored[first:last]
            if not np.any(mirrored):
                return np.zeros((len(spans), last - first), dtype=bool)
            sides = self.windows[first:last]  # (n, 3)
            # squared distances |s - w|^2 of every query's span to every window, as one small product
            gaps = span_energy + np.sum(sides**2, axis=1) - 2 * spans @ sides.T  # (Q, n)
            return (gaps > SIDE_CHANGE_LEGS**2) & mirrored

        return chunk


def sampled(
    frames: FloatArray, guard: SideGuard | None, starts: npt.ArrayLike, lengths: npt.ArrayLike, count: int
) -> tuple[FloatArray, Exclusion | None]:
    """The queries (Q, count, W) over content spans [start, start + length) (Q,) of the search's content
    frames (T, W), and the guard's exclusion for them (None without a guard). frames: the content's
    (`with_sides`), with the guard's sides beside them: both are read at the same positions at once."""
    if guard is None:
        return sample_windows(frames, starts, lengths, count), None
    both = sample_windows(frames, starts, lengths, count)  # (Q, count, W + 3)
    width = frames.shape[1] - guard.content.shape[1]
    return both[:, :, :width], guard.excluded(both[:, :, width:].mean(axis=1))


def with_sides(white_content: FloatArray, guard: SideGuard | None) -> FloatArray:
    """The search's content frames (T, W), with the guard's sides (T, 3) beside them for `sampled`."""
    return white_content if guard is None else np.concatenate([white_content, guard.content], axis=1)


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
    frames = with_sides(white_content, guard)
    patches: list[Patch] = []
    cursor = 0.0
    while cursor < num_frames or not patches:
        lengths = source_lengths
        span = still[int(cursor) : int(cursor) + patch_frames] if still is not None else np.zeros(0, bool)
        if len(span) and np.mean(span) >= STILL_SHARE:
            lengths = np.array([patch_frames])
        starts = np.full(len(lengths), cursor)
        index, similarity = windows.best(*sampled(frames, guard, starts, lengths, patch_frames))
        choice = int(np.argmax(similarity))
        patches.append(Patch(cursor, float(lengths[choice]), int(index[choice]), float(similarity[choice])))
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
    queries, excluded = sampled(with_sides(white_content, guard), guard, starts, lengths, patch_frames)
    index, similarity = (a.reshape(num_patches, -1) for a in windows.best(queries, excluded))  # (P, S)
    choice = np.argmax(similarity, axis=1)
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
    frames = with_sides(white_content, guard)
    index, similarity = windows.best(*sampled(frames, guard, starts, lengths, windows.patch_frames))
    return [Patch(s, n, int(i), float(v)) for (s, n), i, v in zip(spans, index, similarity)]
