"""Safe input and output: only bounded regular files are read; never a half-written file, never an input
overwritten, never an overwrite the user did not ask for, and of two writers racing to create the same
new file exactly one wins."""

from __future__ import annotations

import logging
import os
import shutil
import stat
import tempfile
from collections.abc import Sequence
from pathlib import Path

from elastyle.errors import OutputError

log = logging.getLogger(__name__)

MAX_INPUT_VARIABLE = "ELASTYLE_MAX_INPUT_MB"
DEFAULT_MAX_INPUT_MB = 512.0  # about an hour of 120 fps capture of a 60-joint skeleton


_WARNED: set[tuple[str, str]] = set()  # (variable, value) pairs already warned about in this process


def megabytes_from_environment(variable: str, default_mb: float) -> int:
    """A size limit in bytes from an environment variable in megabytes (the default when unset; a warning
    naming it, once per process, where it is not a number of megabytes, 0 or more)."""
    text = os.environ.get(variable, "")
    try:
        megabytes = float(text) if text else default_mb
    except ValueError:
        megabytes = float("nan")
    if megabytes >= 0 and megabytes != float("inf"):
        return int(megabytes * 2**20)
    if (variable, text) not in _WARNED:  # read once per file: said once
        _WARNED.add((variable, text))
        log.warning(
            "warning: %s=%s is not a number of megabytes (0 or more): %g MB is used",
            variable,
            text,
            default_mb,
        )
    return int(default_mb * 2**20)


def max_input_bytes() -> int:
    """The largest input elastyle reads (bytes): `ELASTYLE_MAX_INPUT_MB`, else 512 MB."""
    return megabytes_from_environment(MAX_INPUT_VARIABLE, DEFAULT_MAX_INPUT_MB)


def input_problem(path: str | os.PathLike[str], size: int | None = None) -> str | None:
    """Why a file must not be read (missing, a folder, a pipe or device, too large), or None.

    `size`: the byte count when it is known without a stat (a zip member)."""
    if size is None:
        try:
            info = os.stat(path)
        except FileNotFoundError:
            return "no such file"
        except OSError as error:
            return f"cannot read: {error.strerror or error}"
        if stat.S_ISDIR(info.st_mode):
            return "is a directory, not a file"
        if not stat.S_ISREG(info.st_mode):
            return "not a regular file (a pipe, socket or device): give a file"
        size = info.st_size
    limit = max_input_bytes()
    if size > limit:
        return (
            f"{size / 2**20:.1f} MB, above the {limit / 2**20:.1f} MB limit for an input "
            f"(set {MAX_INPUT_VARIABLE} to raise it)"
        )
    return None


def on_disk(spec: str | os.PathLike[str]) -> Path | None:
    """The file on disk behind an input: the path itself, or the archive of `archive.zip/member`."""
    path = Path(spec)
    for candidate in (path, *path.parents):
        if candidate.is_file():
            return candidate
        if candidate.exists():
            return None
    return None


def check_output_path(
    path: str | os.PathLike[str], force: bool = False, inputs: tuple[str, ...] = (), probe: bool = True
) -> Path:
    """Validate an output path before any work is done; returns it as a `Path`.

    An output may never be one of `inputs` (files, or paths inside a zip archive), with or without force.
    probe: also check that its folder takes a new file (`check_writable`)."""
    if str(path) == "":
        raise OutputError("an empty output name; give a file name")
    target = Path(path)
    if not target.parent.exists():
        raise OutputError(f"{target}: output folder {target.parent} does not exist")
    if target.is_dir():
        raise OutputError(f"{target}: is a directory; give a file name")
    for source in inputs:
        if _same_file(target, source):
            raise OutputError(
                f"{target}: would overwrite {source}, which this command reads or writes; choose another name"
            )
    if target.exists() and not force:
        raise OutputError(f"{target}: already exists (--force, or force=True in Python, overwrites it)")
    if probe:
        check_writable(target)
    return target


def check_writable(target: Path) -> None:
    """An `OutputError` now, before any work, when the target's folder takes no new file (read-only, not a
    folder, a virtual file system): found by opening an anonymous temporary file there, which leaves none."""
    try:
        with tempfile.TemporaryFile(dir=target.parent):
            pass
    except OSError as error:
        raise OutputError(f"{target}: cannot write in {target.parent}: {error.strerror or error}") from None


def _same_file(target: Path, source: str) -> bool:
    """Whether `target` is the file behind `source` (by resolved path, or by inode when both exist)."""
    if os.path.realpath(target) == os.path.realpath(source):
        return True
    behind = on_disk(source)
    if behind is None:
        return False
    if os.path.realpath(target) == os.path.realpath(behind):
        return True
    try:
        return target.exists() and os.path.samefile(target, behind)
    except OSError:
        return False


def write_bytes_atomic(
    path: str | os.PathLike[str], data: bytes, force: bool = False, inputs: tuple[str, ...] = ()
) -> None:
    """Write to a temporary file beside `path`, then put it in place only once complete: renamed over the
    target with `force`, else linked to a name that must not exist yet (one of two racing writers wins)."""
    write_files_atomic([(path, data, inputs)], force=force)


