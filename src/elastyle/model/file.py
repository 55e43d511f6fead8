"""The model file: one plain `.npz` array archive (no pickle) holding everything a transfer needs.

Keys: format_version, config (JSON), fps, joint names and parents, offsets, reference rotations,
pelvis forward axis, normalisation mean/std, weights, and a JSON metadata string (training figures).
"""

from __future__ import annotations

import hashlib
import json
import os
import weakref
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import cached_property
from io import BytesIO
from pathlib import Path
from typing import Any, NamedTuple, TypeVar

import numpy as np

from elastyle.core.body import at_size_of, same_rest_pose, same_structure
from elastyle.core.extra_joints import model_joints_in, with_extra_joints, without_extra_joints
from elastyle.core.ground import floor_gap, has_feet, raised
from elastyle.core.joint_tree import folded_joints
from elastyle.core.missing_joints import Completion, completed, completion, uncompleted
from elastyle.core.motion import Motion
from elastyle.core.parts import rest_pose_stands
from elastyle.core.rest_frames import (
    AXIS_TURNS,
    frames_reposed,
    frames_turned,
    rest_degrees,
    rest_rotations,
    rest_rotations_from_pose,
)
from elastyle.core.roots import with_added_roots, without_added_roots
from elastyle.core.skeleton import Skeleton, forward_kinematics
from elastyle.core.smoothing import smooth
from elastyle.errors import ModelError, RestPoseError, SkeletonMismatchError
from elastyle.io.files import input_problem, write_bytes_atomic
from elastyle.model.autoencoder import Autoencoder, AutoencoderWeights
from elastyle.model.config import ModelConfig
from elastyle.model.features import FeatureSpec, RootPath
from elastyle.types import FloatArray, IntArray

FORMAT_VERSION = 1
PRETRAINED_NAME = "bandai-namco-2.npz"
_WEIGHT_NAMES = ("conv1", "bias1", "conv2", "bias2", "deconv2", "debias2", "deconv1", "debias1")


