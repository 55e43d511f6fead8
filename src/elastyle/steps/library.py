"""The style library: style clips (and their mirrors) encoded end to end, with pooled latent statistics.

docs/method.md, "Style library". Encoded once per set of clips (and cached on disk by `steps.cache`), then
searched by every transfer against it.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from elastyle.core.body import guessed_unit_note
from elastyle.core.mirror import ONE_SIDED_DEGREES, asymmetry, mirror
from elastyle.core.motion import Motion, check_finite_clip, leading_pose_note
from elastyle.core.threads import one_blas_thread
from elastyle.errors import ClipTooShortError, ConfigError, SkeletonMismatchError
from elastyle.model.file import StyleModel, as_model
from elastyle.steps.action import action_channels
from elastyle.steps.search import StyleWindows
from elastyle.steps.whiten import LatentStats
from elastyle.types import FloatArray, IntArray

log = logging.getLogger(__name__)


# the mirror of a clip whose manner is held to one side (`core.mirror.ONE_SIDED_DEGREES`) is taken only where
# it matches this much better (cosine similarity) than the best window of the clips as performed: the style
# as its performer did it first, its mirror where it keeps the content's sides or steps (a turn or a hand the
# other way). A hand in a pocket or a head tilted switched sides mid-clip wherever the mirror matched a hair
# better (a head tilted 26 degrees came out tilted 12 the other way on a run; 21 the right way now). Not on
# every clip's mirror: on the dataset's two-sided walks that took the referee's wider walk pairs' timing
# error from 0.09 to 0.23; 0.1 kept a pocket to its side better, but made a straight walk given a
# one-handed wave's style read as turning
MIRROR_HANDICAP = 0.03


@dataclass(frozen=True, eq=False)
class StyleLibrary:
    """Encoded style clips: names, mirrored and played-backwards flags (K,), clip_starts (K,) library
    frames, latents (N, Z) and action descriptors (N, A) (`steps.action`) end to end, and the latents'
    pooled statistics; model: the model that encoded them (a transfer uses it unless told another);
    one_sided: per clip (K,), where its manner is held to one side, the joint that shows it most and by how
    many degrees its direction differs from the mirror's (`core.mirror.asymmetry`), else None; notes: how
    its clips were read (another naming, another rest pose, a guessed unit...), said when they were read
    and kept in each transfer's explain record."""

    names: list[str]
    mirrored: list[bool]
    clip_starts: IntArray
    latents: FloatArray
    actions: FloatArray
    stats: LatentStats
    backwards: list[bool] = field(default_factory=list)
    model: StyleModel | None = None
    one_sided: list[tuple[str, float] | None] = field(default_factory=list)
    notes: tuple[str, ...] = ()

    def __repr__(self) -> str:  # its arrays are the whole library: a summary, not kilobytes of numbers
        clips = ", ".join(dict.fromkeys(self.names))
        return (
            f"StyleLibrary({len(self.names)} clip(s) with mirrors and reversals: {clips}; "
            f"{self.latents.shape[0]} frames of {self.latents.shape[1]} latents)"
        )

    _white: dict[float, FloatArray] = field(default_factory=dict)
    _windows: dict[tuple[int, float, float, int], StyleWindows] = field(default_factory=dict)
    _derived: dict[Hashable, Any] = field(default_factory=dict)

    def white(self, floor: float) -> FloatArray:
        """The library's latents (N, Z) whitened with its own pooled statistics (eigenvalue `floor`)."""
        if floor not in self._white:
            self._white[floor] = self.stats.whiten(self.latents, floor)
        return self._white[floor]

    def windows(
        self, patch_frames: int, floor: float, action_weight: float, frame_step: int = 1
    ) -> StyleWindows:
        """The library's windows of `patch_frames` as the search compares them (on every `frame_step`-th
        frame): whitened latents beside the action descriptors times `action_weight` (`match_frames`)."""
        key = (patch_frames, floor, action_weight, frame_step)
        if key not in self._windows:
            frames = match_frames(self.white(floor), self.actions, action_weight)
            clip = self.clip_of(np.arange(len(frames)))
            sides = [mirrored and side is not None for mirrored, side in zip(self.mirrored, self.sided)]
            handicap = MIRROR_HANDICAP * np.asarray(sides, dtype=np.float64)[clip]  # (N,) per frame
            self._windows[key] = StyleWindows(frames, self.clip_starts, patch_frames, frame_step, handicap)
        return self._windows[key]

    def derived(self, key: Hashable, compute: Callable[[], Any]) -> Any:
        """A value computed from this library alone (its actions' measures, per patch length or body part),
        computed on the first call with `key` and kept: every transfer against the library reads it."""
        if key not in self._derived:
            self._derived[key] = compute()
        return self._derived[key]

    def clip_of(self, library_frames: IntArray) -> IntArray:
        """The clip index (F,) of each library frame (F,)."""
        return np.searchsorted(self.clip_starts, library_frames, side="right") - 1

    def locate(self, library_frame: int) -> tuple[int, int]:
        """(clip index, frame within that clip) of a library frame."""
        clip = int(self.clip_of(np.array([library_frame]))[0])
        return clip, int(library_frame - self.clip_starts[clip])

    @property
    def sided(self) -> list[tuple[str, float] | None]:
        """`one_sided` per clip (K,), None for each where it was not read (a library made by hand)."""
        return self.one_sided if len(self.one_sided) == len(self.names) else [None] * len(self.names)

    @property
    def longest_clip(self) -> int:
        ends = np.append(self.clip_starts[1:], self.latents.shape[0])
        return int(np.max(ends - self.clip_starts))

    @staticmethod
    def of_latents(
        names: Sequence[str],
        mirrored: Sequence[bool],
        latents: Sequence[FloatArray],
        actions: Sequence[FloatArray],
        backwards: Sequence[bool] | None = None,
        model: StyleModel | None = None,
        one_sided: Sequence[tuple[str, float] | None] | None = None,
    ) -> StyleLibrary:
        """A library from each clip's latents (T_k, Z) and action descriptors (T_k, A); `backwards`: which
        clips are played backwards (none by default); model: the one that encoded them; one_sided: per clip,
        where its manner is held to one side (`StyleLibrary.one_sided`; none by default)."""
        starts = np.cumsum([0] + [z.shape[0] for z in latents[:-1]]).astype(np.int64)
        return StyleLibrary(
            list(names), list(mirrored), starts, np.concatenate(latents), np.concatenate(actions),
            LatentStats.of(latents), list(backwards) if backwards is not None else [False] * len(names), model,
            list(one_sided) if one_sided is not None else [None] * len(names),
        )  # fmt: skip


