"""Finding clips: files, folders, globs, and zip archives (also a path inside one, or a glob inside one).

Every command and test lists its clips through `find_clips` and reads them with `ClipRef.read`.
"""

from __future__ import annotations

import difflib
import fnmatch
import glob
import logging
import os
import re
import zipfile
import zlib
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.up import UP_AXES, detected_axis, turned_up
from elastyle.errors import BvhError, ConfigError, DatasetError
from elastyle.io.bvh_layout import BvhLayout
from elastyle.io.bvh_read import parse_bvh, read_bvh, read_input
from elastyle.io.files import input_problem

log = logging.getLogger(__name__)

DATA_ENVIRONMENT_VARIABLE = "ELASTYLE_DATA"
PUBLIC_DATASET_HINT = (
    "the Bandai Namco Research Motion Dataset 2 is published at "
    "github.com/BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset; "
    f"point {DATA_ENVIRONMENT_VARIABLE} (or --data) at its zip or unpacked folder"
)


class ClipRef(NamedTuple):
    """One BVH clip: a file on disk, or a member of a zip archive."""

    name: str  # what messages show: a path, or "archive.zip/member"
    archive: str | None = None
    member: str | None = None

    @property
    def stem(self) -> str:
        return Path(self.member or self.name).stem

    def read(self, up: str | None = None) -> tuple[Motion, BvhLayout]:
        """The clip, standing along +Y, and its layout: BVH, or binary glTF for a `.glb` name (with BVH's
        default layout; glTF is +Y up).

        up: the BVH file's up axis, "y" or "z", or "auto" for the axis its body stands along
        (`core.up.standing_axis`); None: as `set_read_up` last said ("auto" unless told otherwise). A clip
        read with +Z up is turned to +Y up, and its layout turns it back where it is written."""
        suffix = Path(self.member or self.name).suffix.lower()
        if suffix == ".gltf":  # the JSON form, its buffers in other files
            raise BvhError(self.name, "a .gltf (JSON) file: elastyle reads binary glTF; export it as .glb")
        if suffix == ".glb":
            from elastyle.io.gltf_read import parse_glb

            motion = parse_glb(self.data(), self.name)
            moving = np.flatnonzero(np.ptp(motion.translations, axis=0).max(axis=1) > 0).tolist()
            return motion, BvhLayout.default(motion.skeleton, motion.fps, moving)
        up = up or _READ_UP[0]
        if up not in READ_UPS:
            raise ConfigError(f"up must be one of {', '.join(READ_UPS)}, got {up!r}", "up")
        motion, layout = read_bvh(self.name) if self.archive is None else parse_bvh(self.data(), self.name)
        detected = detected_axis(motion)
        axis = (detected or "y") if up == "auto" else up
        if up == "auto" and axis != "y":
            _note_turned(self.name)
        elif up != "auto" and detected not in (None, up):
            log.warning(
                "note: %s: its body stands along +%s, but it is read with +%s up as --up says",
                self.name, detected.upper(), up.upper(),
            )  # fmt: skip
        if axis == "y":
            return motion, layout
        return turned_up(motion, axis), layout._replace(up=axis)

    def data(self) -> bytes:
        """The file's raw bytes."""
        if self.archive is None:
            return read_input(self.name)
        try:
            archive = _open_zip(self.archive, os.getpid())
            problem = input_problem(self.name, size=archive.getinfo(self.member or "").file_size)
            if problem is not None:
                raise BvhError(self.name, problem)
            return archive.read(self.member or "")
        except KeyError:
            raise BvhError(
                self.name,
                f"no such file in the archive {self.archive}{_nearest(self.archive, self.member or '')}",
            ) from None
        except (zipfile.BadZipFile, OSError) as error:
            raise BvhError(self.name, f"cannot read: {error}") from None


def _nearest(archive: str, member: str) -> str:
    """ "(nearest: ...)" naming the archive's clips whose paths in it are nearest `member`, or ""."""
    clips = [name for name in _open_zip(archive, os.getpid()).namelist() if name.lower().endswith(".bvh")]
    close = difflib.get_close_matches(member, clips, n=3, cutoff=0.6)
    return f" (nearest in it: {', '.join(close)})" if close else ""


@lru_cache(maxsize=8)
def _open_zip(path: str, process_id: int) -> zipfile.ZipFile:
    """An open archive per process (a handle shared across a fork would interleave reads)."""
    del process_id
    return zipfile.ZipFile(path)


