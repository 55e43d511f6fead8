"""glTF out, read back by an independent reader (pygltflib) and posed with plain matrix arithmetic here:
every joint where elastyle's forward kinematics puts it, in metres, at every checked frame."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from elastyle import read_bvh
from elastyle.core.motion import Motion
from elastyle.io.clip_write import write_clip
from elastyle.io.dataset import ClipRef
from elastyle.io.gltf_write import metres_per_unit
from tests.conftest import clip_named

COMPONENTS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _accessor(document: pygltflib.GLTF2, index: int) -> np.ndarray:
    accessor = document.accessors[index]
    view = document.bufferViews[accessor.bufferView]
    assert accessor.componentType == pygltflib.FLOAT
    start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
    width = COMPONENTS[accessor.type]
    data = document.binary_blob()[start : start + 4 * width * accessor.count]
    return np.frombuffer(data, dtype="<f4").reshape(accessor.count, width).astype(np.float64)


def _matrix(translation: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
    x, y, z, w = quaternion / np.linalg.norm(quaternion)
    rotation = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = rotation, translation
    return matrix


def _posed_joint_positions(path: Path, frame: int) -> dict[str, np.ndarray]:
    """World position (metres) of every skin joint at keyframe `frame`, from the file alone."""
    document = pygltflib.GLTF2().load(str(path))
    local = {
        index: [
            np.array(node.translation or [0, 0, 0], float),
            np.array(node.rotation or [0, 0, 0, 1], float),
        ]
        for index, node in enumerate(document.nodes)
    }
    animation = document.animations[0]
    for channel in animation.channels:
        sampler = animation.samplers[channel.sampler]
        values = _accessor(document, sampler.output)
        slot = {"translation": 0, "rotation": 1}[channel.target.path]
        local[channel.target.node][slot] = values[frame]
    world: dict[int, np.ndarray] = {}

    def visit(index: int, parent: np.ndarray) -> None:
        world[index] = parent @ _matrix(*local[index])
        for child in document.nodes[index].children or []:
            visit(child, world[index])

    for root in document.scenes[document.scene].nodes:
        visit(root, np.eye(4))
    return {document.nodes[j].name: world[j][:3, 3] for j in document.skins[0].joints}


def _check(motion: Motion, path: Path) -> None:
    write_clip(path, motion)
    document = pygltflib.GLTF2().load(str(path))
    times = _accessor(document, document.animations[0].samplers[0].input)[:, 0]
    np.testing.assert_allclose(times, np.arange(motion.num_frames) / motion.fps, atol=1e-5)
    scale = metres_per_unit(motion)
    positions = motion.positions() * scale  # (T, J, 3) metres, elastyle's forward kinematics
    for frame in sorted({0, motion.num_frames // 3, 2 * motion.num_frames // 3, motion.num_frames - 1}):
        posed = _posed_joint_positions(path, frame)
        assert list(posed) == list(motion.skeleton.names)
        ours = np.array([posed[name] for name in motion.skeleton.names])
        assert np.abs(ours - positions[frame]).max() <= 1e-4, frame  # 0.01 cm


@pytest.mark.slow
def test_a_dataset_clip_and_a_transfer_read_back_where_the_bvh_puts_them(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005")
    _check(walk.read()[0], tmp_path / "walk.glb")
    style = clip_named(dataset_clips, "dataset-2_walk_active_010").name
    out = tmp_path / "styled.glb"
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "transfer", walk.name, "--style", style, "-o", str(out)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert pygltflib.GLTF2().load(str(out)).animations[0].channels


def test_a_batch_writes_glb_where_asked(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    """-o DIR/ wrote BVH only; --output-format glb names each output .glb, as one output named so is."""
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    run = clip_named(dataset_clips, "dataset-2_run_normal_010").name
    style = clip_named(dataset_clips, "dataset-2_walk_active_010").name

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "elastyle.cli", *args], capture_output=True, text=True)

    batch = cli("transfer", walk, run, "--style", style, "-o", f"{tmp_path}/out/", "--output-format", "glb")
    assert batch.returncode == 0, batch.stderr
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "dataset-2_run_normal_010.glb", "dataset-2_walk_normal_005.glb"
    ]  # fmt: skip
    assert cli("transfer", walk, "--style", style, "-o", str(tmp_path / "one.glb")).returncode == 0
    one, in_batch = (
        read_bvh(p)[0] for p in (tmp_path / "one.glb", tmp_path / "out/dataset-2_walk_normal_005.glb")
    )
    np.testing.assert_array_equal(one.rotations, in_batch.rotations)
    mismatch = cli(
        "transfer", walk, "--style", style, "-o", str(tmp_path / "x.bvh"), "--output-format", "glb"
    )
    assert mismatch.returncode == 2 and "name it x.glb" in mismatch.stderr


def test_glb_joint_names_of_spaces_or_two_lines_are_read(three_channel_bvh: Path, tmp_path: Path) -> None:
    """A node named with spaces only, or over two lines, ended in 'internal error' (the skeleton refuses such
    names, which no BVH file can hold): a blank name is made as a missing one is, line breaks become spaces."""
    motion, _ = read_bvh(three_channel_bvh)
    path = tmp_path / "clip.glb"
    write_clip(path, motion)
    document = pygltflib.GLTF2().load(str(path))
    named = [node for node in document.nodes if node.name in motion.skeleton.names]
    named[1].name, named[2].name = "   ", "Upper\nChest"
    document.save(str(path))
    names = read_bvh(path)[0].skeleton.names
    assert names[1] == "joint1" and names[2] == "Upper Chest"


def test_a_three_channel_clip_at_120_fps_in_its_own_unit(three_channel_bvh: Path, tmp_path: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    assert motion.fps == 120
    _check(motion, tmp_path / "tiny.glb")


def test_an_unknown_output_format_is_refused(three_channel_bvh: Path, tmp_path: Path) -> None:
    for name in ("clip.fbx", "clip"):
        result = subprocess.run(
            [sys.executable, "-m", "elastyle.cli", "convert", str(three_channel_bvh), "-o", str(tmp_path / name)],
            capture_output=True, text=True,
        )  # fmt: skip
        assert result.returncode == 2 and "name it .bvh or .glb" in result.stderr
        assert not (tmp_path / name).exists()


def test_glb_in_reads_back_what_glb_out_wrote(three_channel_bvh: Path, tmp_path: Path) -> None:
    from elastyle.io.dataset import read_clip

    motion, _ = read_bvh(three_channel_bvh)
    path = tmp_path / "tiny.glb"
    write_clip(path, motion)
    back, layout = read_clip(path)
    scale = metres_per_unit(motion)
    assert back.skeleton.names == motion.skeleton.names and back.fps == motion.fps
    np.testing.assert_array_equal(back.skeleton.parents, motion.skeleton.parents)
    np.testing.assert_allclose(back.positions(), motion.positions() * scale, atol=1e-6)
    np.testing.assert_allclose(back.skeleton.end_sites, motion.skeleton.end_sites * scale, atol=1e-6)
    # the rest pose kept: a moving joint's offset is its bone's, not its first frame's place
    np.testing.assert_allclose(back.skeleton.offsets, motion.skeleton.offsets * scale, atol=1e-6)
    assert layout.channels[0][:3] == ("Xposition", "Yposition", "Zposition")
    again = tmp_path / "again.bvh"
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "convert", str(path), "-o", str(again)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    np.testing.assert_allclose(read_bvh(again)[0].positions(), motion.positions() * scale, atol=1e-5)


@pytest.mark.parametrize("seconds, fps", [(70.0, 30.0), (18.0, 120.0), (None, 24.0)])
def test_long_and_one_frame_glb_read_back(three_channel_bvh: Path, tmp_path: Path, seconds, fps) -> None:  # type: ignore[no-untyped-def]
    """A clip over a minute at 30 fps (or 16 s at 120) has float32 keyframe times that stray from an even grid
    by more than the reader allowed, and a one-frame clip's times say no frame rate: both were written and
    then refused ('not evenly spaced')."""
    from elastyle.io.dataset import read_clip

    motion, _ = read_bvh(three_channel_bvh)
    count = 1 if seconds is None else int(seconds * fps)
    index = np.arange(count) % motion.num_frames
    clip = Motion(motion.skeleton, motion.rotations[index], motion.translations[index], fps)
    path = tmp_path / "clip.glb"
    write_clip(path, clip)
    back, _ = read_clip(path)
    assert back.num_frames == count and back.fps == fps
    np.testing.assert_allclose(back.positions(), clip.positions() * metres_per_unit(clip), atol=1e-6)


def test_a_damaged_glb_is_one_line(three_channel_bvh: Path, tmp_path: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    path = tmp_path / "cut.glb"
    write_clip(path, motion)
    path.write_bytes(path.read_bytes()[:300])
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "info", str(path)], capture_output=True, text=True
    )
    assert result.returncode == 1 and "cut.glb" in result.stderr and "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    assert "cut short: 300 of the" in result.stderr  # what is wrong, not an exception's class name
    path.write_bytes(b"\x89PNG" + bytes(400))
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "info", str(path)], capture_output=True, text=True
    )
    assert result.returncode == 1 and "does not start with 'glTF'" in result.stderr, result.stderr


def test_units_does_not_apply_to_glb_clips_which_are_metres(three_channel_bvh: Path, tmp_path: Path) -> None:
    from elastyle.core.body import centimetres_per_unit, in_units

    motion, layout = read_bvh(three_channel_bvh)
    target = tmp_path / "clip.glb"
    write_clip(target, motion, layout)
    read_back = read_bvh(target)[0]
    assert centimetres_per_unit(in_units(read_back, "cm").skeleton) == 100.0
    assert centimetres_per_unit(in_units(motion, "cm").skeleton) == 1.0  # a BVH takes the stated unit
    document = pygltflib.GLTF2().load(str(target))  # an exporter's scale on a node: the unit is not known
    document.nodes[0].scale = [0.01, 0.01, 0.01]
    document.save(str(target))
    assert read_bvh(target)[0].skeleton.unit_cm is None
    assert centimetres_per_unit(in_units(read_bvh(target)[0], "cm").skeleton) == 1.0


def test_a_gltf_json_file_and_scale_tracks_are_said(tmp_path: Path, three_channel_bvh: Path, caplog) -> None:  # type: ignore[no-untyped-def]
    """A .gltf was answered "not a BVH file: starts with '{'", and scale tracks were dropped without a word."""
    import logging

    from elastyle import BvhError
    from elastyle.io.dataset import read_clip

    (tmp_path / "walk.gltf").write_text('{"asset": {"version": "2.0"}}')
    with pytest.raises(
        BvhError, match="a .gltf \\(JSON\\) file: elastyle reads binary glTF; export it as .glb"
    ):
        read_clip(tmp_path / "walk.gltf")
    motion, _ = read_bvh(three_channel_bvh)
    path = tmp_path / "tiny.glb"
    write_clip(path, motion)
    document = pygltflib.GLTF2().load(str(path))
    animation = document.animations[0]
    first = animation.channels[0]
    blob = bytearray(document.binary_blob())
    twice = np.full((motion.num_frames, 3), 2.0)
    document.bufferViews.append(
        pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=twice.size * 4)
    )
    blob.extend(twice.astype("<f4").tobytes())
    document.accessors.append(
        pygltflib.Accessor(bufferView=len(document.bufferViews) - 1, componentType=pygltflib.FLOAT,
                           count=len(twice), type="VEC3")
    )  # fmt: skip
    sampler = animation.samplers[first.sampler]
    animation.samplers.append(
        pygltflib.AnimationSampler(input=sampler.input, output=len(document.accessors) - 1)
    )
    animation.channels.append(
        pygltflib.AnimationChannel(
            sampler=len(animation.samplers) - 1,
            target=pygltflib.AnimationChannelTarget(node=first.target.node, path="scale"),
        )
    )
    document.buffers[0].byteLength = len(blob)
    document.set_binary_blob(bytes(blob))
    scaled = tmp_path / "scaled.glb"
    document.save_binary(str(scaled))
    with caplog.at_level(logging.INFO, logger="elastyle"):
        read_clip(scaled)
    assert "the scale tracks of 1 joint(s)" in caplog.text and "every bone keeps its length" in caplog.text


def test_glb_exports_with_an_armature_short_tracks_and_several_animations(
    tmp_path: Path, dataset_clips: list[ClipRef], caplog
) -> None:  # type: ignore[no-untyped-def]
    """What exporters write that elastyle's own .glb does not: an Armature node turned a quarter over a Z-up
    rig (ignored: the body read lying down, 6.5 m off), a track that holds still kept as two keys (refused:
    "has 2 keys, not 267"), and several animations (the first read without a word)."""
    import logging

    from scipy.spatial.transform import Rotation

    from elastyle.io.dataset import read_clip

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0].slice(0, 60)
    path = tmp_path / "walk.glb"
    write_clip(path, walk)
    document = pygltflib.GLTF2().load(str(path))
    blob = bytearray(document.binary_blob())

    def appended(values: np.ndarray, kind: str) -> int:
        """A new float accessor (its own buffer view at the blob's end) holding values (N, width)."""
        document.bufferViews.append(
            pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=values.size * 4)
        )
        blob.extend(values.astype("<f4").tobytes())
        document.accessors.append(
            pygltflib.Accessor(
                bufferView=len(document.bufferViews) - 1, componentType=pygltflib.FLOAT, count=len(values),
                type=kind, min=values.min(axis=0).tolist() if kind == "SCALAR" else None,
                max=values.max(axis=0).tolist() if kind == "SCALAR" else None,
            )
        )  # fmt: skip
        return len(document.accessors) - 1

    animation, root = document.animations[0], document.skins[0].joints[0]
    up = Rotation.from_euler("x", 90, degrees=True)  # the rig stored standing along +Z ...
    for channel in animation.channels:
        sampler = animation.samplers[channel.sampler]
        if channel.target.node == root:
            values = _accessor(document, sampler.output)
            turned = (
                up.apply(values)
                if channel.target.path == "translation"
                else (up * Rotation.from_quat(values)).as_quat()
            )
            sampler.output = appended(turned, "VEC3" if channel.target.path == "translation" else "VEC4")
    node = document.nodes[root]
    node.translation = up.apply(node.translation or [0.0, 0.0, 0.0]).tolist()
    node.rotation = (up * Rotation.from_quat(node.rotation or [0.0, 0.0, 0.0, 1.0])).as_quat().tolist()
    half = float(np.sqrt(0.5))  # ... under an Armature turned back a quarter
    document.nodes.append(pygltflib.Node(name="Armature", rotation=[-half, 0.0, 0.0, half], children=[root]))
    document.scenes[0].nodes = [len(document.nodes) - 1]
    # the head's rotation held still: two keys, at the clip's ends
    head = walk.skeleton.names.index("Head")
    head_node = document.skins[0].joints[head]
    track = next(c for c in animation.channels if c.target.node == head_node and c.target.path == "rotation")
    times = _accessor(document, animation.samplers[track.sampler].input)[:, 0]
    first = _accessor(document, animation.samplers[track.sampler].output)[:1]
    animation.samplers.append(
        pygltflib.AnimationSampler(
            input=appended(np.array([[times[0]], [times[-1]]]), "SCALAR"),
            output=appended(np.repeat(first, 2, axis=0), "VEC4"),
        )
    )
    track.sampler = len(animation.samplers) - 1
    document.animations.append(
        pygltflib.Animation(
            name="Other", channels=list(animation.channels), samplers=list(animation.samplers)
        )
    )
    document.buffers[0].byteLength = len(blob)
    document.set_binary_blob(bytes(blob))
    exported = tmp_path / "exported.glb"
    document.save_binary(str(exported))
    with caplog.at_level(logging.INFO, logger="elastyle"):
        read = read_clip(exported)[0]
    assert f"{exported} holds 2 animations: the first, 'motion', is read" in caplog.text
    assert "scale tracks" not in caplog.text
    rotations = walk.rotations.copy()
    rotations[:, head] = rotations[0, head]  # as the two keys hold it
    held = Motion(walk.skeleton, rotations, walk.translations, walk.fps)
    assert read.num_frames == 60 and read.fps == walk.fps
    np.testing.assert_allclose(read.positions(), held.positions() * metres_per_unit(walk), atol=1e-5)