def match_frames(white_latents: FloatArray, actions: FloatArray, action_weight: float) -> FloatArray:
    """What the search compares, per frame (T, Z + A): the whitened latents, and the action descriptors
    times `action_weight` (0: the latents alone, the report's matching)."""
    return np.concatenate([white_latents, action_weight * actions], axis=1)


@one_blas_thread
def prepare_style(
    model: StyleModel | str | os.PathLike[str] | None,
    motions: Motion | Sequence[Motion],
    names: Sequence[str] | None = None,
    mirror_style: bool = True,
    reverse_style: bool = False,
) -> StyleLibrary:
    """Encode a style library: every clip, plus its mirror when the skeleton allows, and with
    `reverse_style` each of those played backwards. model: a `StyleModel` or a model file's path (None: the
    shipped model); motions: one clip or several; names: one per clip (style0, style1, ... by default; one
    clip's name may be given as a string)."""
    model = as_model(model)
    motions = [motions] if isinstance(motions, Motion) else list(motions)
    _check_style_clips(motions)
    for flag, value in (("mirror_style", mirror_style), ("reverse_style", reverse_style)):
        if not isinstance(value, (bool, np.bool_)):
            raise ConfigError(f"{flag} must be True or False, got {value!r}")
    names = [names] if isinstance(names, str) else names
    if names is not None and not all(isinstance(name, str) for name in names):
        raise ConfigError(f"style names must be strings, got {list(names)!r:.80}")
    if names is not None and len(names) != len(motions):
        raise ConfigError(
            f"{len(names)} style name(s) for {len(motions)} style clip(s): give one name per clip"
        )
    names = _named_clips(names, len(motions))
    for name, motion in zip(names, motions):  # every clip checked before any is encoded
        check_finite_clip(motion, name)
        if motion.num_frames == 0:
            raise ClipTooShortError(f"{name}: a style clip without frames")
    clips: list[tuple[str, bool, Motion]] = []
    sided: list[tuple[str, float] | None] = []  # per clip in `clips`
    for name, motion in zip(names, motions):
        model.check_clip(motion, name)
        sized = model.at_model_size(model.on_model_hierarchy(motion))[0]
        motion = model.on_model_floor(sized).resample(model.fps)
        clips.append((name, False, motion))
        sided.append(None)
        if mirror_style:
            try:
                mirrored = _mirrored_by_model_names(model, motion)
            except SkeletonMismatchError:
                log.info(
                    "note: %s: no left/right joint pairs found, so the style is used without its mirror", name
                )
                continue
            clips.append((name, True, mirrored))
            degrees, joint = asymmetry(motion, mirrored)
            side = (motion.skeleton.names[joint], round(degrees, 1)) if degrees > ONE_SIDED_DEGREES else None
            sided[-1:] = [side, side]
    backwards = [False] * len(clips)
    if reverse_style:
        clips += [(name, mirrored, played_backwards(m)) for name, mirrored, m in clips]
        backwards += [True] * (len(clips) - len(backwards))
        sided += sided
    latents = [model.encode_motion(m)[0] for _, _, m in clips]
    actions = [action_channels(m) for _, _, m in clips]
    return StyleLibrary.of_latents(
        [c[0] for c in clips], [c[1] for c in clips], latents, actions, backwards, model, sided
    )