@dataclass(frozen=True, eq=False)
class StyleModel:
    """A trained autoencoder with its feature spec and normalisation: everything `transfer` needs.

    feature_mean, feature_std: (C,) per-channel normalisation of the features.
    """

    config: ModelConfig
    features: FeatureSpec
    feature_mean: FloatArray
    feature_std: FloatArray
    autoencoder: Autoencoder
    fps: float
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def skeleton(self) -> Skeleton:
        return self.features.skeleton

    def __repr__(self) -> str:
        shape = self.config
        return (
            f"StyleModel({shape.latent_channels} latent channels, {shape.hidden_channels} hidden, "
            f"{shape.kernel_frames}-frame kernel, {self.fps:g} fps, {self.skeleton!r})"
        )

    @cached_property
    def encoding_fingerprint(self) -> str:
        """A digest of everything encoding reads (normalisation, reference rotations, encoder weights, shape,
        frame rate, joints): style libraries encoded by models with the same one are the same."""
        digest = hashlib.sha256()
        weights = self.autoencoder.weights
        for array in (
            self.feature_mean, self.feature_std, self.features.reference_rotations, weights.conv1, weights.conv2
        ):  # fmt: skip
            digest.update(np.ascontiguousarray(array).tobytes())
        digest.update(repr((self.config, self.fps, self.skeleton.names, self.ground)).encode())
        return digest.hexdigest()

    def at_model_size(self, motion: Motion) -> tuple[Motion, float]:
        """The clip scaled to the model's unit and size (`core.body.size_factor`), and the factor."""
        return at_size_of(motion, self.skeleton)

    @property
    def ground(self) -> float | None:
        """The toes' ground level (model units, `core.ground.ground_level`) of the model's held-out takes
        (their median, recorded by `calibrate`); None in a file written before it was recorded."""
        value = self.metadata.get("ground")
        return None if value is None else float(value)

    def floor_lift(self, motion: Motion, positions: FloatArray | None = None) -> float:
        """How far (model units) to raise a clip at the model's size (`at_model_size`) so that it stands on
        the floor of the model's takes: their toes' ground level (`ground`) less the clip's (positions
        (T, J, 3) of its frames, when known), unless within a tolerance (`core.ground.floor_gap`). The model reads
        the pelvis's height above y = 0, so a clip on another floor would take the style's height above
        that floor (a walk on a floor 10 cm up came out crouched 11 cm lower, its toes dragging). 0 where
        the model records no ground or the clip has no toes."""
        if self.ground is None or not has_feet(motion):
            return 0.0
        return floor_gap(motion, self.ground, positions)

    def on_model_floor(self, motion: Motion) -> Motion:
        """The clip at the model's size raised onto the floor of the model's takes (`floor_lift`)."""
        return raised(motion, self.floor_lift(motion))

    def on_model_hierarchy(self, motion: Motion) -> Motion:
        """The clip on the model's joints: its joints' axes turned to the model's where an exporter turned
        them all (`core.rest_frames`), joints the model lacks below its own dropped and its own put in the
        model's order (`core.extra_joints`: fingers, props, tips), and the joints above its root that the
        model has and it lacks added at rest (`core.roots`: a static root some exporters drop), as are the
        model's joints it lacks elsewhere (`core.missing_joints`: a toe, a neck); any other clip as it is."""
        found = self.completion(motion)
        if found is not None:
            motion = completed(motion, found)
        rest = self.rest_pose(motion)
        if rest is not None:
            motion = frames_reposed(motion, rest)
        turn = self.rest_turn(motion)
        if turn is not None:
            motion = frames_turned(motion, turn)
        joints = model_joints_in(self.skeleton, motion.skeleton)
        if joints is not None:
            motion = without_extra_joints(motion, joints)
        return with_added_roots(self.skeleton, motion) or motion

    def on_clip_hierarchy(self, motion: Motion, clip_at: Motion) -> Motion:
        """An output on the model's hierarchy (`on_model_hierarchy` of the clip) back on the clip's own
        skeleton: the added root joints dropped, its axes turned back, the clip's other joints as `clip_at`,
        the clip at the output's N moments, has them, and its own rest pose; the model's joints it lacks left
        out (`core.missing_joints.uncompleted`)."""
        found = self.completion(clip_at)
        if found is not None:
            own = self._on_clip_joints(motion, completed(clip_at, found))
            return uncompleted(own, clip_at.skeleton, found)
        return self._on_clip_joints(motion, clip_at)

    def _on_clip_joints(self, motion: Motion, clip_at: Motion) -> Motion:
        """`on_clip_hierarchy` for a clip with every model joint."""
        rest = self.rest_pose(clip_at)
        if rest is None:
            return self._on_clip_hierarchy(motion, clip_at)
        own = frames_reposed(
            self._on_clip_hierarchy(motion, frames_reposed(clip_at, rest)), rest, inverse=True
        )
        return Motion(clip_at.skeleton, own.rotations, own.translations, own.fps)

    def _on_clip_hierarchy(self, motion: Motion, clip_at: Motion) -> Motion:
        """`on_clip_hierarchy` for a clip in the model's rest pose."""
        turn = self.rest_turn(clip_at)
        turned = clip_at if turn is None else frames_turned(clip_at.slice(0, 1), turn)
        joints = model_joints_in(self.skeleton, turned.skeleton)
        own = turned.skeleton if joints is None else without_extra_joints(turned, joints).skeleton
        motion = without_added_roots(motion, own)
        if turn is not None:
            motion = frames_turned(motion, turn.T)
        return motion if joints is None else with_extra_joints(motion, clip_at, joints)

    def completion(self, motion: Motion) -> Completion | None:
        """The model's joints a clip lacks and where they go (`core.missing_joints.completion`), where the model
        reads it with them added and not without; None otherwise. Found once per clip skeleton."""
        return _once_per_skeleton(_COMPLETIONS, self.skeleton, motion, self._find_completion)

    def _find_completion(self, motion: Motion) -> Completion | None:
        try:
            self._check_given(motion, "clip")
            return None
        except SkeletonMismatchError:
            pass
        found = completion(self.skeleton, motion.skeleton, self.typical_pose)
        if found is None:
            return None
        try:
            self._check_given(completed(motion, found), "clip")
            return found
        except SkeletonMismatchError:
            return None

    @cached_property
    def typical_pose(self) -> FloatArray:
        """World rotations (J, 3, 3) of the model's joints in its typical pose: each joint at its mean rotation
        over the training clips (`FeatureSpec.reference_rotations`; the pelvis's relative to the heading)."""
        rotations = self.features.reference_rotations[None]  # (1, J, 3)
        return forward_kinematics(self.skeleton, rotations, self.skeleton.offsets[None])[0][0]

    @cached_property
    def standing_skeleton(self) -> Skeleton:
        """The model's skeleton resting in its typical pose (`typical_pose`): its bones as they point there, in
        the world's frame, as a rig that rests standing has them."""
        rest = Motion(
            self.skeleton, np.zeros((1, self.skeleton.num_joints, 3)), self.skeleton.offsets[None], self.fps
        )
        return frames_reposed(rest, self.typical_pose, inverse=True).skeleton

    def rest_turn(self, motion: Motion) -> FloatArray | None:
        """The turn (3, 3) of every joint's axes under which the model reads a clip it does not read as it
        is (`core.rest_frames`: an exporter's own axes); None where it reads it as it is, or under no turn.
        Found once per clip skeleton (it decides alone)."""
        return _once_per_skeleton(_REST_TURNS, self.skeleton, motion, self._find_rest_turn)

    def rest_pose(self, motion: Motion) -> FloatArray | None:
        """Per clip joint, the turn (J, 3, 3) of its frame under which the model reads a clip of its hierarchy
        in another rest pose (`core.rest_frames.rest_rotations`: an A-pose's arms, bones set otherwise at rest;
        or, for a rig that rests standing, `rest_rotations_from_pose` from the model's `typical_pose`: the
        reading whose own turns add up least), the same world motion; None where the clip's bones point as the
        model's (within `REPOSE_DEGREES`) or too far otherwise for both readings (`REPOSE_MOST_DEGREES`,
        `POSED_MOST_DEGREES`), where an axis turn reads it, or where re-posing does not make it readable.
        Found once per clip skeleton."""
        reading = _once_per_skeleton(_REST_POSES, self.skeleton, motion, self._find_rest_pose)
        return None if reading is None else reading.turns

    def rest_from_typical_pose(self, motion: Motion) -> bool:
        """Whether `rest_pose` reads the clip from the model's typical pose (a rig that rests standing)."""
        reading = _once_per_skeleton(_REST_POSES, self.skeleton, motion, self._find_rest_pose)
        return reading is not None and reading.from_pose

    def _find_rest_pose(self, motion: Motion) -> _RestReading | None:
        if self.skeleton.same_as(motion.skeleton) and np.array_equal(
            self.skeleton.offsets, motion.skeleton.offsets
        ):
            return None
        if self.rest_turn(motion) is not None:
            return None
        # a rig that rests standing is matched under other names against the model's skeleton in its typical
        # pose: against its rest (bones along X), Mixamo's arms were paired with the other side's
        reference = self.standing_skeleton if rest_pose_stands(motion.skeleton) else self.skeleton
        mapped = _model_joints(reference, motion.skeleton)
        if mapped is None:
            return None
        rest = rest_rotations(motion.skeleton, self.skeleton, *mapped)
        turned = rest_degrees(rest)[mapped[0]]  # (J',) each model joint's match
        if turned.max() <= REPOSE_DEGREES:
            return None  # read as it is
        # the rest turned from the model's, or from the model's typical pose where the rig stands at rest (a T-
        # or an A-pose: bones that point another way from the model's each get their twist from that pose): the
        # reading that turns the clip's joints least
        readings = (
            [(float(turned.sum()), _RestReading(rest, False))] if turned.max() <= REPOSE_MOST_DEGREES else []
        )
        posed, turns = rest_rotations_from_pose(
            motion.skeleton, self.skeleton, mapped[0], self.typical_pose, mapped[1]
        )
        if turns[mapped[0]].max() <= POSED_MOST_DEGREES:
            readings.append((float(turns[mapped[0]].sum()), _RestReading(posed, True)))
        for _, reading in sorted(readings, key=lambda reading: reading[0]):
            try:
                self._check(frames_reposed(motion, reading.turns), "clip")
                return reading
            except SkeletonMismatchError:
                continue
        return None

    def _find_rest_turn(self, motion: Motion) -> FloatArray | None:
        try:
            self._check(motion, "clip")
            return None
        except SkeletonMismatchError:
            pass
        for turn in AXIS_TURNS:
            try:
                self._check(frames_turned(motion, turn), "clip")
                return turn
            except SkeletonMismatchError:
                continue
        return None

    def normalise(self, features: FloatArray) -> FloatArray:
        return (features - self.feature_mean) / self.feature_std

    def denormalise(self, features: FloatArray) -> FloatArray:
        return features * self.feature_std + self.feature_mean

    def encode_motion(self, motion: Motion) -> tuple[FloatArray, RootPath]:
        """Latents (T, Z) and root path of a clip already at the model's frame rate."""
        features, root = self.features.encode(motion)
        return self.autoencoder.encode(self.normalise(features)).astype(np.float64), root

    def decode_latents(
        self, latents: FloatArray, smooth_s: float = 0.0, frames: IntArray | None = None
    ) -> FloatArray:
        """Features (T, C) from latents (T, Z), low-passed along time by a Gaussian of `smooth_s` seconds;
        frames: only these output frames (n,) -> (n, C), unsmoothed."""
        if frames is not None:
            return self.denormalise(self.autoencoder.decode(latents, frames).astype(np.float64))
        features = self.denormalise(self.autoencoder.decode(latents).astype(np.float64))
        return smooth(features, smooth_s * self.fps)

    def check_clip(self, motion: Motion, what: str) -> str | None:
        """None for a clip of the model's skeleton (its joints and rest pose); a note for one the model reads
        otherwise (`on_model_hierarchy`: other joint names or order, extra joints, a dropped static root,
        its axes turned, joints it lacks); otherwise a `SkeletonMismatchError` naming the clip, what differs,
        and how to get a model for it."""
        found = self.completion(motion)
        if found is None:
            try:
                return self._check_given(motion, what)
            except SkeletonMismatchError:
                self._raise_rest_pose_of_completed(motion, what)
                raise
        lacking, them = list(found.names), "it" if len(found.names) == 1 else "them"
        above = any(found.skeleton.children(joint) for joint in found.added.tolist())
        return _also(
            f"note: {what}: it lacks the model's {_listed(lacking)}: read with {them} added at rest, unturned, "
            f"and written without {them}"
            + (" (the joints below an added one take its turn)" if above else ""),
            self._check_given(completed(motion.slice(0, 1), found), what),
            what,
        )

    def _raise_rest_pose_of_completed(self, motion: Motion, what: str) -> None:
        """The rest pose's error of a clip that lacks some of the model's joints (`core.missing_joints`) and
        whose bones, with them added, point too far otherwise at rest: that, not the joints, is why it is
        refused."""
        found = completion(self.skeleton, motion.skeleton, self.typical_pose)
        if found is not None:
            try:
                self._check_given(completed(motion.slice(0, 1), found), what)
            except RestPoseError as error:
                raise error from None
            except SkeletonMismatchError:
                pass

    def _check_given(self, motion: Motion, what: str) -> str | None:
        """`check_clip` for a clip with every model joint."""
        rest = self.rest_pose(motion)
        if rest is not None:
            degrees = rest_degrees(rest)
            said = (
                "it rests standing, where the model's rest does not: read re-posed from the model's typical pose "
                "turned onto its bones (the twist of a bone about itself, which no rest tells, is that pose's)"
                if self.rest_from_typical_pose(motion)
                else f"its rest pose differs from the model's (its {motion.skeleton.names[int(np.argmax(degrees))]}'s "
                f"bones turned {degrees.max():.0f} degrees): read re-posed onto the model's"
            )
            return _also(
                f"note: {what}: {said}, the same world motion, and written back in its own",
                self._check(frames_reposed(motion.slice(0, 1), rest), what),
                what,
            )
        try:
            return self._check(motion, what)
        except SkeletonMismatchError:
            turn = self.rest_turn(motion)
            if turn is None:
                raise
            return _also(
                f"note: {what}: every joint's axes are turned from the model's (an exporter's own axes): read "
                "in the model's axes and written back in its own",
                self._check(frames_turned(motion.slice(0, 1), turn), what),
                what,
            )

    def _check(self, motion: Motion, what: str) -> str | None:
        """`check_clip` for a clip in the model's axes."""
        joints = model_joints_in(self.skeleton, motion.skeleton)
        if joints is not None:  # the model's joints and more: read on the model's alone
            names = motion.skeleton.names
            folded = folded_joints(motion.skeleton, joints)
            extra = [name for joint, name in enumerate(names) if joint not in joints and joint not in folded]
            said = [
                f"{len(extra)} joint(s) the model does not have ({_listed(extra)}): the transfer reads the "
                "model's joints and the output carries these as the clip performs them"
            ] if extra else []  # fmt: skip
            if folded:
                said.append(
                    f"{len(folded)} joint(s) between two of the model's ({_listed([names[j] for j in folded])}): "
                    "the model reads each such chain as one bone, and the output turns them as the clip does"
                )
            if not said:
                said.append(
                    "its joints are listed in another order than the model's: read in the model's order and "
                    "written in its own"
                )
            return _also(
                f"note: {what}: " + "; ".join(said),
                self._check(without_extra_joints(motion, joints), what),
                what,
            )
        if self.skeleton.same_as(motion.skeleton):
            if same_rest_pose(self.skeleton, motion.skeleton):
                return None
            raise _rest_pose_error(what, "the model's joints")
        if same_structure(self.skeleton, motion.skeleton):
            renamed = next(
                (theirs, ours)
                for theirs, ours in zip(motion.skeleton.names, self.skeleton.names)
                if theirs != ours
            )
            return (
                f"note: {what}: joint names differ from the model's ({renamed[0]} for {renamed[1]}, ...), but "
                "its hierarchy and limbs are the model's: read joint by joint in that order"
            )
        rooted = with_added_roots(self.skeleton, motion)
        if rooted is not None:
            added = self.skeleton.num_joints - motion.skeleton.num_joints
            return _also(
                f"note: {what}: the model's skeleton without {', '.join(self.skeleton.names[:added])} above "
                f"{motion.skeleton.names[0]}: read with it added at rest, and written without it",
                self._check(rooted, what),  # under other names too
                what,
            )
        # the model's hierarchy under other names, or without its static root, but bones pointing other ways
        posed = with_added_roots(self.skeleton, motion, rest_pose=False) or motion
        if same_structure(self.skeleton, posed.skeleton, rest_pose=False) or (
            posed is not motion and self.skeleton.same_as(posed.skeleton)
        ):
            raise _rest_pose_error(
                what,
                "the model's skeleton"
                + (" under other joint names" if not self.skeleton.same_as(posed.skeleton) else ""),
            )
        try:
            self.skeleton.check_same(motion.skeleton, "the model", what)
        except SkeletonMismatchError as error:
            raise SkeletonMismatchError(f"{error}; {self._other_skeleton_advice(motion)}") from None
        return None  # check_same passed: the same names in the same hierarchy

    def _other_skeleton_advice(self, motion: Motion) -> str:
        """What to do with a clip this model cannot read: the shipped model reads it (a model of the user's
        own rig given with a clip of the dataset's), else train a model for its skeleton."""
        shipped = load_model()
        if not shipped.skeleton.same_as(self.skeleton):
            try:
                shipped.check_clip(motion, "clip")
                return (
                    "the shipped model reads this skeleton: leave out --model (in Python, model=None) for it"
                )
            except SkeletonMismatchError:
                pass
        return (
            "for this skeleton, train a model on its clips with 'elastyle train CLIPS -o model.npz --recipe "
            "shipped --minutes 20' and pass it with --model model.npz"
        )


