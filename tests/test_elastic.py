"""The patch search against a plain loop over every style window in float64."""

from __future__ import annotations

import numpy as np

from elastyle.steps.search import SideGuard, StyleWindows, half_shifted, sample_windows, search_sequential


def _brute_force_best(
    library: np.ndarray, valid_starts: list[int], query: np.ndarray, step: int = 1
) -> tuple[int, float]:
    best, best_similarity = -1, -np.inf
    flat_query = query[::step].ravel() / np.linalg.norm(query[::step])
    for start in valid_starts:
        window = library[start : start + query.shape[0]][::step].ravel()
        similarity = float(flat_query @ window / np.linalg.norm(window))
        if similarity > best_similarity:
            best, best_similarity = start, similarity
    return best, best_similarity


def test_batched_float32_search_agrees_with_float64_loop() -> None:
    rng = np.random.default_rng(0)
    clip_lengths = [70, 45, 90]  # a library of three clips: no window may straddle two of them
    library = rng.standard_normal((sum(clip_lengths), 8))
    starts = np.cumsum([0] + clip_lengths[:-1])
    patch = 12
    windows = StyleWindows(library, starts, patch)
    valid = [s + k for s, n in zip(starts, clip_lengths) for k in range(n - patch + 1)]
    assert np.flatnonzero(windows.valid).tolist() == valid
    content = rng.standard_normal((100, 8))
    # spans stretched and squeezed, one running past the content's end (its last frame held)
    span_starts, span_lengths = (
        np.arange(0, 84, 7.0),
        np.array([14.0, 9.5, 12, 17, 11, 14, 13, 8, 15, 12, 14, 30]),
    )
    queries = sample_windows(content, span_starts, span_lengths, patch)
    index, similarity = windows.best(content, span_starts, span_lengths)
    for q, query in enumerate(queries):
        expected, expected_similarity = _brute_force_best(library, valid, query)
        assert index[q] == expected
        assert abs(similarity[q] - expected_similarity) < 1e-5
    # small groups of queries and small chunks of windows give the same similarities
    reference = windows.similarities(content, span_starts, span_lengths)
    windows.CHUNK_BYTES, windows.MIN_CHUNK_WINDOWS, windows.GROUP_ROWS = 1, 10, 1
    assert np.allclose(windows.similarities(content, span_starts, span_lengths), reference, atol=1e-5)
    assert windows.best(content, span_starts, span_lengths)[0].tolist() == index.tolist()


def test_windows_compared_on_every_other_frame() -> None:
    rng = np.random.default_rng(2)
    clip_lengths = [70, 45, 90]
    library = rng.standard_normal((sum(clip_lengths), 8))
    starts = np.cumsum([0] + clip_lengths[:-1])
    content = rng.standard_normal((100, 8))
    span_starts, span_lengths = np.arange(0, 80, 7.0), np.full(12, 14.0)
    for patch in (12, 13):  # compared frames 0, 2, .., 10 and 0, 2, .., 12
        windows = StyleWindows(library, starts, patch, frame_step=2)
        valid = np.flatnonzero(windows.valid).tolist()
        queries = sample_windows(content, span_starts, span_lengths, patch)
        index, similarity = windows.best(content, span_starts, span_lengths)
        for q, query in enumerate(queries):
            expected, expected_similarity = _brute_force_best(library, valid, query, step=2)
            assert index[q] == expected
            assert abs(similarity[q] - expected_similarity) < 1e-5
        reference = windows.similarities(content, span_starts, span_lengths)
        windows.CHUNK_BYTES, windows.MIN_CHUNK_WINDOWS, windows.GROUP_ROWS = 1, 10, 1
        assert np.allclose(windows.similarities(content, span_starts, span_lengths), reference, atol=1e-5)


def test_sequential_search_consumes_the_content_at_the_matched_stretch() -> None:
    rng = np.random.default_rng(1)
    # the style is the content played 1.25 times faster: the search should read about 1.25 L per patch
    phase = np.arange(400) * 2 * np.pi / 40
    content = np.stack(
        [np.sin(phase), np.cos(phase), np.sin(2 * phase)], axis=1
    ) + 0.01 * rng.standard_normal((400, 3))
    style_phase = np.arange(300) * 2 * np.pi / 32
    style = np.stack([np.sin(style_phase), np.cos(style_phase), np.sin(2 * style_phase)], axis=1)
    windows = StyleWindows(style, np.array([0]), 32)
    patches = search_sequential(content, windows, np.arange(24, 41))
    shifted = half_shifted(content, windows, patches)
    stretches = [p.content_frames / 32 for p in patches[:-1]]
    assert abs(float(np.median(stretches)) - 1.25) < 0.07
    assert patches[0].content_start == 0
    for a, b in zip(patches, patches[1:]):
        assert b.content_start == a.content_start + a.content_frames
    assert len(shifted) == len(patches) - 1


