"""Batch throughput: clips per second for 1, 2 and 4 local processes and for a local Dask cluster of 2
workers (started here), on dataset-2 clips against one style; Dask's overhead against the local pool as a
ratio, and the memory of one Dask worker. Whole commands are timed (start-up, style encoding, writing).

    python benchmarks/batch.py [--clips 100]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from elastyle.io.dataset import default_data_path, find_clips


def _run(contents: list[str], style: str, output: Path, *extra: str) -> float:
    """Seconds for one `elastyle transfer` over the clips (outputs overwritten)."""
    started = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "transfer", *contents, "--style", style, "-o", f"{output}/",
         "--force", *extra],
        check=True, capture_output=True,
    )  # fmt: skip
    return time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("--clips", type=int, default=100)
    args = parser.parse_args()
    if not args.data:
        print("no dataset: set ELASTYLE_DATA", file=sys.stderr)
        return 1
    clips = find_clips([args.data], pattern="dataset-2_*")
    contents = [c.name for c in clips[:: max(1, len(clips) // args.clips)][: args.clips]]
    style = next(c.name for c in clips if c.stem == "dataset-2_walk_elderly_010")
    figures = {}
    with tempfile.TemporaryDirectory() as folder:
        output = Path(folder) / "out"
        _run(contents[:2], style, output)  # warm the style cache and the file system
        for jobs in (1, 2, 4):
            seconds = _run(contents, style, output, "--jobs", str(jobs))
            figures[f"local, {jobs} process(es)"] = len(contents) / seconds
        from distributed import Client, LocalCluster

        with LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster:
            with Client(cluster) as client:
                _run(contents[:2], style, output, "--scheduler", cluster.scheduler_address)
                seconds = _run(contents, style, output, "--scheduler", cluster.scheduler_address)
                figures["Dask, 2 local workers"] = len(contents) / seconds
                memory = client.run(lambda: __import__("psutil").Process().memory_info().rss)
    for name, rate in figures.items():
        print(f"{name:<24} {rate:6.1f} clips/s")
    ratio = figures["Dask, 2 local workers"] / figures["local, 2 process(es)"]
    print(f"Dask / local pool on the same 2 processes: {ratio:.2f} (clips: {len(contents)})")
    print(f"memory of one Dask worker after the batch: {max(memory.values()) / 2**20:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