# a clip whose bones at rest point within this of the model's (degrees; each joint's best turn) is read as it is
REPOSE_DEGREES = 2.0
# ... and one whose bones turn further than this is not re-posed: a bone's direction leaves its twist about it
# open, so the least turn reads a chain set far otherwise with twists the model never saw (a rig whose rest is
# its first frame, its chest 129 degrees off, was read with 24.5 cm mean joint error against 0.1); an A-pose's
# arms turn about 45
REPOSE_MOST_DEGREES = 90.0
# ... and a rig that stands at rest is read from the model's typical pose where no joint turns further than this
# from it (a T-pose's arms turn about 80 degrees from the typical pose's hanging ones)
POSED_MOST_DEGREES = 120.0


def _listed(names: list[str], most: int = 4) -> str:
    """Up to `most` names, comma-separated, then an ellipsis where there are more."""
    return ", ".join(names[:most]) + (", ..." if len(names) > most else "")


def _model_joints(model: Skeleton, clip: Skeleton) -> tuple[IntArray, int] | None:
    """Each model joint's clip joint (J_model - first,) from the model's joint `first` on (the model's static
    joints above the clip's root left out), where the clip is the model's hierarchy, with extra joints or
    joints in another order or not; None for another hierarchy."""
    joints = model_joints_in(model, clip)
    if joints is not None:
        return joints, model.num_joints - len(joints)
    first = model.num_joints - clip.num_joints
    if first < 0 or first > model.pelvis:
        return None
    below = np.where(model.parents[first:] >= first, model.parents[first:] - first, -1)
    return (np.arange(clip.num_joints), first) if np.array_equal(clip.parents, below) else None