def test_glb_with_joints_listed_children_first_and_interleaved_tracks(
    dataset_clips: list[ClipRef], tmp_path: Path
) -> None:
    """glTF lets a skin list its joints in any order and a buffer view interleave several accessors (its
    byteStride): a skin listed children first was refused, and interleaved tracks were read as each other's
    values (a body in pieces, without a word)."""
    from elastyle.io.dataset import read_clip

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0].slice(0, 30)
    path = tmp_path / "walk.glb"
    write_clip(path, walk)
    document = pygltflib.GLTF2().load(str(path))
    document.skins[0].joints = document.skins[0].joints[::-1]
    # every rotation track's values in one view, row by row: joint 1's key 0, joint 2's key 0, ..., key 1 ...
    animation = document.animations[0]
    outputs = [
        animation.samplers[c.sampler].output for c in animation.channels if c.target.path == "rotation"
    ]
    values = np.stack([_accessor(document, index) for index in outputs], axis=1)  # (keys, tracks, 4)
    blob = bytearray(document.binary_blob())
    document.bufferViews.append(
        pygltflib.BufferView(
            buffer=0, byteOffset=len(blob), byteLength=values.size * 4, byteStride=16 * len(outputs)
        )
    )
    blob.extend(values.astype("<f4").tobytes())
    for track, index in enumerate(outputs):
        document.accessors[index].bufferView = len(document.bufferViews) - 1
        document.accessors[index].byteOffset = 16 * track
    document.buffers[0].byteLength = len(blob)
    document.set_binary_blob(bytes(blob))
    exported = tmp_path / "exported.glb"
    document.save_binary(str(exported))
    read = read_clip(exported)[0]
    assert sorted(read.skeleton.names) == sorted(walk.skeleton.names)
    assert read.skeleton.names[0] == walk.skeleton.names[0]
    order = [read.skeleton.names.index(joint) for joint in walk.skeleton.names]
    parents = [read.skeleton.names[p] if p >= 0 else None for p in read.skeleton.parents[order]]
    assert parents == [walk.skeleton.names[p] if p >= 0 else None for p in walk.skeleton.parents]
    np.testing.assert_allclose(
        read.positions()[:, order], walk.positions() * metres_per_unit(walk), atol=1e-5
    )