def default_data_path() -> Path | None:
    """`$ELASTYLE_DATA`, else `../shared/data/bandai-namco-2.zip` beside the project or the working folder."""
    configured = os.environ.get(DATA_ENVIRONMENT_VARIABLE)
    if configured:
        return Path(configured)
    project_root = Path(__file__).resolve().parents[3]
    for base in (project_root, Path.cwd()):
        candidate = base.parent / "shared" / "data" / "bandai-namco-2.zip"
        if candidate.exists():
            return candidate
    return None


CLIP_SUFFIXES = (".bvh", ".glb")  # what a folder's clips are


def _is_clip_name(name: str, suffixes: tuple[str, ...] = CLIP_SUFFIXES) -> bool:
    """Whether a path found in a folder, archive or glob names a clip: its suffix, and not the metadata macOS
    writes beside each file (`._name.bvh`, and every file under `__MACOSX/` in a zip it makes)."""
    parts = name.replace("\\", "/").split("/")
    return name.lower().endswith(suffixes) and not parts[-1].startswith("._") and "__MACOSX" not in parts


def _split_archive(spec: str) -> tuple[str, str] | None:
    """'a/b.zip/inner/x*.bvh' -> ('a/b.zip', 'inner/x*.bvh'); 'a/b.zip' -> ('a/b.zip', '')."""
    parts = Path(spec).parts
    for index in range(len(parts), 0, -1):
        head = str(Path(*parts[:index]))
        if head.lower().endswith(".zip") and Path(head).is_file():
            return head, "/".join(parts[index:])
    return None


def _archive_clips(archive: str, inner: str) -> list[ClipRef]:
    try:
        members = [m for m in _open_zip(archive, os.getpid()).namelist() if _is_clip_name(m, (".bvh",))]
    except (zipfile.BadZipFile, OSError) as error:
        raise DatasetError(f"{archive}: not a readable zip archive ({error})") from None
    if inner:
        pattern = inner if any(c in inner for c in "*?[") else inner.rstrip("/") + "*"
        members = [m for m in members if fnmatch.fnmatch(m, pattern) or fnmatch.fnmatch(m, "*/" + pattern)]
    return [ClipRef(f"{archive}/{m}", archive, m) for m in sorted(members)]


def find_clips(
    specs: str | os.PathLike[str] | Iterable[str | os.PathLike[str]], pattern: str | None = None
) -> list[ClipRef]:
    """Every BVH clip that files, folders, globs or zip archives name (one, or a list of them), sorted
    within each spec.

    `pattern` (a glob on the file name, e.g. '*walk_normal*') filters the result.
    """
    clips: list[ClipRef] = []
    for raw in [specs] if isinstance(specs, (str, os.PathLike)) else specs:
        spec = str(raw)
        archive = _split_archive(spec)
        if archive is not None:
            found = _archive_clips(*archive)
        elif Path(spec).is_dir():
            found = [
                ClipRef(str(p))
                for p in sorted(Path(spec).rglob("*"))
                if _is_clip_name(str(p.relative_to(spec))) and p.is_file()  # below the folder given
            ]
        elif Path(spec).exists():  # a file named with glob characters (walk[1].bvh) is that file
            found = [ClipRef(spec)]
        elif any(c in spec for c in "*?["):
            found = [
                ClipRef(p)
                for p in sorted(glob.glob(spec, recursive=True))
                if Path(p).is_file() and _is_clip_name(p, ("",))  # any suffix the glob asks for
            ]
        else:
            raise DatasetError(f"{spec}: no such file, folder or archive")
        if pattern:
            found = [c for c in found if fnmatch.fnmatch(Path(c.member or c.name).name, pattern)]
        if not found:
            nearest = _nearest(*archive) if archive is not None and archive[1] else ""
            raise DatasetError(
                f"{spec}: no BVH clips found{f' matching {pattern!r}' if pattern else ''}{nearest}"
            )
        clips.extend(found)
    return clips


def read_clip(spec: str | os.PathLike[str], up: str | None = None) -> tuple[Motion, BvhLayout]:
    """Read one clip named by a file path or a path inside a zip archive (up: `ClipRef.read`): the clip, its
    rotations (T, J, 3) exp maps in radians and translations (T, J, 3) in the file's length unit, and the
    layout that writes it back as its file has it."""
    if isinstance(spec, bytes) and b"\n" not in spec:
        spec = os.fsdecode(spec)  # a path given as bytes
    if not isinstance(spec, (str, os.PathLike)):
        raise TypeError(
            f"read_bvh takes a file's path, got {type(spec).__name__} {spec!r:.40}: a BVH text in memory is "
            "read by elastyle.io.bvh_read.parse_bvh(data, name)"
        )
    archive = _split_archive(str(spec))
    if archive is not None and archive[1]:
        return ClipRef(str(spec), archive[0], archive[1]).read(up)
    return ClipRef(str(spec)).read(up)


