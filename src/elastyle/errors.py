"""Exception types that elastyle raises for problems a user can fix.

Every message is one line that names the file (or joint) and the problem; the CLI prints it as is.
"""

from __future__ import annotations


class ElastyleError(Exception):
    """Base class of every error caused by input, not by a bug in elastyle."""


class BvhError(ElastyleError):
    """A BVH file that cannot be read or written: `path:line: problem`."""

    def __init__(self, path: str, problem: str, line: int | None = None) -> None:
        place = f"{path}:{line}" if line is not None else str(path)
        super().__init__(f"{place}: {problem}")
        self.path = str(path)
        self.line = line
        self.problem = problem

    def __reduce__(self) -> tuple[type[BvhError], tuple[str, str, int | None]]:
        """Pickled by its own arguments, so an error raised where clips are read in parallel (training)
        reaches the caller as itself (the default pickling passes only the message and fails there)."""
        return (type(self), (self.path, self.problem, self.line))


class SkeletonMismatchError(ElastyleError):
    """Two clips (or a clip and a model) whose skeletons differ."""


class RestPoseError(SkeletonMismatchError):
    """A clip of a model's joints (under its names or others) whose bones point too far otherwise at rest."""


class ModelError(ElastyleError):
    """A model file that is missing, truncated, foreign or of another format version."""


class ClipTooShortError(ElastyleError):
    """A clip shorter than what an operation needs (for example one patch)."""


class DatasetError(ElastyleError):
    """A data path (file, folder, glob or zip) that yields no usable clips."""


class ResultError(ElastyleError):
    """A step that produced an unusable result (NaN or infinite values): nothing is written."""


class OutputError(ElastyleError):
    """An output path that cannot or must not be written."""


class UsageError(ElastyleError):
    """A wrong command line: an option out of range or a wrong combination of options (exit code 2)."""


class ConfigError(UsageError):
    """A transfer option out of its declared range or choices (from Python or the command line).

    option: the option's Python name where the message starts with it ("strength: ..."): the command line
    says its flag there instead (`elastyle.cli.options.config_from_args`)."""

    def __init__(self, message: str, option: str | None = None) -> None:
        super().__init__(message)
        self.option = option
