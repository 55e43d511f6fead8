"""Speed against the machine's own limit, on one core (issue: speed). Prints ratios measured in one run.

    python benchmarks/speed.py [--quick] [--model M] [--option NAME=VALUE ...]

Cases: 10 s content x 10 s style; 60 s content x a 10-minute style library (dataset walks), each with
the report's 4-frame stretch step (2 frames at 30 fps) and with every frame. For each: transfer time
(no file I/O; the style library encoded beforehand), search time, a plain float32 matmul of every
query (its compared frames) against every window in the same run, the arithmetic a frame-by-frame
comparison does, and their ratio (below 1: the search multiplies only the content frames its queries
read, so it does less), the GFLOP/s that comparison would need, and peak memory. Then BVH
read/write throughput, the library cache's speed-up, and the CLI's wall time against Python's start-up
with numpy and scipy.
"""

from __future__ import annotations

import os

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[variable] = "1"

import argparse  # noqa: E402
import logging  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from elastyle.core.motion import Motion  # noqa: E402
from elastyle.io.bvh_read import parse_bvh  # noqa: E402
from elastyle.io.bvh_write import bvh_text  # noqa: E402
from elastyle.io.dataset import default_data_path, find_clips  # noqa: E402
from elastyle.model.file import load_model  # noqa: E402
from elastyle.pipeline import transfer  # noqa: E402
from elastyle.steps import search as elastic  # noqa: E402
from elastyle.steps.config import TransferConfig  # noqa: E402
from elastyle.steps.library import prepare_style  # noqa: E402

# (stretch step, label, placement): the sequential search has one library pass per patch (each patch
# starts where the previous one's matched stretch ended); the fixed placement searches all in one batch
CASES = (
    (4 / 60, "report step", "sequential"),
    (0.0, "1-frame", "sequential"),
    (4 / 60, "fixed, report step", "fixed"),
)


def best_of(function, repeats: int = 5) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return min(times)


def interleaved_best(first, second, repeats: int) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """Best times of two functions run alternately, so a burst of load on the shared machine hits both."""
    times: tuple[list[float], list[float]] = ([], [])
    for _ in range(repeats):
        for function, kept in zip((first, second), times):
            started = time.perf_counter()
            function()
            kept.append(time.perf_counter() - started)
    return min(times[0]), min(times[1])


def concatenate(motions: list[Motion], seconds: float) -> Motion:
    """Clips end to end up to `seconds` (a long content clip)."""
    frames = int(seconds * motions[0].fps)
    rotations = np.concatenate([m.rotations for m in motions])[:frames]
    translations = np.concatenate([m.translations for m in motions])[:frames]
    return Motion(motions[0].skeleton, rotations, translations, motions[0].fps)