def test_mirrored_windows_are_not_taken_where_they_switch_the_content_s_sides() -> None:
    rng = np.random.default_rng(3)
    content = rng.standard_normal((60, 4))
    original = content[::-1] + 0.5 * rng.standard_normal((60, 4))  # like the content, not as like
    library = np.concatenate([original, content])  # the second clip: the mirror, the content itself
    starts = np.array([0, 60])
    windows = StyleWindows(library, starts, 12)
    mirrored = np.arange(windows.num_windows) >= 60
    lengths = np.array([12])
    # the content's hands level (sides 0); the mirror's windows one hand 1 leg above the other
    window_sides = np.where(mirrored[:, None], [0.0, 1.0, 0.0], 0.0)
    guard = SideGuard(np.zeros((60, 3)), window_sides, mirrored)
    free = search_sequential(content, windows, lengths)
    guarded = search_sequential(content, windows, lengths, guard)
    assert all(p.style_start >= 60 for p in free)  # unguarded, the mirror matches best
    assert all(p.style_start < 60 for p in guarded)
    assert all(p.style_start < 60 for p in half_shifted(content, windows, guarded, guard))
    # a mirror whose sides agree with the content's is taken as before
    agreeing = SideGuard(np.zeros((60, 3)), np.zeros_like(window_sides), mirrored)
    assert search_sequential(content, windows, lengths, agreeing) == free


def test_side_guard_reads_each_window_of_a_real_library(dataset_clips) -> None:  # type: ignore[no-untyped-def]
    from elastyle.model.file import load_model
    from elastyle.steps.action import action_layout
    from elastyle.steps.library import prepare_style
    from elastyle.steps.track import side_guard
    from tests.conftest import clip_named

    model = load_model()
    raise_left = clip_named(dataset_clips, "dataset-2_raise-up-left-hand_feminine_005").read()[0]
    library = prepare_style(model, [raise_left])  # the clip and its mirror
    layout = action_layout(raise_left.skeleton)
    guard = side_guard(library.actions, library, 30, layout)
    assert guard is not None
    left, right = layout.arm_hands["left-arm"], layout.arm_hands["right-arm"]
    sides = library.actions[:, left] - library.actions[:, right]
    for window in (0, 17, library.clip_starts[1] - 30, library.clip_starts[1] + 5):
        np.testing.assert_allclose(
            guard.windows[window], sides[window : window + 30].mean(axis=0), atol=1e-12
        )
        assert guard.mirrored[window] == (window >= library.clip_starts[1])
    # the raised left hand: the original's windows have it higher than the right, the mirror's lower
    peak = int(np.argmax(guard.windows[: library.clip_starts[1] - 29, 1]))
    assert guard.windows[peak, 1] > 0.3 and guard.windows[library.clip_starts[1] + peak, 1] < -0.3
    # every window excluded for a query: the search falls back to the best of all
    spans = np.tile([0.0, 50.0, 0.0], (len(library.actions), 1))  # no window is anywhere near
    only_mirrored = guard._replace(content=spans, mirrored=np.ones_like(guard.mirrored))
    windows = library.windows(30, 0.1, 2.0)
    frames, start, length = windows.frames, [0.0], [30.0]  # the library's first window as the query
    excluded = only_mirrored.excluded(spans[:1])  # one query whose span's mean sides are those
    assert np.array_equal(
        windows.best(frames, start, length, excluded)[0], windows.best(frames, start, length)[0]
    )


def test_a_handicapped_window_is_taken_only_where_it_matches_better_by_its_handicap() -> None:
    """A clip and a copy of it handicapped by 0.03 (as a style's mirror is), the copy's window at frame 20
    changed: a query that is that window takes the clip's own where the clip's is within the handicap of
    it, the copy's where it is not; the similarity given back is the window's own, without the handicap."""
    rng = np.random.default_rng(1)
    clip = rng.standard_normal((40, 6))
    windows_of = {}
    for change in (0.1, 0.6):
        copy = clip.copy()
        copy[20:32] += change * rng.standard_normal((12, 6))
        library = np.concatenate([clip, copy])
        handicap = np.repeat([0.0, 0.03], 40)
        windows = StyleWindows(library, np.array([0, 40]), 12, handicap=handicap)
        query = copy[20:32]
        own = _brute_force_best(library, [20], query)[1]  # the clip's window at 20 against the copy's (1.0)
        index, score = windows.best(query, [0.0], [12.0])
        windows_of[change] = int(index[0]), own
        assert (
            abs(windows.similarity(index, score)[0] - _brute_force_best(library, [int(index[0])], query)[1])
            < 1e-5
        )
        assert (
            StyleWindows(library, np.array([0, 40]), 12).best(query, [0.0], [12.0])[0][0] == 60
        )  # no handicap
    assert windows_of[0.1][1] > 0.97 and windows_of[0.1][0] == 20  # within the handicap: the clip's own
    assert windows_of[0.6][1] < 0.97 and windows_of[0.6][0] == 60  # far better: the copy's
