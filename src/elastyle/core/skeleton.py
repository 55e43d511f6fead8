"""The skeleton: joint names, hierarchy and rest offsets, plus forward kinematics."""

from __future__ import annotations

import numbers
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from elastyle.core.rotations import to_matrix
from elastyle.errors import SkeletonMismatchError
from elastyle.types import FloatArray, IntArray

# Left/right markers in joint names (group 1 is the side word): _L/.L suffixes, L_/L. prefixes and Left/Right
# in any letter case, and a capital L/R before a capital letter (LHipJoint, RThumb).
_SIDE_PATTERNS = (
    re.compile(r"[_.](l|r)$", re.IGNORECASE),
    re.compile(r"^(l|r)[_.]", re.IGNORECASE),
    re.compile(r"(left|right)", re.IGNORECASE),
    re.compile(r"^(L|R)(?=[A-Z])"),  # CMU: LHipJoint, RThumb
    re.compile(r"(?:^|(?<=\s))(L|R)(?=\s|$)"),  # 3ds Max biped: "Bip01 L Thigh", also "L Thigh"
    re.compile(r"(?<=[a-z])(L|R)$"),  # camel-case suffix: UpperLegL
)
_OPPOSITE_SIDE = {"l": "r", "r": "l", "left": "right", "right": "left"}


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy in file order.

    names:   (J,) joint names, unique.
    parents: (J,) parent index per joint, -1 for the root; parents[j] < j.
    offsets: (J, 3) rest offset of each joint from its parent, in the file's length unit.
    end_sites: (J, 3) End Site offset of each joint (NaN where the joint has none).
    unit_cm: centimetres per file unit where the user or the file format stated the unit (`--units`; glTF:
             metres); None: guessed from the body's height (`core.body.centimetres_per_unit`).
    A skeleton is immutable (its arrays are read-only copies): lookups derived from it (pelvis, mirror pairs,
    limbs) are computed once.
    """

    names: tuple[str, ...]
    parents: IntArray
    offsets: FloatArray
    end_sites: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    unit_cm: float | None = None

    def __post_init__(self) -> None:
        # lists of names and numbers as a tuple and arrays, as `Motion` takes lists
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "offsets", np.array(self.offsets, dtype=np.float64))
        parents = np.asarray(self.parents)
        if parents.dtype.kind not in "iu":
            whole = parents.dtype.kind == "f" and np.all(
                np.isfinite(parents) & (parents == np.round(parents))
            )
            if not whole:
                raise ValueError(f"parents must be joint indices (integers), got {parents.dtype} values")
        object.__setattr__(self, "parents", parents.astype(np.int64))
        num_joints = len(self.names)
        if not all(isinstance(name, str) for name in self.names):
            raise ValueError("joint names must be strings")
        unnamed = [j for j, name in enumerate(self.names) if not name.strip() or "\n" in name or "\r" in name]
        if unnamed:
            raise ValueError(
                f"joint names must be non-empty and on one line: joint {unnamed[0]} is {self.names[unnamed[0]]!r}"
            )
        repeated = [name for name, count in Counter(self.names).items() if count > 1]
        if repeated:
            raise ValueError(
                f"joint names must be unique: {repeated[0]!r} names {Counter(self.names)[repeated[0]]} joints"
            )
        if self.parents.shape != (num_joints,):
            raise ValueError(f"parents must be ({num_joints},), got {self.parents.shape}")
        if self.offsets.shape != (num_joints, 3):
            raise ValueError(f"offsets must be ({num_joints}, 3), got {self.offsets.shape}")
        if num_joints and (self.parents[0] != -1 or np.any(self.parents[1:] >= np.arange(1, num_joints))):
            raise ValueError("parents must satisfy parents[0] == -1 and parents[j] < j")
        if not np.all(np.isfinite(self.offsets)):
            joint = int(np.flatnonzero(~np.all(np.isfinite(self.offsets), axis=1))[0])
            raise ValueError(
                f"offsets must be finite numbers: joint {self.names[joint]!r} has {self.offsets[joint]}"
            )
        end_sites = np.array(self.end_sites, dtype=np.float64)
        if end_sites.size == 0:  # none given
            end_sites = np.full((num_joints, 3), np.nan)
        if end_sites.shape != (num_joints, 3):
            raise ValueError(
                f"end_sites must be ({num_joints}, 3) (NaN where a joint has none), got {end_sites.shape}"
            )
        object.__setattr__(self, "end_sites", end_sites)
        unit = self.unit_cm
        if unit is not None and (
            isinstance(unit, bool) or not isinstance(unit, numbers.Real) or not (0 < unit < np.inf)
        ):
            raise ValueError(
                f"unit_cm must be a positive finite number of centimetres per unit, or None; got {unit!r}"
            )
        for array in (self.parents, self.offsets, self.end_sites):
            array.setflags(write=False)

    def __setstate__(self, state: dict[str, object]) -> None:
        """Unpickled (a batch's worker process) read-only as built: pickling keeps no array flags."""
        self.__dict__.update(state)
        for array in (self.parents, self.offsets, self.end_sites):
            array.setflags(write=False)

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def __repr__(self) -> str:
        shown = ", ".join(self.names[:4]) + (", ..." if self.num_joints > 4 else "")
        return f"Skeleton({self.num_joints} joints: {shown})"

    def children(self, joint: int) -> list[int]:
        return [int(j) for j in np.flatnonzero(self.parents == joint)]

    def offset_from(self, ancestor: int, joint: int) -> FloatArray:
        """(3,) the joint's rest place from its ancestor's (file units): the offsets between them added (the
        joint's own offset where `ancestor` is its parent)."""
        offset = np.zeros(3)
        while joint != ancestor:
            offset = offset + self.offsets[joint]
            joint = int(self.parents[joint])
        return offset

    def with_ancestors(self, joints: Sequence[int] | IntArray | None) -> IntArray:
        """The joints and every joint above them, sorted (parents first); None: all joints."""
        if joints is None:
            return np.arange(self.num_joints)
        needed = np.zeros(self.num_joints, dtype=bool)
        for joint in np.asarray(joints, dtype=np.int64).ravel().tolist():
            while joint >= 0 and not needed[joint]:
                needed[joint] = True
                joint = int(self.parents[joint])
        return np.flatnonzero(needed)

    @cached_property
    def levels(self) -> tuple[IntArray, ...]:
        """The joints below a root (a joint without a parent) by depth in the tree: the roots' children (n1,),
        theirs (n2,), ..."""
        depth = np.zeros(self.num_joints, dtype=np.int64)
        for joint, parent in enumerate(self.parents.tolist()):
            if parent >= 0:
                depth[joint] = depth[parent] + 1
        return tuple(np.flatnonzero(depth == level) for level in range(1, int(depth.max(initial=0)) + 1))

    @cached_property
    def pelvis(self) -> int:
        """The centre joint whose translation and heading carry the body: the first joint that branches."""
        for joint in range(self.num_joints):
            if len(self.children(joint)) >= 2:
                return joint
        return 0

    def index(self, name: str) -> int:
        return self.names.index(name)

    def same_as(self, other: Skeleton) -> bool:
        return self.names == other.names and bool(np.array_equal(self.parents, other.parents))

    def check_same(self, other: Skeleton, what: str, other_what: str) -> None:
        """Raise `SkeletonMismatchError` listing the joints that differ between two skeletons."""
        if self.same_as(other):
            return
        ours, theirs = set(self.names), set(other.names)
        parts = []
        for label, names in ((what, [n for n in self.names if n not in theirs]),
                             ("this clip", [n for n in other.names if n not in ours])):  # fmt: skip
            if names:
                parts.append(f"only in {label}: {', '.join(names[:8])}{' ...' if len(names) > 8 else ''}")
        if not parts:
            parts.append("same joints in a different order or hierarchy")
        raise SkeletonMismatchError(f"{other_what}: skeleton differs from {what} ({'; '.join(parts)})")

    def mirror_pairs(self) -> IntArray:
        """(J,) index of each joint's left/right partner (itself for centre joints), from joint names."""
        return self._sides[0]

    def unpaired_sides(self) -> list[str]:
        """Names of joints whose names say a side but that have no partner of the other side's name (a
        renamed hand): `mirror` reflects them in place instead of swapping them."""
        partner = self.mirror_pairs()
        return [
            name
            for j, name in enumerate(self.names)
            if partner[j] == j and any(pattern.search(name) for pattern in _SIDE_PATTERNS)
        ]

    def named_side(self, joint: int) -> int:
        """+1 where the joint's name says left, -1 right, 0 neither, whether or not a partner of the other
        side's name exists (`sides` counts only joints with one)."""
        for pattern in _SIDE_PATTERNS:
            match = pattern.search(self.names[joint])
            if match is not None:
                return 1 if match.group(1).lower() in ("l", "left") else -1
        return 0

    def sides(self) -> IntArray:
        """(J,) +1 for a left joint, -1 for a right joint, 0 for a centre joint (one without a partner)."""
        return self._sides[1]

    @cached_property
    def _sides(self) -> tuple[IntArray, IntArray]:
        """The one left/right finder: partners and sides from the side markers of `_SIDE_PATTERNS`."""
        partner = np.arange(self.num_joints)
        side = np.zeros(self.num_joints, dtype=np.int64)
        lookup = {name: j for j, name in enumerate(self.names)}
        for j, name in enumerate(self.names):
            for pattern in _SIDE_PATTERNS:
                match = pattern.search(name)
                if match is None:
                    continue
                other = name[: match.start(1)] + _opposite_side(match.group(1)) + name[match.end(1) :]
                if lookup.get(other, j) != j:
                    partner[j] = lookup[other]
                    side[j] = 1 if match.group(1).lower() in ("l", "left") else -1
                    break
        partner.flags.writeable = False  # shared by every caller
        side.flags.writeable = False
        return partner, side

    def rest_positions(self) -> FloatArray:
        """World positions (J, 3) of the joints with every rotation zero."""
        return self._rest_positions

    @cached_property
    def _rest_positions(self) -> FloatArray:
        positions = np.zeros((self.num_joints, 3))
        for joint in range(self.num_joints):
            parent = self.parents[joint]
            positions[joint] = self.offsets[joint] + (positions[parent] if parent >= 0 else 0.0)
        positions.flags.writeable = False  # shared by every caller
        return positions

    def height(self) -> float:
        """Vertical extent (Y) of the rest pose, in the file's length unit."""
        positions = self.rest_positions()
        return float(np.ptp(positions[:, 1]))

    def scaled(self, factor: float) -> Skeleton:
        """This skeleton `factor` times as large (offsets and End Sites; a stated unit follows, so the same
        centimetres are meant; `core.body.at_size_of` sets the reference's instead)."""
        unit_cm = None if self.unit_cm is None else self.unit_cm / factor
        return replace(
            self, offsets=self.offsets * factor, end_sites=self.end_sites * factor, unit_cm=unit_cm
        )


def bare_name(name: str) -> str:
    """A joint name without an exporter's namespace (`Character1:Hips` -> `Hips`)."""
    return name.rsplit(":", 1)[-1]


def _opposite_side(word: str) -> str:
    """'L' -> 'R', 'left' -> 'right', 'Right' -> 'Left', keeping the letter case."""
    opposite = _OPPOSITE_SIDE[word.lower()]
    if word.isupper():
        return opposite.upper()
    if word[0].isupper():
        return opposite.capitalize()
    return opposite


def forward_kinematics(
    skeleton: Skeleton,
    local_rotations: FloatArray,
    local_translations: FloatArray,
    joints: Sequence[int] | IntArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Global joint transforms.

    local_rotations: (T, J, 3) exp maps; local_translations: (T, J, 3) file units.
    joints: only these joints (and their ancestors) are computed, the others are NaN; None: every joint.
    Returns world rotation matrices (T, J, 3, 3) and world positions (T, J, 3) in file units.
    """
    expected = (skeleton.num_joints, 3)
    for name, values in (("local_rotations", local_rotations), ("local_translations", local_translations)):
        if np.ndim(values) != 3 or np.shape(values)[1:] != expected:
            raise ValueError(f"{name} must be (T, {expected[0]}, 3), got {np.shape(values)}")
    if joints is not None and np.any((np.asarray(joints) < 0) | (np.asarray(joints) >= skeleton.num_joints)):
        raise ValueError(f"joints must be indices from 0 to {skeleton.num_joints - 1}, got {list(joints)}")
    needed = skeleton.with_ancestors(joints)
    num_frames = local_rotations.shape[0]
    world_matrices = np.full((num_frames, skeleton.num_joints, 3, 3), np.nan)
    world_positions = np.full((num_frames, skeleton.num_joints, 3), np.nan)
    world_matrices[:, needed] = to_matrix(local_rotations[:, needed])  # local for now, (T, n, 3, 3)
    world_positions[:, needed] = local_translations[:, needed]
    is_needed = np.zeros(skeleton.num_joints, dtype=bool)
    is_needed[needed] = True
    # one tree level at a time: every joint of a level below its parent, whose level is done
    for level in skeleton.levels:
        level = level[is_needed[level]]
        if not len(level):
            continue
        parent_matrices = world_matrices[:, skeleton.parents[level]]  # (T, n, 3, 3)
        world_positions[:, level] = world_positions[:, skeleton.parents[level]] + np.einsum(
            "tnij,tnj->tni", parent_matrices, world_positions[:, level]
        )
        world_matrices[:, level] = parent_matrices @ world_matrices[:, level]
    return world_matrices, world_positions


def check_mirrorable(skeleton: Skeleton) -> IntArray:
    """Partner indices (J,), or `SkeletonMismatchError` when no left/right joint pairs are recognisable."""
    partner = skeleton.mirror_pairs()
    if np.all(partner == np.arange(skeleton.num_joints)):
        raise SkeletonMismatchError(
            "cannot mirror: no left/right joint pairs found in the joint names "
            "(expected markers such as _L/_R, Left/Right, l_/r_ or .L/.R)"
        )
    return partner
