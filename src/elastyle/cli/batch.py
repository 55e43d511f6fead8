"""Running a transfer over many content clips: one clip (`transfer_one`), the cores of this computer
(`run_local`), or an existing Dask cluster (`run_on_dask`, `elastyle[dask]`). The style library is encoded
once and shared: inherited by forked local workers, scattered once to every Dask worker. A task reads and
transfers its clip and returns the output file's bytes; the command writes each output atomically, once,
under the same `--force` and never-overwrite-an-input rules (so a task run twice, after its worker died,
writes nothing twice, and on a cluster only the command needs to see the output folder). A failed clip is
one error line and the others still finish."""

from __future__ import annotations

import json
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from elastyle.core.threads import stop_workers, usable_cores
from elastyle.errors import ElastyleError, OutputError, UsageError

if TYPE_CHECKING:
    from elastyle.model.file import StyleModel
    from elastyle.steps.config import TransferConfig
    from elastyle.steps.library import StyleLibrary
    from elastyle.steps.schedule import Schedule

log = logging.getLogger("elastyle")
CONNECT_TIMEOUT_S = 20  # how long to wait for a Dask scheduler to answer
DASK_RESUBMITS = 5  # a clip whose Dask task is cancelled this often is given up (one error line)


Output = tuple[bytes, str | None]  # an output file's bytes and its explain record (JSON text), if asked


class Job(NamedTuple):
    """Everything a content clip's transfer needs besides the clip: shared by the batch's workers."""

    style: StyleLibrary
    model: StyleModel
    config: TransferConfig
    second: StyleLibrary | None
    second_weight: Schedule
    part_styles: dict[str, StyleLibrary]  # body part names -> the library whose manner they take
    units: str | None  # the clips' length unit as stated (`core.body.UNITS`), None: guessed
    up: str  # how the content clips' up axis is read (`io.dataset.ClipRef.read`): workers elsewhere know it too
    force: bool
    explain: str | None  # a file for one content clip, or a folder (DIR/) for a record per output
    inputs: tuple[str, ...]  # what the command reads: never written
    model_file: str | None  # as given (--model), None for the shipped model: recorded in the explain file
    working_folder: (
        str  # where the command runs: the explain file's relative paths (clips as given) start there
    )


def transfer_one(job: Job, content_spec: str, target: Path) -> None:
    """Read one content clip, transfer it and write its output (and explain file) atomically."""
    _write(job, target, *_transfer(job, content_spec, target))


def names_folder(path: str) -> bool:
    """Whether an -o or --explain path names a folder (DIR/, or one that exists): a file per output in it."""
    return path.endswith(("/", "\\")) or Path(path).is_dir()


def explain_path(explain: str, target: Path) -> Path:
    """Where the explain record of the output `target` goes: the file given, or in a folder given the
    output's name with .json."""
    return Path(explain) / (target.stem + ".json") if names_folder(explain) else Path(explain)


def _transfer(job: Job, content_spec: str, target: Path) -> Output:
    """One content clip read and transferred: the bytes of its output file and its explain record's text
    (None where none is asked for)."""
    from elastyle.core.body import in_units
    from elastyle.io.clip_write import clip_bytes
    from elastyle.io.dataset import read_clip
    from elastyle.pipeline import transfer

    motion, layout = read_clip(content_spec, job.up)
    motion = in_units(motion, job.units)
    result = transfer(
        motion, job.style, job.config, model=job.model, second_style=job.second,
        second_weight=job.second_weight, part_styles=job.part_styles, content_name=content_spec,
    )  # fmt: skip
    log.info("transferred %s (%d frames, %.2f s; content %.2f s)", content_spec, result.motion.num_frames,
             result.motion.duration_s, motion.duration_s)  # fmt: skip
    if not job.explain:
        return clip_bytes(target, result.motion, layout), None
    explain = result.explain
    if layout.up != "y":  # said when read (once per process), recorded for every clip
        turned = (
            f"note: {content_spec}: read with +{layout.up.upper()} up, turned to +Y up, and written back so"
        )
        explain = dict(explain, notes=[turned, *explain["notes"]])
    # the output's absolute path: `view` tells whether the clips it shows include it
    output_path = os.path.abspath(target)
    explain = dict(
        explain, content=content_spec, output=output_path, model=job.model_file or "shipped",
        working_folder=job.working_folder,
    )  # fmt: skip
    return clip_bytes(target, result.motion, layout), json.dumps(explain, indent=1)


def _write(job: Job, target: Path, output: bytes, explain: str | None) -> None:
    """An output file, and its explain record where one is asked for, atomically: both or neither."""
    from elastyle.io.files import write_files_atomic

    files = [(target, output, job.inputs)]
    made = None  # the records' folder, where this write makes it
    if job.explain and explain is not None:
        if names_folder(job.explain) and not Path(job.explain).is_dir():
            made = Path(job.explain)  # made with the first record (its parent was checked beforehand)
            made.mkdir(exist_ok=True)
        record = explain_path(job.explain, target)
        files.append((record, explain.encode("utf-8"), (*job.inputs, str(target))))
    try:
        write_files_atomic(files, force=job.force)  # both or neither
    except OutputError:
        if made is not None and not any(made.iterdir()):
            made.rmdir()
        raise
    log.info("wrote %s", target)
    if len(files) > 1:
        log.info("wrote %s (the explain record)", files[1][0])