def write_files_atomic(
    files: Sequence[tuple[str | os.PathLike[str], bytes, tuple[str, ...]]], force: bool = False
) -> None:
    """Files that go together (an output and its explain record), each (path, data, inputs) as
    `write_bytes_atomic` writes one: every file is first written whole to a temporary beside its target,
    and only then are they put in place, in order. A failure (a full disk, a name taken meanwhile) leaves
    none of them: the temporaries are removed, a file put in place under a name that was free is removed
    again, and one put over an existing file (`force`) is put back as it was."""
    if not files:
        return
    targets = [check_output_path(path, force=force, inputs=inputs, probe=False) for path, _, inputs in files]
    seen: set[str] = set()
    for target in targets:
        if os.path.realpath(target) in seen:
            raise OutputError(f"{target}: named twice among the files written together; give each its own")
        seen.add(os.path.realpath(target))
    temporaries: list[Path] = []
    placed: list[tuple[Path, Path | None]] = []  # each target put in place, and the copy of what it replaced
    current = targets[0]
    try:
        for current, (_, data, _) in zip(targets, files):
            _remove_stale_temporaries(current)
            temporary, handle = _create_temporary(current)
            temporaries.append(temporary)
            with os.fdopen(handle, "wb") as stream:
                stream.write(data)
                stream.flush()
                os.fsync(stream.fileno())
        for at, (current, temporary) in enumerate(zip(targets, temporaries)):
            if force and current.exists():
                # kept until the files after it are in place too (none: nothing is left to fail)
                kept = _kept_copy(current) if at < len(targets) - 1 else None
                try:
                    os.replace(temporary, current)
                except BaseException:
                    if kept is not None:
                        kept.unlink(missing_ok=True)
                    raise
                placed.append((current, kept))
            else:
                _link_new(temporary, current)
                placed.append((current, None))
    except FileExistsError:
        _undo(temporaries, placed)
        raise OutputError(
            f"{current}: already exists (--force, or force=True in Python, overwrites it)"
        ) from None
    except OSError as error:
        _undo(temporaries, placed)
        raise OutputError(f"{current}: write failed: {error.strerror or error}") from None
    except BaseException:
        _undo(temporaries, placed)
        raise
    for _, kept in placed:
        if kept is not None:
            kept.unlink(missing_ok=True)


def _kept_copy(target: Path) -> Path:
    """A copy of an existing file beside it (a hard link where the file system has them), under a temporary
    name, for `_undo` to put back."""
    kept = target.with_name(f"{_temporary_prefix(target)}{os.getpid()}.{os.urandom(4).hex()}.tmp")
    try:
        os.link(target, kept)
    except FileExistsError:
        raise
    except OSError:
        shutil.copy2(target, kept)
    return kept


def _undo(temporaries: list[Path], placed: list[tuple[Path, Path | None]]) -> None:
    """A failed `write_files_atomic`'s traces removed: the files it put in place (the ones it replaced put
    back), then its temporaries."""
    for target, kept in reversed(placed):
        try:
            if kept is None:
                target.unlink(missing_ok=True)
            else:
                os.replace(kept, target)
        except OSError:
            log.warning("could not undo the write of %s", target)
    for path in temporaries:
        path.unlink(missing_ok=True)


def _link_new(temporary: Path, target: Path) -> None:
    """Give the finished temporary file the target's name, failing with FileExistsError if it exists."""
    try:
        os.link(temporary, target)
    except FileExistsError:
        raise
    except OSError:  # a file system without hard links: check and rename (not race-free there)
        if target.exists():
            raise FileExistsError(str(target)) from None
        os.replace(temporary, target)
        return
    try:
        temporary.unlink()
    except OSError:  # the target is in place; the temporary goes with the next write's stale ones
        pass


def _temporary_prefix(target: Path) -> str:
    return f".{target.name}."


def _create_temporary(target: Path) -> tuple[Path, int]:
    """A new hidden file beside `target` (a name no other writer holds) and its open descriptor, with the
    user's usual permissions (0666 less the umask); OSError where the folder takes no new file."""
    while True:
        temporary = target.with_name(f"{_temporary_prefix(target)}{os.getpid()}.{os.urandom(4).hex()}.tmp")
        try:
            return temporary, os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue


def _remove_stale_temporaries(target: Path) -> None:
    """Temporary files of this target left by a writer that was killed (its process no longer runs)."""
    prefix = _temporary_prefix(target)
    try:
        names = [n for n in os.listdir(target.parent or ".") if n.startswith(prefix) and n.endswith(".tmp")]
    except OSError:
        return
    for name in names:
        pid_text = name[len(prefix) :].split(".")[0]
        if pid_text.isdigit() and not _running(int(pid_text)):
            (target.parent / name).unlink(missing_ok=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def write_text_atomic(
    path: str | os.PathLike[str], text: str, force: bool = False, inputs: tuple[str, ...] = ()
) -> None:
    write_bytes_atomic(path, text.encode("utf-8"), force=force, inputs=inputs)