# per model skeleton, per clip skeleton: a turn found for it once (`StyleModel.rest_turn`, `.rest_pose`)
Found = TypeVar("Found")
_PerSkeleton = weakref.WeakKeyDictionary[Skeleton, weakref.WeakKeyDictionary[Skeleton, tuple[Found | None]]]


class _RestReading(NamedTuple):
    """How a clip's rest pose is read (`StyleModel.rest_pose`): the turns (J, 3, 3) of its joints' frames,
    and whether they start from the model's typical pose."""

    turns: FloatArray
    from_pose: bool


_REST_POSES: _PerSkeleton[_RestReading] = weakref.WeakKeyDictionary()  # the turns of its joints' frames
_REST_TURNS: _PerSkeleton[FloatArray] = weakref.WeakKeyDictionary()  # the turn of its axes
_COMPLETIONS: _PerSkeleton[Completion] = weakref.WeakKeyDictionary()  # the model's joints it lacks


def _once_per_skeleton(
    cache: _PerSkeleton[Found], model: Skeleton, motion: Motion, find: Callable[[Motion], Found | None]
) -> Found | None:
    """`find` of the clip's first frame (one is enough: it decides by the skeleton alone), once per model
    skeleton and clip skeleton."""
    known = cache.setdefault(model, weakref.WeakKeyDictionary())
    if motion.skeleton not in known:
        known[motion.skeleton] = (find(motion.slice(0, 1)),)
    return known[motion.skeleton][0]


