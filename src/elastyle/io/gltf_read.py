"""glTF 2.0 in: a skinned, animated `.glb` as a `Motion` (what `io.gltf_write` writes, and what engines and
Blender export), so `.glb` clips can be viewed, converted and transferred like BVH.

The first skin's joints are the skeleton (in their order where each follows its parent, else depth first),
each joint's rest translation its offset, its root under the rotations of the nodes above it (an
exporter's Armature); the first animation's rotation and translation tracks animate them, on the keyframe
times of the track with the most keys (which must be evenly spaced: the frame rate), a track with fewer
read between its own keys (linear, slerp, or held for STEP). Lengths stay in metres.
"""

from __future__ import annotations

import logging
import struct
from typing import Any

import numpy as np

from elastyle.core.body import UNITS
from elastyle.core.motion import Motion
from elastyle.core.resample import interpolate_rows
from elastyle.core.rotations import from_matrix, from_quat, quat_to_matrix, slerp_resample, to_matrix
from elastyle.core.skeleton import Skeleton
from elastyle.errors import BvhError
from elastyle.io.bvh_read import frame_rate
from elastyle.types import FloatArray

log = logging.getLogger("elastyle")
_WIDTH = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}


GLB_HEADER_BYTES = 12  # magic 'glTF', version, total length (little-endian 32-bit words)


def _header_problem(data: bytes) -> str | None:
    """What is wrong with a binary glTF file's 12-byte header (its magic, version and length), if anything."""
    if data[:4] != b"glTF":
        return "not a binary glTF file (it does not start with 'glTF')"
    if len(data) < GLB_HEADER_BYTES:
        return f"cut short: {len(data)} bytes, shorter than a binary glTF header"
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        return f"binary glTF version {version}; only version 2 is read"
    if len(data) < length:
        return f"cut short: {len(data)} of the {length} bytes its header gives"
    return None