class SearchTimer:
    """Wraps StyleWindows.best to add up search time and the shapes it multiplied."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.shapes: list[tuple[int, int, int]] = []
        self.original = elastic.StyleWindows.best

    def __enter__(self) -> SearchTimer:
        timer = self

        def timed(windows, content, starts, lengths, excluded=None):  # type: ignore[no-untyped-def]
            started = time.perf_counter()
            result = timer.original(windows, content, starts, lengths, excluded)
            timer.seconds += time.perf_counter() - started
            # the queries' shape: each span read at the compared frames, against every window
            queries = len(np.atleast_1d(starts))
            timer.shapes.append((queries, windows.compared_frames * content.shape[1], windows.num_windows))
            return result

        elastic.StyleWindows.best = timed  # type: ignore[method-assign]
        return self

    def __exit__(self, *args: object) -> None:
        elastic.StyleWindows.best = self.original  # type: ignore[method-assign]


def plain_matmul_s(rows: int, inner: int, columns: int) -> float:
    a = np.random.default_rng(0).standard_normal((rows, inner), dtype=np.float32)
    b = np.random.default_rng(1).standard_normal((columns, inner), dtype=np.float32)
    return best_of(lambda: a @ b.T, 5)


def run_case(name: str, model, content: Motion, style_motions: list[Motion], step_s: float,  # type: ignore[no-untyped-def]
             placement: str = "sequential") -> None:  # fmt: skip
    config = TransferConfig.of(OPTIONS, stretch_step_s=step_s, placement=placement)
    library = prepare_style(model, style_motions)
    transfer(content, library, config, model=model)  # warm the window cache
    total_s, search_s = np.inf, np.inf
    for _ in range(3):  # best of three, for the whole transfer and for its search
        with SearchTimer() as timer:
            started = time.perf_counter()
            transfer(content, library, config, model=model)
            total_s = min(total_s, time.perf_counter() - started)
        search_s = min(search_s, timer.seconds)
    rows = sum(s[0] for s in timer.shapes)
    inner, columns = timer.shapes[0][1], timer.shapes[0][2]
    matmul_s = plain_matmul_s(rows, inner, columns)
    flops = 2.0 * rows * inner * columns
    tracemalloc.start()
    transfer(content, library, config, model=model)
    peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    print(
        f"{name:<34} transfer {1000 * total_s:8.1f} ms | search {1000 * search_s:7.1f} ms, "
        f"matmul {rows}x{inner}x{columns} {1000 * matmul_s:7.1f} ms, ratio {search_s / matmul_s:5.2f}, "
        f"{flops / search_s / 1e9:6.1f} GFLOP/s | peak {peak_mb:6.0f} MB"
    )


OPTIONS = TransferConfig()


def config_option(text: str) -> tuple[str, object]:
    """NAME=VALUE as a TransferConfig field and its value (numbers as floats, true/false as booleans)."""
    name, _, value = text.partition("=")
    if value in ("true", "false"):
        return name, value == "true"
    try:
        return name, float(value)
    except ValueError:
        return name, value


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("--quick", action="store_true", help="small version: 10 s cases only, fewer files")
    parser.add_argument("--no-io", action="store_true", help="skip the BVH throughput over the dataset")
    parser.add_argument("--model", help="model file (default: the shipped one)")
    parser.add_argument(
        "--option", action="append", default=[], metavar="NAME=VALUE",
        help="a TransferConfig field for every transfer timed, e.g. decode=plain",
    )  # fmt: skip
    args = parser.parse_args()
    # the cases' contents are dataset walks end to end: their seams trip the out-of-depth warning, which
    # would otherwise print on every timed transfer
    logging.getLogger("elastyle").setLevel(logging.ERROR)
    global OPTIONS
    OPTIONS = TransferConfig.of(None, **dict(config_option(text) for text in args.option))
    model = load_model(args.model)
    walks = [c.read()[0] for c in find_clips([args.data], pattern="*_walk_*")[:: 2 if args.quick else 1]]
    neutral = [m for m in walks][:20]
    content_10 = concatenate(neutral, 10)
    style_10 = concatenate(walks[40:50], 10)
    gemm_s = plain_matmul_s(1024, 1024, 1024)
    print(
        f"one core; 1024^3 float32 matmul {1000 * gemm_s:.1f} ms ({2 * 1024**3 / gemm_s / 1e9:.0f} GFLOP/s)"
    )
    for step_s, label, placement in CASES:
        run_case(f"10 s x 10 s, {label}", model, content_10, [style_10], step_s, placement)
    config = OPTIONS
    library = prepare_style(model, [style_10])
    square = np.random.default_rng(0).standard_normal((1024, 1024), dtype=np.float32)
    gemm_s, whole = interleaved_best(
        lambda: square @ square, lambda: transfer(content_10, library, config, model=model), 10
    )
    print(f"10 s x 10 s transfer {1000 * whole:.1f} ms / half a 1024^3 matmul (the matmul {1000 * gemm_s:.1f} ms "
          f"in these alternate runs): {whole / (gemm_s / 2):.2f} (target <= 1)")  # fmt: skip
    gemm_s, bare = interleaved_best(
        lambda: square @ square,
        lambda: transfer(content_10, library, TransferConfig.of(config, cleanup=False), model=model),
        10,
    )
    print(f"  without the foot clean-up: {bare / (gemm_s / 2):.2f} ({1000 * bare:.1f} ms)")
    if not args.quick:
        long_content = concatenate(walks[:60], 60)
        library_clips = walks[60:]
        total = 0
        chosen = []
        for motion in library_clips:
            chosen.append(motion)
            total += motion.num_frames
            if total >= 600 * motion.fps:
                break
        for step_s, label, placement in CASES:
            run_case(f"60 s x 10 min library, {label}", model, long_content, chosen, step_s, placement)
        encode_s = best_of(lambda: prepare_style(model, chosen), 1)
        cached = prepare_style(model, chosen)
        with_cache = best_of(lambda: transfer(content_10, cached, config, model=model), 3)
        print(
            f"10 s content x 10 min library: encoding the library {1000 * encode_s:.0f} ms, transfer with it "
            f"cached {1000 * with_cache:.0f} ms (speed-up {(encode_s + with_cache) / with_cache:.1f}x)"
        )
    if not args.no_io:
        bvh_throughput(args.data, args.quick)
    cli_wall_time(content_10, style_10)
    batch_throughput(args.data, 20 if args.quick else 100)
    return 0


def batch_throughput(data: str, count: int) -> None:
    """`elastyle transfer` of `count` dataset walks against one style clip into a folder: clips per second
    on one process and on every core (the CLI's default), from the command's start to its end."""
    walks = [c.name for c in find_clips([data], pattern="*_walk_*")]
    contents = walks[:: max(1, len(walks) // count)][:count]
    style = [c.name for c in find_clips([data], pattern="*_walk_exhausted_*")][0]
    for jobs in (1, os.cpu_count() or 1):
        with tempfile.TemporaryDirectory() as folder:
            command = [sys.executable, "-m", "elastyle.cli", "transfer", *contents, "--style", style,
                       "-o", f"{folder}/", "--jobs", str(jobs), "--no-cache"]  # fmt: skip
            started = time.perf_counter()
            subprocess.run(
                command, check=True, capture_output=True, env=dict(os.environ, OPENBLAS_NUM_THREADS="1")
            )
            seconds = time.perf_counter() - started
            frames = sum(c.read()[0].num_frames for c in find_clips([f"{folder}/*.bvh"]))
        print(f"batch: {len(contents)} dataset walks on {jobs} process(es): {seconds:.1f} s, "
              f"{len(contents) / seconds:.1f} clips/s, {frames / seconds:,.0f} output frames/s")  # fmt: skip


def bvh_throughput(data: str, quick: bool) -> None:
    """Read and write every dataset clip (every 20th with --quick); read-write-read FK error."""
    clips = find_clips([data])[:: 20 if quick else 1]
    raw = [(c.name, _raw_bytes(c)) for c in clips]
    started = time.perf_counter()
    parsed = [parse_bvh(data, name) for name, data in raw]
    read_s = time.perf_counter() - started
    frames = sum(m.num_frames for m, _ in parsed)
    started = time.perf_counter()
    texts = [bvh_text(m, layout) for m, layout in parsed]
    write_s = time.perf_counter() - started
    worst = max(
        float(np.abs(parse_bvh(t.encode(), "again")[0].positions() - m.positions()).max())
        for t, (m, _) in zip(texts, parsed)
    )
    print(
        f"BVH: {len(raw)} files, {frames} frames: read {frames / read_s:,.0f} frames/s, write {frames / write_s:,.0f} "
        f"frames/s; read-write-read FK error max {worst:.2e} units"
    )


def cli_wall_time(content_10: Motion, style_10: Motion) -> None:
    """The CLI's wall time for 10 s x 10 s against Python's start-up with numpy and scipy.

    Measured twice: as this environment runs it, and with Python's bytecode cache (in a temporary
    PYTHONPYCACHEPREFIX) warm, as numpy's and scipy's own modules are: with PYTHONDONTWRITEBYTECODE set,
    as on this project's machines, every run compiles elastyle's modules afresh.
    """
    with tempfile.TemporaryDirectory() as folder:
        content_path, style_path = Path(folder) / "c.bvh", Path(folder) / "s.bvh"
        content_path.write_text(bvh_text(content_10))
        style_path.write_text(bvh_text(style_10))
        command = [sys.executable, "-m", "elastyle.cli", "transfer", str(content_path), "--style", str(style_path),
                   "-o", str(Path(folder) / "o.bvh"), "--force"]  # fmt: skip
        baseline = [sys.executable, "-c", "import numpy, scipy"]
        cached = dict(os.environ, PYTHONPYCACHEPREFIX=str(Path(folder) / "pycache"))
        cached.pop("PYTHONDONTWRITEBYTECODE", None)
        for label, env in (("this environment", dict(os.environ)), ("bytecode cached", cached)):
            subprocess.run(command, check=True, capture_output=True, env=env)  # warm the caches
            base, cli = interleaved_best(
                lambda: subprocess.run(baseline, check=True, env=env),  # noqa: B023
                lambda: subprocess.run(command, check=True, capture_output=True, env=env),  # noqa: B023
                15,
            )
            print(f"CLI 10 s x 10 s ({label}): {1000 * cli:.0f} ms; python -c 'import numpy, scipy': "
                  f"{1000 * base:.0f} ms; ratio {cli / base:.2f} (target <= 2)")  # fmt: skip


def _raw_bytes(clip) -> bytes:  # type: ignore[no-untyped-def]
    if clip.archive is None:
        return Path(clip.name).read_bytes()
    from elastyle.io.dataset import _open_zip

    return _open_zip(clip.archive, os.getpid()).read(clip.member)


if __name__ == "__main__":
    sys.exit(main())