def transfer_task(job: Job, content_spec: str, target: Path) -> Output | str:
    """One batch item wherever it runs: the output file's bytes and its explain record, or the one-line
    error."""
    try:
        return _transfer(job, content_spec, target)
    except ElastyleError as error:
        return str(error)


_WORKER_JOB: list[Job] = []


PARENT_POLL_S = 1.0  # how often a batch worker checks that the command that started it still runs


def _worker_start(job: Job) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the command's handler: a worker ended ends at once
    _WORKER_JOB[:] = [job]
    logging.getLogger("elastyle").setLevel(logging.WARNING)
    parent = os.getppid()

    def watch() -> None:  # a worker whose command was killed (not Ctrl-C: a kill of it alone) ends too
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _worker_transfer(task: tuple[str, Path]) -> Output | str:
    return transfer_task(_WORKER_JOB[0], *task)


@contextmanager
def output_folder(targets: list[Path]) -> Iterator[None]:
    """The outputs' folder, made once the command has checked everything, and removed again where the
    command leaves it empty (every clip failed): a refused or failed command leaves none."""
    folder = targets[0].parent if targets else None
    made = folder is not None and not folder.exists()
    if folder is not None:
        folder.mkdir(exist_ok=True)
    try:
        yield
    finally:
        if made and folder is not None and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()


def run_local(job: Job, contents: list[str], targets: list[Path], jobs: int | None) -> int:
    """Many content clips on `jobs` processes of this computer (every core by default)."""
    import multiprocessing
    import os
    from concurrent.futures import ProcessPoolExecutor, as_completed

    workers = max(1, min(len(contents), jobs or usable_cores()))
    context = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
    with (
        output_folder(targets),
        ProcessPoolExecutor(workers, mp_context=context, initializer=_worker_start, initargs=(job,)) as pool,
    ):
        futures = {pool.submit(_worker_transfer, task): task for task in zip(contents, targets)}
        try:
            return _write_all(job, as_completed(futures), futures, lambda future: future.result())
        except KeyboardInterrupt:  # the clips not begun are dropped and those under way end now (workers
            stop_workers(pool)  # write nothing: the outputs are this process's to write)
            raise


def require_dask() -> None:
    """A `UsageError` where Dask's scheduler client is not installed."""
    import importlib.util

    if importlib.util.find_spec("distributed") is None:
        raise UsageError('--scheduler needs Dask: pip install "elastyle[dask]"')


def run_on_dask(job: Job, contents: list[str], targets: list[Path], address: str) -> int:
    """Many content clips as tasks of the Dask cluster at `address` (the job scattered to every worker
    once; a task whose worker dies is run again elsewhere, and a task cancelled because the scattered job
    went with a dead worker is submitted again with the job scattered anew, up to `DASK_RESUBMITS` times)."""
    require_dask()
    from concurrent.futures import CancelledError

    from distributed import Client, as_completed

    try:
        client = Client(address, timeout=f"{CONNECT_TIMEOUT_S}s")
    except ValueError as error:  # no port, an unknown protocol
        raise UsageError(
            f"--scheduler {address}: not a scheduler's address ({error}); give tcp://HOST:PORT"
        ) from None
    except (OSError, TimeoutError) as error:
        raise ElastyleError(f"{address}: cannot reach the Dask scheduler ({error})") from None
    with client, output_folder(targets):

        def scatter() -> Any:
            """One future for the whole job (a tuple given to scatter is scattered field by field)."""
            return client.scatter([job], broadcast=True, hash=False)[0]

        shared = [scatter()]
        resubmits: dict[tuple[str, Path], int] = {}  # per clip: how often it was submitted again

        def submit(task: tuple[str, Path]) -> Any:
            return client.submit(transfer_task, shared[0], *task, pure=False, retries=2)

        futures = {submit(task): task for task in zip(contents, targets)}
        done = as_completed(futures)

        def result(future: Any) -> Output | str | None:
            try:
                return future.result()  # type: ignore[no-any-return]
            except CancelledError:
                task = futures[future]
                if resubmits.get(task, 0) >= DASK_RESUBMITS:
                    return f"{task[0]}: cancelled by the Dask scheduler {DASK_RESUBMITS + 1} times; not transferred"
                resubmits[task] = resubmits.get(task, 0) + 1
                log.info("a task was cancelled (its worker or the job was lost): submitted again")
                if shared[0].status != "finished":  # the job went with its workers: scattered anew
                    shared[0] = scatter()
                again = submit(task)
                futures[again] = task
                done.add(again)
                return None

        return _write_all(job, done, futures, result)


def _write_all(
    job: Job,
    done: Iterable[Any],
    tasks: dict[Any, tuple[str, Path]],
    result: Callable[[Any], Output | str | None],
) -> int:
    """Each finished task's output written (a progress bar on a terminal), one error line per failed clip;
    the exit code. `result` gives a task's output file bytes and explain record, its one-line error, or
    None where the task was submitted again (it comes back through `done`)."""
    from tqdm import tqdm

    failures, total = 0, len(tasks)
    with tqdm(total=total, unit="clip", desc="transfer", disable=None, dynamic_ncols=True) as bar:
        for future in done:
            content, target = tasks[future]
            output = result(future)
            if output is None:
                continue
            try:
                if isinstance(output, str):
                    raise ElastyleError(output)
                _write(job, target, *output)
            except ElastyleError as error:
                failures += 1
                bar.write(f"elastyle: error: {error}", file=sys.stderr)
            bar.update()
    log.info("%d of %d clips transferred", total - failures, total)
    return 1 if failures else 0