def parse_glb(data: bytes, name: str) -> Motion:
    """A `.glb` file's bytes as a clip; `BvhError` naming the file when it is not a usable animation."""
    import pygltflib as gl

    problem = _header_problem(data)
    if problem is not None:
        raise BvhError(name, problem)
    try:
        document = gl.GLTF2.load_from_bytes(data)
    except Exception as error:  # pygltflib raises bare exceptions of many kinds on damaged files
        raise BvhError(name, f"a damaged binary glTF file: {str(error) or type(error).__name__}") from None
    if not document.skins or not document.animations:
        raise BvhError(name, "a glTF file needs a skin (the skeleton) and an animation")
    joints = _parents_first(document, list(document.skins[0].joints))
    index = {node: j for j, node in enumerate(joints)}
    parents = np.full(len(joints), -1, dtype=np.int64)
    for node, j in index.items():
        for child in document.nodes[node].children or []:
            if child in index:
                parents[index[child]] = j
    nodes = [document.nodes[node] for node in joints]
    offsets = np.array([node.translation or [0.0, 0.0, 0.0] for node in nodes], dtype=np.float64)
    rest_rotations = np.array([node.rotation or [0.0, 0.0, 0.0, 1.0] for node in nodes], dtype=np.float64)
    animation = document.animations[0]
    if len(document.animations) > 1:
        log.info(
            "note: %s holds %d animations: the first, %r, is read", name, len(document.animations),
            animation.name or "unnamed",
        )  # fmt: skip
    tracks = [
        channel for channel in animation.channels
        if channel.target.node in index and channel.target.path in ("rotation", "translation")
    ]  # fmt: skip
    if not tracks:
        raise BvhError(name, "the animation moves none of the skin's joints")
    scaling = [
        channel for channel in animation.channels
        if channel.target.node in index and channel.target.path == "scale"
        and not np.allclose(_accessor(document, animation.samplers[channel.sampler].output, name), 1.0)
    ]  # fmt: skip
    if scaling:
        log.info(
            "note: %s: the scale tracks of %d joint(s) (%s) are not read: every bone keeps its length",
            name, len(scaling), document.nodes[scaling[0].target.node].name or "unnamed",
        )  # fmt: skip
    # the frames: the keys of the track with the most (an exporter keeps two of a track that holds still)
    key_times = [_accessor(document, animation.samplers[track.sampler].input, name)[:, 0] for track in tracks]
    times = max(key_times, key=len)
    fps = _frame_rate(times, animation.extras, name)
    frames = len(times)
    rotations = np.broadcast_to(from_quat(rest_rotations), (frames, len(joints), 3)).copy()
    translations = np.broadcast_to(offsets, (frames, len(joints), 3)).copy()
    for track, own_times in zip(tracks, key_times):
        joint = index[track.target.node]
        sampler = animation.samplers[track.sampler]
        values = _accessor(document, sampler.output, name)
        if sampler.interpolation == "CUBICSPLINE" and len(values) == 3 * len(own_times):
            values = values[1::3]  # each key's value between its tangents
        if len(values) != len(own_times):
            raise BvhError(
                name,
                f"a track of joint {nodes[joint].name!r} has {len(values)} values for {len(own_times)} keys",
            )
        if track.target.path == "rotation":
            values = from_quat(values / np.linalg.norm(values, axis=-1, keepdims=True))
        if len(own_times) != frames or not np.allclose(own_times, times):  # on the frames, between its keys
            at = np.interp(times, own_times, np.arange(len(own_times)))  # (T,) fractional key indices
            at = np.floor(at) if sampler.interpolation == "STEP" else at
            values = (
                slerp_resample(values[:, None], at)[:, 0]
                if track.target.path == "rotation"
                else interpolate_rows(values, at)
            )
        if track.target.path == "rotation":
            rotations[:, joint] = values
        else:
            translations[:, joint] = values
    _under_nodes_above(document, joints[0], rotations, translations, offsets)
    # a name on one line (a BVH file holds it on one), and one for a node without any
    names = tuple(" ".join((node.name or "").split()) or f"joint{j}" for j, node in enumerate(nodes))
    repeated = next((joint for j, joint in enumerate(names) if joint in names[:j]), None)
    if repeated is not None:
        raise BvhError(name, f"duplicate joint name {repeated!r}")
    end_sites = np.full((len(joints), 3), np.nan)
    for j, node in enumerate(nodes):  # a child node outside the skin: an End Site (as io.gltf_write writes)
        leaves = [c for c in node.children or [] if c not in index]
        if leaves:
            end_sites[j] = document.nodes[leaves[0]].translation or [0.0, 0.0, 0.0]
    # glTF's unit is the metre, unless a node scales it (an exporter's 0.01 on an armature over centimetres,
    # which this reader does not apply): then the unit is guessed, or stated with --units, as for a BVH
    scaled = any(node.scale is not None and list(node.scale) != [1.0, 1.0, 1.0] for node in document.nodes)
    skeleton = Skeleton(names, parents, offsets, end_sites, unit_cm=None if scaled else UNITS["m"])
    return Motion(skeleton, rotations, translations, fps)


def _parents_first(document: Any, joints: list[int]) -> list[int]:
    """A skin's joint nodes, each after its parent: in the skin's order where it lists them so, else depth
    first from its top joints, children in the skin's order (the glTF format lets a skin list them in any
    order)."""
    listed = set(joints)
    children: dict[int, list[int]] = {node: [] for node in joints}
    has_parent: set[int] = set()
    for node in joints:
        for child in document.nodes[node].children or []:
            if child in listed:
                children[node].append(child)
                has_parent.add(child)
    position = {node: j for j, node in enumerate(joints)}
    if all(position[parent] < position[child] for parent in joints for child in children[parent]):
        return joints  # listed parents first already: kept as it is
    order: list[int] = []
    stack = [node for node in reversed(joints) if node not in has_parent]
    while stack:
        node = stack.pop()
        order.append(node)
        stack.extend(sorted(children[node], key=position.__getitem__, reverse=True))
    return order


