"""An on-disk cache of encoded style libraries, keyed by the clips' bytes and the model.

Encoding a long style library (features, mirrors, the encoder) is most of the cost of a short transfer
against it; a second transfer against the same clips and model loads the latents instead. The cache
lives in `$ELASTYLE_CACHE` or `~/.cache/elastyle`, as plain array archives (no pickle), and is kept under
`$ELASTYLE_CACHE_MB` megabytes (default 1024) by removing the least recently used libraries.
"""

from __future__ import annotations

import hashlib
import logging
import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from elastyle.core.body import in_units
from elastyle.core.motion import Motion
from elastyle.errors import OutputError
from elastyle.io.dataset import ClipRef, read_up
from elastyle.io.files import megabytes_from_environment, write_bytes_atomic
from elastyle.model.file import FORMAT_VERSION, StyleModel
from elastyle.steps.action import action_layout
from elastyle.steps.library import StyleLibrary, prepare_style

log = logging.getLogger(__name__)


DEFAULT_CACHE_MB = 1024.0


def cache_limit_bytes() -> int:
    """The cache's size limit: `$ELASTYLE_CACHE_MB` megabytes, else 1024."""
    return megabytes_from_environment("ELASTYLE_CACHE_MB", DEFAULT_CACHE_MB)


def cache_folder() -> Path:
    return Path(os.environ.get("ELASTYLE_CACHE") or Path.home() / ".cache" / "elastyle") / "libraries"


# 2: one BLAS thread; 3: action descriptors; 4: their ground by nearest sample; 5: clips at the model's size; 6: the root path
# smoothed to the clip's ends (`core.smoothing.smooth_path`: the latents near its ends change); 7: clips standing
# along +Z read turned to +Y up (`core.up`), the reading's --up in the key; 8: a clip read under other joint names
# mirrored by the model's names (`steps.library`); 9: the clips' reading notes kept, said again on a hit; 11: mirror
# axes per rig (`core.mirror`); 12: the trunk's lean among the action descriptors; 13: the pelvis's height;
# 14: which clips are held to one side (`StyleLibrary.one_sided`); 15: the head's gaze; 16: clips animated in place
# travel as their feet say (`steps.action.clip_in_place`)
CACHE_VERSION = 17
Note = tuple[int, str]  # a logging level and the text said at it


def library_key(
    model: StyleModel,
    clips: list[ClipRef],
    mirror_style: bool,
    reverse_style: bool = False,
    units: str | None = None,
) -> str:
    reverse = ":backwards" if reverse_style else ""  # libraries without reversed clips keep their keys
    unit = f":units-{units}" if units else ""  # and those of guessed units
    digest = hashlib.sha256(
        f"v{FORMAT_VERSION}.{CACHE_VERSION}:{model.encoding_fingerprint}:{mirror_style}{reverse}:up-{read_up()}{unit}".encode()
    )
    for clip in clips:
        digest.update(clip.name.encode())
        digest.update(hashlib.sha256(clip.data()).digest())
    return digest.hexdigest()[:32]


