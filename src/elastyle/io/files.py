"""Safe output: never a half-written file, never an overwrite the user did not ask for."""

from __future__ import annotations

import os
from pathlib import Path

from elastyle.errors import OutputError


def check_output_path(
    path: str | os.PathLike[str], force: bool = False, inputs: tuple[str, ...] = ()
) -> Path:
    """Validate an output path before any work is done; returns it as a `Path`."""
    target = Path(path)
    if not target.parent.exists():
        raise OutputError(f"{target}: output folder {target.parent} does not exist")
    if target.is_dir():
        raise OutputError(f"{target}: is a directory; give a file name")
    for source in inputs:
        try:
            same = target.exists() and os.path.samefile(target, source)
        except OSError:
            same = False
        if same:
            raise OutputError(f"{target}: output would overwrite an input file; choose another name")
    if target.exists() and not force:
        raise OutputError(f"{target}: already exists (use --force to overwrite)")
    return target


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes, force: bool = False) -> None:
    """Write to a temporary file beside `path`, then rename it into place only once complete."""
    target = check_output_path(path, force=force)
    temporary, handle = _create_temporary(target)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise OutputError(f"{target}: write failed: {error.strerror or error}") from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def _create_temporary(target: Path) -> tuple[Path, int]:
    """A new hidden file beside `target` (a name no other writer holds) and its open descriptor, with the
    user's usual permissions (0666 less the umask)."""
    while True:
        temporary = target.with_name(f".{target.name}.{os.getpid()}.{os.urandom(4).hex()}.tmp")
        try:
            return temporary, os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        except OSError as error:
            raise OutputError(f"{target}: write failed: {error.strerror or error}") from None


def write_text_atomic(path: str | os.PathLike[str], text: str, force: bool = False) -> None:
    write_bytes_atomic(path, text.encode("utf-8"), force=force)