READ_UPS = ("auto", *UP_AXES)
_READ_UP = ["auto"]  # how clips find their up axis (`set_read_up`): the command line's --up
_TURNED_NOTED: list[str] = []  # the first clip read turned, noted once per process


def set_read_up(up: str) -> None:
    """How every clip read from now on finds its BVH file's up axis (`ClipRef.read`): "auto", "y" or "z"
    (the command line's --up; worker processes forked after this inherit it)."""
    if up not in READ_UPS:
        raise ValueError(f"up must be one of {', '.join(READ_UPS)}, got {up!r}")
    _READ_UP[0] = up


def read_up() -> str:
    """How clips find their up axis now (`set_read_up`)."""
    return _READ_UP[0]


def _note_turned(name: str) -> None:
    """One note per process for clips found standing along +Z (a training set may hold thousands)."""
    if _TURNED_NOTED:
        log.debug("%s: read with +Z up", name)
        return
    _TURNED_NOTED.append(name)
    log.warning(
        "note: %s stands along +Z: read with +Z up (as any other such clip), and written back so; "
        "--up y reads clips as +Y up", name,
    )  # fmt: skip


# <content>_<style>_<take> ending a file name, after any prefix: the dataset's dataset-2_walk_normal_005, or
# a user's own hero_walk_proud_012 (content types may hold hyphens: walk-turn-left)
LABELLED_NAME = re.compile(r"(?:^|_)(?P<content>[a-z][a-z0-9-]*)_(?P<style>[a-z][a-z0-9]*)_(?P<take>\d+)$")
LABELLED_NAME_TEXT = "<content>_<style>_<take>.bvh after any prefix, such as dataset-2_walk_normal_005.bvh"


class DatasetLabel(NamedTuple):
    """What a labelled file name (`LABELLED_NAME`) says: content type, style and take number."""

    content: str
    style: str
    take: int


def dataset_label(clip: ClipRef) -> DatasetLabel | None:
    """The label of a file named as the dataset's are (`LABELLED_NAME`, any letter case), or None."""
    match = LABELLED_NAME.search(clip.stem.lower())
    if match is None:
        return None
    return DatasetLabel(match["content"], match["style"], int(match["take"]))


def labelled_clips(
    clips: Iterable[ClipRef], held_out: bool | None = None
) -> list[tuple[ClipRef, DatasetLabel]]:
    """The clips that carry a dataset label, with it; only held-out (or only training) takes if asked."""
    pairs = [(clip, label) for clip in clips if (label := dataset_label(clip)) is not None]
    if held_out is None:
        return pairs
    return [(clip, label) for clip, label in pairs if is_held_out(clip) == held_out]


HOLDOUT_EVERY = 5  # dataset takes numbered % 5 == 0 are held out: never trained on, used for every benchmark


_TAKE_NUMBER = re.compile(r"(\d+)$")  # the number that ends a file name (without its extension): its take


def is_held_out(clip: ClipRef, every: int = HOLDOUT_EVERY, numbered: bool = True) -> bool:
    """The one train / held-out split, by whole files: takes numbered % every == 0, the take being the
    number that ends the file name (`walk_proud_005.bvh`, `take10.bvh`); names without one (or all names,
    not `numbered`: where one number ends every name of a set) by a stable hash of the file name."""
    stem = Path(clip.name).name.rsplit(".", 1)[0]
    take = _TAKE_NUMBER.search(stem) if numbered else None
    if take is not None:
        return int(take.group(1)) % every == 0
    return zlib.crc32(Path(clip.name).name.encode()) % every == 0


def split_held_out(clips: list[ClipRef], every: int = HOLDOUT_EVERY) -> tuple[list[ClipRef], list[ClipRef]]:
    """Training and held-out clips by `is_held_out`; where one number ends every name of several clips (a
    date, a frame rate: not takes), by the names' hash instead; every clip trained on where none is left."""
    held_out = [c for c in clips if is_held_out(c, every)]
    if len(held_out) == len(clips) > 1:
        held_out = [c for c in clips if is_held_out(c, every, numbered=False)]
    chosen = {id(c) for c in held_out}
    training = [c for c in clips if id(c) not in chosen]
    return (training, held_out) if training else (held_out, [])
