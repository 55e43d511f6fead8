"""Safe output: never a half-written file, never an overwrite the user did not ask for."""

from __future__ import annotations

import os
import tempfile
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
    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    umask = os.umask(0)
    os.umask(umask)
    try:
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600; give the file the user's usual mode
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    except OSError as error:
        Path(temporary).unlink(missing_ok=True)
        raise OutputError(f"{target}: write failed: {error.strerror or error}") from None
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | os.PathLike[str], text: str, force: bool = False) -> None:
    write_bytes_atomic(path, text.encode("utf-8"), force=force)
