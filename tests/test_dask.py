"""A batch on a real Dask cluster (a scheduler and two workers started here, no mock): byte-identical to
the local run, one error line for a bad clip, and --skip-existing resumes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from elastyle.io.dataset import ClipRef
from tests.conftest import THREE_CHANNEL_BVH, clip_named

pytest.importorskip("distributed", reason='Dask is an extra: pip install "elastyle[dask]"')

CONTENTS = ["walk_normal_005", "walk_normal_010", "run_normal_005", "walk-turn-left_normal_005",
            "wave-left-hand_normal_005", "raise-up-both-hands_normal_005"]  # fmt: skip


QUIET: dict[str, Any] = {
    "stdout": subprocess.DEVNULL,
    "stderr": subprocess.DEVNULL,
    "start_new_session": True,
}


def _start_worker(scheduler_file: Path) -> subprocess.Popen[bytes]:
    """A one-thread Dask worker process joining the scheduler of `scheduler_file`."""
    worker = [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(scheduler_file),
              "--nthreads", "1", "--no-dashboard", "--memory-limit", "0"]  # fmt: skip
    return subprocess.Popen(worker, **QUIET)


@contextmanager
def _cluster(folder: Path, workers: int = 2) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """A Dask scheduler and one-thread workers as separate processes: the address and the worker processes
    (a worker the caller adds to that list is stopped with the others)."""
    scheduler_file = folder / "scheduler.json"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    scheduler = subprocess.Popen([*dask, "--scheduler-file", str(scheduler_file), "--port", "0",
                                   "--dashboard-address", ":0"], **QUIET)  # fmt: skip
    worker_processes: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(300):
            if scheduler_file.exists() and scheduler_file.read_text().strip():
                break
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        worker_processes += [_start_worker(scheduler_file) for _ in range(workers)]
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(workers, timeout=60)
        yield address, worker_processes
    finally:
        processes = [scheduler, *worker_processes]
        for process in processes:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
        for process in processes:
            process.wait(timeout=30)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A scheduler and two workers for the module; yields the scheduler address."""
    with _cluster(tmp_path_factory.mktemp("dask")) as (address, _):
        yield address


def _transfer(contents: list[str], style: str, output: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "transfer", *contents, "--style", style, "-o", f"{output}/", *extra],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip


@pytest.mark.slow
def test_a_batch_on_a_dask_cluster_matches_the_local_run(
    cluster: str, tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    contents = [clip_named(dataset_clips, f"dataset-2_{stem}").name for stem in CONTENTS]
    style = clip_named(dataset_clips, "dataset-2_walk_elderly_010").name
    local, remote = tmp_path / "local", tmp_path / "dask"
    assert _transfer(contents, style, local).returncode == 0
    result = _transfer(contents, style, remote, "--scheduler", cluster)
    assert result.returncode == 0, result.stderr
    names = sorted(p.name for p in local.iterdir())
    assert len(names) == 6 and names == sorted(p.name for p in remote.iterdir())
    for name in names:
        assert (remote / name).read_bytes() == (local / name).read_bytes(), name
    # a bad clip: one error line naming it, the others written, exit 1; then --skip-existing resumes
    bad = tmp_path / "bad.bvh"
    bad.write_text(THREE_CHANNEL_BVH)
    mixed = tmp_path / "mixed"
    result = _transfer([contents[0], str(bad)], style, mixed, "--scheduler", cluster)
    assert result.returncode == 1
    errors = [line for line in result.stderr.splitlines() if line.startswith("elastyle: error:")]
    assert len(errors) == 1 and "bad.bvh" in errors[0] and "skeleton differs" in errors[0]
    assert sorted(p.name for p in mixed.iterdir()) == [Path(contents[0]).stem + ".bvh"]
    before = (mixed / (Path(contents[0]).stem + ".bvh")).stat().st_mtime_ns
    result = _transfer(contents[:2], style, mixed, "--scheduler", cluster, "--skip-existing")
    assert result.returncode == 0, result.stderr
    assert "1 of 2 outputs exist and are skipped" in result.stderr
    assert (mixed / (Path(contents[0]).stem + ".bvh")).stat().st_mtime_ns == before
    assert (mixed / (Path(contents[1]).stem + ".bvh")).read_bytes() == (
        local / (Path(contents[1]).stem + ".bvh")
    ).read_bytes()


def test_an_unreachable_scheduler_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from elastyle.cli import batch
    from elastyle.cli.batch import run_on_dask

    monkeypatch.setattr(batch, "CONNECT_TIMEOUT_S", 2)
    with pytest.raises(Exception, match="cannot reach the Dask scheduler"):
        run_on_dask(None, ["x"], [tmp_path / "x.bvh"], "tcp://127.0.0.1:9")  # type: ignore[arg-type]


@pytest.mark.slow
@pytest.mark.parametrize("workers", [2, 1], ids=["one-of-two-dies", "the-only-worker-dies-another-joins"])
def test_a_worker_that_dies_mid_batch_does_not_lose_clips(
    tmp_path: Path, dataset_clips: list[ClipRef], workers: int
) -> None:
    """With two workers the other finishes the batch; with one, the scattered job dies with it (its tasks are
    cancelled by the scheduler) and the batch submits them again, with the job scattered anew, to a worker
    that joins later."""
    walks = [c.name for c in dataset_clips if c.stem.startswith("dataset-2_walk_normal_")][:16]
    style = clip_named(dataset_clips, "dataset-2_walk_elderly_010").name
    local, remote = tmp_path / "local", tmp_path / "dask"
    assert _transfer(walks, style, local).returncode == 0
    with _cluster(tmp_path, workers=workers) as (address, processes):
        command = [sys.executable, "-m", "elastyle.cli", "transfer", *walks, "--style", style, "-o", f"{remote}/",
                   "--scheduler", address]  # fmt: skip
        batch = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        for _ in range(600):  # the first output written: the workers are busy
            if remote.exists() and any(remote.glob("*.bvh")):
                break
            time.sleep(0.05)
        os.killpg(processes[0].pid, signal.SIGKILL)
        written_at_kill = len(list(remote.glob("*.bvh")))
        if workers == 1:
            processes.append(_start_worker(tmp_path / "scheduler.json"))
        _, stderr = batch.communicate(timeout=300)
    assert written_at_kill < len(walks)  # the worker died with the batch under way
    assert batch.returncode == 0, stderr
    assert sorted(p.name for p in remote.glob("*.bvh")) == sorted(p.name for p in local.glob("*.bvh"))
    for path in local.glob("*.bvh"):
        assert (remote / path.name).read_bytes() == path.read_bytes(), path.name