def _rest_pose_error(what: str, skeleton: str) -> RestPoseError:
    """The error for a clip of the model's hierarchy (`skeleton` says how: its joints, under other names)
    whose bones point other ways at rest."""
    return RestPoseError(
        f"{what}: {skeleton}, but another rest pose (its bones point other ways at rest, so its rotations mean "
        "other poses): export it in the model's rest pose, or train a model on its clips with 'elastyle train "
        "CLIPS -o model.npz --recipe shipped --minutes 20' and pass it with --model"
    )


def _also(note: str, other: str | None, what: str) -> str:
    """One note on a clip followed by another on it (`check_clip`'s), if any, without its repeated prefix."""
    return note if other is None else f"{note}; {other.removeprefix(f'note: {what}: ')}"


def save_model(path: str | os.PathLike[str], model: StyleModel, force: bool = False) -> None:
    """Write a model file atomically (refusing to overwrite unless `force`)."""
    skeleton = model.skeleton
    arrays: dict[str, Any] = {
        "format_version": np.array(FORMAT_VERSION),
        "config": np.array(json.dumps(asdict(model.config))),
        "metadata": np.array(json.dumps(model.metadata)),
        "fps": np.array(model.fps),
        "joint_names": np.array(skeleton.names),
        "joint_parents": skeleton.parents,
        "joint_offsets": skeleton.offsets,
        "end_sites": skeleton.end_sites,
        "reference_rotations": model.features.reference_rotations,
        "forward_local": model.features.forward_local,
        "feature_mean": model.feature_mean,
        "feature_std": model.feature_std,
    }
    for name in _WEIGHT_NAMES:
        value = getattr(model.autoencoder.weights, name)
        if value is not None:
            arrays[f"weight_{name}"] = value
    buffer = BytesIO()
    np.savez(buffer, **arrays)  # uncompressed: float weights shrink by 7% compressed, and load 3x slower
    write_bytes_atomic(path, buffer.getvalue(), force=force)