def _mirrored_by_model_names(model: StyleModel, motion: Motion) -> Motion:
    """The mirror of a clip on the model's joints (`StyleModel.on_model_hierarchy`), its left and right
    joints paired by the model's joint names: a clip the model reads joint by joint under other names
    mirrors as the model's own would, even where its own names do not pair (a hand renamed on one side)."""
    if motion.skeleton.num_joints != model.skeleton.num_joints:
        return mirror(motion)
    mirrored = mirror(motion.renamed(model.skeleton.names))
    return Motion(motion.skeleton, mirrored.rotations, mirrored.translations, motion.fps)


def played_backwards(motion: Motion) -> Motion:
    """The clip played from its last frame to its first (a forward walk becomes a backward one)."""
    return Motion(
        motion.skeleton, motion.rotations[::-1].copy(), motion.translations[::-1].copy(), motion.fps
    )


def as_library(
    model: StyleModel,
    style: Motion | Sequence[Motion] | StyleLibrary,
    names: Sequence[str] | None,
    mirror_style: bool,
    reverse_style: bool = False,
) -> StyleLibrary:
    """A prepared library as it is (`check_prepared` first); one clip or several clips encoded into one."""
    if isinstance(style, StyleLibrary):
        check_prepared(style, model, mirror_style, reverse_style)
        return style
    if isinstance(style, (str, bytes, os.PathLike)):
        raise TypeError(
            f"the style must be a Motion, a list of them or a StyleLibrary, got the path {style!r:.80}: read it "
            "first with elastyle.read_bvh(path), which returns (motion, layout)"
        )
    if not isinstance(style, (Motion, list, tuple)):
        raise TypeError(
            f"the style must be a Motion, a list of them or a StyleLibrary, got {type(style).__name__} "
            f"{style!r:.60}"
        )
    motions = [style] if isinstance(style, Motion) else list(style)
    library = prepare_style(model, motions, names, mirror_style, reverse_style)
    # how each clip is read, said as a content's is (a prepared library's clips had it said where they were
    # read: `steps.cache.load_library`)
    notes = []
    for name, motion in zip(_named_clips(names, len(motions)), motions):
        unit_note = guessed_unit_note(motion.skeleton, name)
        for note in (leading_pose_note(motion, name), model.check_clip(motion, name), unit_note):
            if note is not None:
                log.warning("%s", note)
                notes.append(note)
    return replace(library, notes=tuple(notes))


def _named_clips(names: Sequence[str] | None, count: int) -> list[str]:
    """The names of `count` style clips: as given, else style0, style1, ..."""
    return list(names) if names is not None else [f"style{i}" for i in range(count)]


def check_prepared(library: StyleLibrary, model: StyleModel, mirror_style: bool, reverse_style: bool) -> None:
    """A `ConfigError` where a prepared library does not fit the transfer: encoded by a model that encodes
    otherwise than `model`, or with mirrored or backwards clips that the options refuse, or without the
    backwards clips they ask for (a library's clips are chosen when it is prepared)."""
    if library.model is not None and library.model.encoding_fingerprint != model.encoding_fingerprint:
        raise ConfigError(
            "the style library was prepared with another model than the transfer's: prepare it with the same "
            "model, or give that one (transfer(..., model=library.model))"
        )
    for asked, name, flags, kind in (
        (mirror_style, "mirror_style", library.mirrored, "mirrored"),
        (reverse_style, "reverse_style", library.backwards, "backwards"),
    ):
        if (not asked and any(flags)) or (asked and name == "reverse_style" and not any(flags)):
            raise ConfigError(
                f"{name}={asked}, but the style library was prepared {'with' if any(flags) else 'without'} "
                f"{kind} clips: prepare it with prepare_style(..., {name}={asked})"
            )


def _check_style_clips(motions: Sequence[Motion]) -> None:
    """An `ElastyleError` without clips, a `TypeError` naming what was given where a clip belongs."""
    if not motions:
        raise ConfigError("no style clips given")
    for motion in motions:
        if not isinstance(motion, Motion):
            raise TypeError(
                f"style clips must be Motions, got {type(motion).__name__} (elastyle.read_bvh returns (motion, "
                "layout): pass its motion)"
            )
