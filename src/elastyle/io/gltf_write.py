"""glTF 2.0 out: a clip as a binary glTF (`.glb`) for engines, Blender and the web.

The skeleton becomes a node hierarchy (joint names kept, End Sites as `<joint>_end` leaves), a skin over
the joints with their inverse bind matrices (the rest pose: offsets, no rotation), and one animation with
a rotation track per joint and a translation track per joint whose translation moves, sampled at the
clip's frame times with linear interpolation. glTF wants metres and Y up: lengths are scaled from the
file's unit (`core.body.centimetres_per_unit`), and BVH is Y up already. Written with pygltflib.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from elastyle.core.body import centimetres_per_unit
from elastyle.core.motion import Motion
from elastyle.core.rotations import continuous_quats, to_quat
from elastyle.types import AnyFloatArray, FloatArray


def metres_per_unit(motion: Motion) -> float:
    """The scale from the clip's file unit to metres."""
    return centimetres_per_unit(motion.skeleton) / 100.0


def glb_bytes(motion: Motion) -> bytes:
    """The clip (T frames, J joints) as the bytes of a `.glb` file."""
    import pygltflib as gl

    scale = metres_per_unit(motion)
    skeleton = motion.skeleton
    blob = _Blob()
    translations = motion.translations * scale  # (T, J, 3)
    quats = continuous_quats(to_quat(motion.rotations), axis=0)  # (T, J, 4) x, y, z, w
    moving = np.ptp(translations, axis=0).max(axis=-1) > 0  # (J,) joints whose translation is animated
    # a joint's own translation: its bone offset where a track animates it (so the file keeps the rest pose:
    # a BVH read back from it has the pelvis's offset, not its first frame's place), else its one value
    rest = np.where(moving[:, None], skeleton.offsets * scale, translations[0])  # (J, 3)
    nodes = [
        gl.Node(name=name, translation=_floats(rest[j]), rotation=_floats(quats[0, j]), children=[])
        for j, name in enumerate(skeleton.names)
    ]
    for joint, parent in enumerate(skeleton.parents):
        if parent >= 0:
            nodes[int(parent)].children.append(joint)
    for joint, end in enumerate(skeleton.end_sites):
        if np.all(np.isfinite(end)):
            nodes[joint].children.append(len(nodes))
            nodes.append(gl.Node(name=f"{skeleton.names[joint]}_end", translation=_floats(end * scale)))
    world_rest = skeleton.rest_positions() * scale  # (J, 3) metres
    inverse_bind = np.tile(np.eye(4, dtype=np.float32), (skeleton.num_joints, 1, 1))
    inverse_bind[:, 3, :3] = -world_rest  # column-major: the translation is the last column
    times = np.arange(motion.num_frames, dtype=np.float64) / motion.fps
    time_accessor = blob.add(times.astype(np.float32)[:, None], gl.SCALAR, with_bounds=True)
    channels, samplers = [], []
    for joint in range(skeleton.num_joints):
        tracks = [("rotation", quats[:, joint], gl.VEC4)]
        if moving[joint]:
            tracks.append(("translation", translations[:, joint], gl.VEC3))
        for path, values, kind in tracks:
            samplers.append(
                gl.AnimationSampler(
                    input=time_accessor, output=blob.add(values, kind), interpolation="LINEAR"
                )
            )
            channels.append(
                gl.AnimationChannel(
                    sampler=len(samplers) - 1, target=gl.AnimationChannelTarget(node=joint, path=path)
                )
            )
    roots = [j for j, parent in enumerate(skeleton.parents) if parent < 0]
    document = gl.GLTF2(
        asset=gl.Asset(generator="elastyle", version="2.0"),
        scene=0,
        scenes=[gl.Scene(nodes=roots)],
        nodes=nodes,
        skins=[
            gl.Skin(
                name="skeleton",
                joints=list(range(skeleton.num_joints)),
                skeleton=roots[0],
                inverseBindMatrices=blob.add(inverse_bind.reshape(-1, 16), gl.MAT4),
            )
        ],
        # the frame rate also as a number: a one-frame clip's keyframe times cannot say it
        animations=[
            gl.Animation(name="motion", channels=channels, samplers=samplers, extras={"fps": motion.fps})
        ],
        accessors=blob.accessors,
        bufferViews=blob.views,
        buffers=[gl.Buffer(byteLength=len(blob.data))],
    )
    document.set_binary_blob(bytes(blob.data))
    return bytes(b"".join(document.save_to_bytes()))


class _Blob:
    """The binary chunk: float32 arrays (N, K) end to end (4-byte aligned), with a view and accessor each."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[Any] = []
        self.accessors: list[Any] = []

    def add(self, values: AnyFloatArray, kind: str, with_bounds: bool = False) -> int:
        import pygltflib as gl

        array = np.ascontiguousarray(values, dtype=np.float32)
        offset = len(self.data)
        self.data += array.tobytes()
        self.views.append(gl.BufferView(buffer=0, byteOffset=offset, byteLength=array.nbytes))
        bounds: dict[str, Any] = {}
        if with_bounds:
            bounds = {"min": array.min(axis=0).tolist(), "max": array.max(axis=0).tolist()}
        self.accessors.append(
            gl.Accessor(
                bufferView=len(self.views) - 1,
                componentType=gl.FLOAT,
                count=array.shape[0],
                type=kind,
                **bounds,
            )
        )
        return len(self.accessors) - 1


def _floats(values: FloatArray) -> list[float]:
    return [float(v) for v in values]