def default_model_path() -> Path:
    """The pretrained model shipped inside the package (package data beside the modules; resolving it by
    path skips importlib.resources, a few milliseconds of every command's start-up)."""
    return Path(__file__).resolve().parent.parent / "pretrained" / PRETRAINED_NAME


def as_model(model: StyleModel | str | os.PathLike[str] | None) -> StyleModel:
    """A model as given, or loaded from a model file's path (the shipped model for None); a `TypeError`
    naming anything else."""
    if isinstance(model, StyleModel):
        return model
    if model is None or isinstance(model, (str, os.PathLike)):
        return load_model(model)
    raise TypeError(
        f"model must be a StyleModel or a model file's path, got {type(model).__name__} {model!r:.60}"
    )


def _checkpoint_error(path: Path) -> ModelError:
    return ModelError(
        f"{path}: a training checkpoint, not a model: `elastyle train CLIPS -o MODEL.npz --resume {path}` "
        "continues it, and the model is the file it writes"
    )


def load_model(path: str | os.PathLike[str] | None = None) -> StyleModel:
    """Load a model file (the shipped pretrained model when `path` is None); `ModelError` if unusable."""
    if path is not None and not str(path).strip():
        raise ModelError("the model's path is empty; give a model file (.npz), or none for the shipped model")
    path = default_model_path() if path is None else Path(path)
    problem = input_problem(path)
    if problem is not None:
        raise ModelError(f"{path}: {'no such model file' if problem == 'no such file' else problem}")
    if path.suffix.lower() == ".ckpt":
        raise _checkpoint_error(path)
    try:
        with np.load(path, allow_pickle=False) as archive:
            data = {key: archive[key] for key in archive.files}
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as error:
        kind = "not an .npz archive" if isinstance(error, ValueError) else f"truncated or foreign: {error}"
        raise ModelError(f"{path}: not an elastyle model file ({kind})") from None
    if "format_version" not in data:
        if any(key.endswith("data.pkl") for key in data):
            raise _checkpoint_error(path)
        raise ModelError(f"{path}: not an elastyle model file (no format_version)")
    version = int(data["format_version"])
    if version != FORMAT_VERSION:
        raise ModelError(f"{path}: model format version {version}, this elastyle reads {FORMAT_VERSION}")
    try:
        config = ModelConfig(**json.loads(str(data["config"])))
        skeleton = Skeleton(
            tuple(str(n) for n in data["joint_names"]),
            data["joint_parents"].astype(np.int64),
            data["joint_offsets"],
            data["end_sites"],
        )
        spec = FeatureSpec(skeleton, data["reference_rotations"], data["forward_local"])
        weights = AutoencoderWeights(
            **{n: data[f"weight_{n}"] for n in _WEIGHT_NAMES if f"weight_{n}" in data}
        )
        _check_arrays(data, config, len(skeleton.names))
        if spec.num_channels != data["feature_mean"].shape[0]:  # the skeleton read otherwise than in training
            raise ValueError(
                f"its skeleton gives {spec.num_channels} feature channels, its weights {data['feature_mean'].shape[0]}: "
                "train it again with this elastyle"
            )
        return StyleModel(
            config,
            spec,
            data["feature_mean"],
            data["feature_std"],
            Autoencoder(config, weights),
            float(data["fps"]),
            json.loads(str(data["metadata"])),
        )
    except (KeyError, TypeError, ValueError) as error:
        raise ModelError(f"{path}: incomplete or inconsistent model file ({error})") from None


def _check_arrays(data: dict[str, Any], config: ModelConfig, num_joints: int) -> None:
    """Every numeric array finite and of the shape the config implies; `ValueError` naming the first that
    is not (the loader turns it into a `ModelError` naming the file)."""
    for key, value in data.items():
        if value.dtype.kind == "f" and key != "end_sites" and not np.all(np.isfinite(value)):
            raise ValueError(f"{key} holds NaN or infinite values")
    if not (np.isfinite(float(data["fps"])) and 0 < float(data["fps"]) <= 10_000):
        raise ValueError(f"frame rate {float(data['fps'])} out of range")
    channels = data["feature_mean"].shape[0]
    expected = {
        "joint_parents": (num_joints,),
        "joint_offsets": (num_joints, 3),
        "reference_rotations": (num_joints, 3),
        "feature_std": (channels,),
        "weight_conv1": (config.hidden_channels, channels, config.kernel_frames),
        "weight_conv2": (config.latent_channels, config.hidden_channels, 1),
    }
    for key, shape in expected.items():
        if data[key].shape != shape:
            raise ValueError(f"{key} has shape {data[key].shape}, expected {shape}")
    if np.any(data["feature_std"] <= 0):
        raise ValueError("feature_std must be positive")