def load_library(
    model: StyleModel,
    clips: list[ClipRef],
    mirror_style: bool,
    use_cache: bool = True,
    check: Callable[[ClipRef, Motion], list[Note]] | None = None,
    reverse_style: bool = False,
    units: str | None = None,
) -> StyleLibrary:
    """The encoded library of `clips` (read in the length unit `units` states, guessed for None: `--units`),
    from the cache when it holds them, else read, checked by `check`
    (which raises for a clip that cannot be used, and returns the notes on how each clip is read: another
    naming, turned axes, another frame rate), encoded and cached. The notes are logged either way: a
    library from the cache says them again."""
    path = cache_folder() / f"{library_key(model, clips, mirror_style, reverse_style, units)}.npz"
    if use_cache and path.exists():
        try:
            with np.load(path, allow_pickle=False) as archive:
                latents, actions = archive["latents"], archive["actions"]
                if latents.shape[1:] != (model.config.latent_channels,) or actions.shape[1:] != (
                    action_layout(model.skeleton).width,
                ):
                    raise ValueError("written by another version")  # read as unreadable: encoded again
                names = [str(n) for n in archive["names"]]
                spans = _spans(archive["clip_starts"], len(latents))
                backwards = [bool(b) for b in archive["backwards"]] if "backwards" in archive else None
                notes = list(zip(archive["note_levels"].tolist(), archive["notes"].tolist()))
                one_sided = [
                    (str(joint), float(degrees)) if joint else None
                    for joint, degrees in zip(archive["sided_joints"], archive["sided_degrees"])
                ]
                library = StyleLibrary.of_latents(
                    names, [bool(m) for m in archive["mirrored"]], [latents[a:b] for a, b in spans],
                    [actions[a:b] for a, b in spans], backwards, model, one_sided,
                )  # fmt: skip
            log.debug("style library from cache %s", path)
            _say(notes)
            os.utime(path)  # recently used: kept longest when the cache is pruned
            return replace(library, notes=tuple(text for _, text in notes))
        except Exception:  # empty, cut short or garbled in any way: only a cache, so a miss
            log.debug("unreadable cache entry %s: encoding again", path)
    motions = [in_units(clip.read()[0], units) for clip in clips]
    notes = [note for clip, motion in zip(clips, motions) for note in (check(clip, motion) if check else [])]
    _say(notes)
    library = prepare_style(model, motions, [c.name for c in clips], mirror_style, reverse_style)
    if use_cache:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            from io import BytesIO

            buffer = BytesIO()
            np.savez(
                buffer, latents=library.latents, actions=library.actions, names=np.array(library.names),
                mirrored=np.array(library.mirrored), clip_starts=library.clip_starts,
                backwards=np.array(library.backwards, dtype=bool),
                note_levels=np.array([level for level, _ in notes], dtype=np.int64),
                notes=np.array([text for _, text in notes], dtype=str),
                sided_joints=np.array([side[0] if side else "" for side in library.sided], dtype=str),
                sided_degrees=np.array([side[1] if side else np.nan for side in library.sided]),
            )  # fmt: skip
            write_bytes_atomic(path, buffer.getvalue(), force=True)
            prune_cache(path.parent, cache_limit_bytes(), keep=path)
        except (OSError, OutputError) as error:  # a read-only home is no reason to fail a transfer
            _cannot_cache(path.parent, error)
    return replace(library, notes=tuple(text for _, text in notes))


_WARNED_CACHE: set[Path] = set()  # the cache folders said to be unwritable in this process


def _cannot_cache(folder: Path, error: Exception) -> None:
    """Said once per folder where the user named it ($ELASTYLE_CACHE: a file there was passed over without a
    word); where it is the default under the home folder (read-only on some machines), only in --verbose."""
    if not os.environ.get("ELASTYLE_CACHE") or folder in _WARNED_CACHE:
        log.debug("cannot cache the style library in %s: %s", folder, error)
        return
    _WARNED_CACHE.add(folder)
    log.warning(
        "warning: cannot write the style cache in %s (%s): ELASTYLE_CACHE must name a folder this user can "
        "write; transferring without the cache", folder, error,
    )  # fmt: skip


def _say(notes: list[Note]) -> None:
    for level, text in notes:
        log.log(level, "%s", text)


def prune_cache(folder: Path, limit_bytes: int, keep: Path | None = None) -> None:
    """Remove the least recently used libraries (by modification time) until the folder holds at most
    `limit_bytes`; `keep` (the entry just written) stays."""
    entries = []
    for entry in folder.glob("*.npz"):
        try:
            info = entry.stat()
        except OSError:
            continue
        entries.append((info.st_mtime, info.st_size, entry))
    total = sum(size for _, size, _ in entries)
    for _, size, entry in sorted(entries, key=lambda item: item[0]):
        if total <= limit_bytes:
            break
        if entry != keep:
            entry.unlink(missing_ok=True)
            total -= size


def _spans(starts: np.ndarray, total: int) -> list[tuple[int, int]]:
    ends = list(starts[1:]) + [total]
    return [(int(a), int(b)) for a, b in zip(starts, ends)]