def test_a_skin_listed_parents_first_keeps_its_order(dataset_clips: list[ClipRef], tmp_path: Path) -> None:
    """A skin listed breadth first (every parent before its children, though not depth first) is read in
    its own order: only a skin that lists a child before its parent is reordered."""
    from elastyle.io.dataset import read_clip

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0].slice(0, 10)
    path = tmp_path / "walk.glb"
    write_clip(path, walk)
    document = pygltflib.GLTF2().load(str(path))
    depth = [0] * walk.skeleton.num_joints
    for joint, parent in enumerate(walk.skeleton.parents):
        depth[joint] = depth[parent] + 1 if parent >= 0 else 0
    order = sorted(range(walk.skeleton.num_joints), key=lambda joint: depth[joint])
    assert order != list(range(walk.skeleton.num_joints))
    document.skins[0].joints = [document.skins[0].joints[joint] for joint in order]
    exported = tmp_path / "breadth_first.glb"
    document.save_binary(str(exported))
    assert read_clip(exported)[0].skeleton.names == tuple(walk.skeleton.names[joint] for joint in order)


def test_a_buffer_view_stride_shorter_than_its_values_is_one_line(
    three_channel_bvh: Path, tmp_path: Path
) -> None:
    """A byteStride under an accessor's value size cannot hold its rows: said as such, not as truncation."""
    path = tmp_path / "clip.glb"
    write_clip(path, read_bvh(three_channel_bvh)[0].slice(0, 10))
    document = pygltflib.GLTF2().load(str(path))
    animation = document.animations[0]
    rotation = next(c for c in animation.channels if c.target.path == "rotation")
    document.bufferViews[
        document.accessors[animation.samplers[rotation.sampler].output].bufferView
    ].byteStride = 8
    document.save_binary(str(tmp_path / "bad.glb"))
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "info", str(tmp_path / "bad.glb")],
        capture_output=True,
        text=True,
    )
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert "byteStride (8) is shorter than its VEC4 values" in result.stderr, result.stderr