def _under_nodes_above(
    document: Any, root: int, rotations: FloatArray, translations: FloatArray, offsets: FloatArray
) -> None:
    """The skin's root joint (node `root`), its rotations (T, J, 3) and translations (T, J, 3) in place and its
    rest offset, placed under the nodes above it that are no joints (an exporter's Armature, turned a quarter
    to stand a Z-up rig along +Y): their rotations taken in, and their translations where no node scales (a
    scale is the unit, guessed, and the lengths stay the joints' own)."""
    parent_of = {child: node for node, entry in enumerate(document.nodes) for child in entry.children or []}
    turn, shift, scaled = np.eye(3), np.zeros(3), False
    node = parent_of.get(root)
    while node is not None:  # from the root's parent up: each node's transform before the ones below it
        entry = document.nodes[node]
        scaled |= entry.scale is not None and list(entry.scale) != [1.0, 1.0, 1.0]
        quaternion = np.asarray(entry.rotation or [0.0, 0.0, 0.0, 1.0], dtype=np.float64)
        own = quat_to_matrix(quaternion / np.linalg.norm(quaternion))
        shift = own @ shift + np.asarray(entry.translation or [0.0, 0.0, 0.0], dtype=np.float64)
        turn = own @ turn
        node = parent_of.get(node)
    if np.allclose(turn, np.eye(3)) and (scaled or not np.any(shift)):
        return
    rotations[:, 0] = from_matrix(turn @ to_matrix(rotations[:, 0]))
    placed = np.zeros(3) if scaled else shift
    translations[:, 0] = translations[:, 0] @ turn.T + placed
    offsets[0] = turn @ offsets[0] + placed


# keyframe times may stray this share of a frame from an even grid: float32 times of an hour at 120 fps
# stray under 2 % of a frame (their rounding), a dropped or doubled frame 50 % or more
SPACING_TOLERANCE = 0.1
ONE_FRAME_FPS = 30.0  # the frame rate of a one-frame animation that does not state one


def _frame_rate(times: FloatArray, extras: Any, name: str) -> float:
    """The frame rate of keyframe times (N,) evenly spaced (a `BvhError` otherwise); a one-frame animation's
    from its `extras.fps` (elastyle writes it), else `ONE_FRAME_FPS`."""
    stated = extras.get("fps") if isinstance(extras, dict) else None
    if len(times) == 0:
        raise BvhError(name, "the animation has no keyframes")
    if len(times) == 1:
        return float(stated) if isinstance(stated, (int, float)) and stated > 0 else ONE_FRAME_FPS
    step = (times[-1] - times[0]) / (len(times) - 1)
    grid = times[0] + step * np.arange(len(times))
    if step <= 0 or np.max(np.abs(times - grid)) > SPACING_TOLERANCE * step:
        raise BvhError(name, "the animation's keyframes are not evenly spaced frames")
    return frame_rate(float(step))


def _accessor(document: Any, accessor_index: int, name: str) -> FloatArray:
    """A float accessor's values (N, width) from the binary chunk."""
    import pygltflib as gl

    accessor = document.accessors[accessor_index]
    if accessor.componentType != gl.FLOAT or accessor.type not in _WIDTH or accessor.bufferView is None:
        raise BvhError(name, f"an animation accessor of type {accessor.type} is not float32 data")
    view = document.bufferViews[accessor.bufferView]
    width = _WIDTH[accessor.type]
    start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
    stride = view.byteStride or 4 * width  # an interleaved view holds other accessors' values between rows
    blob = document.binary_blob() or b""
    if stride < 4 * width:
        raise BvhError(
            name, f"a buffer view's byteStride ({stride}) is shorter than its {accessor.type} values"
        )
    size = stride * (accessor.count - 1) + 4 * width if accessor.count else 0
    if len(blob) < start + size:
        raise BvhError(name, "the binary chunk is shorter than its accessors say (truncated?)")
    rows = np.ndarray((accessor.count, width), dtype="<f4", buffer=blob, offset=start, strides=(stride, 4))
    return rows.astype(np.float64)
