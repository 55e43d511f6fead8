"""The Python API as an integrating developer meets it: wrong types and counts get clear errors of elastyle's
own types or TypeErrors that say what to pass, never a numpy or attribute error from deep inside."""

from __future__ import annotations

import json
import os
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

import elastyle
from elastyle import (
    BvhError,
    ConfigError,
    Motion,
    TransferConfig,
    UsageError,
    prepare_style,
    read_bvh,
    transfer,
    write_bvh,
    write_clip,
)
from elastyle.steps.schedule import Schedule
from tests.conftest import clip_named


def test_too_few_or_too_many_style_names_are_refused(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    """Before, names and clips were paired by zip: a second clip with no name was silently dropped."""
    with pytest.raises(ConfigError, match="1 style name\\(s\\) for 2 style clip\\(s\\)"):
        transfer(content, [style_clip, content], model=model, style_names=["a"])
    with pytest.raises(ConfigError, match="3 style name"):
        prepare_style(model, [style_clip, content], names=["a", "b", "c"])
    library = prepare_style(model, style_clip, names=["one"])  # one clip alone is a library of one
    assert library.names == ["one", "one"]  # the clip and its mirror


def test_clips_with_nan_are_named_before_any_work(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    rotations = content.rotations.copy()
    rotations[5, 3, 1] = np.nan
    broken = Motion(content.skeleton, rotations, content.translations, content.fps)
    with pytest.raises(BvhError, match="walk: NaN or infinite values, first at frame 5"):
        transfer(broken, style_clip, model=model, content_name="walk")
    with pytest.raises(BvhError, match="tired: NaN or infinite values, first at frame 5"):
        prepare_style(model, [broken], names=["tired"])


def test_wrong_types_say_what_to_pass(model, content: Motion, style_clip: Motion, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(TypeError, match="the style must be a Motion"):
        transfer(content, None, model=model)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="no style clips given"):
        prepare_style(model, [])
    with pytest.raises(ConfigError, match="config must be a TransferConfig"):
        transfer(content, style_clip, {"strength": 0.5}, model=model)  # type: ignore[arg-type]
    # options are named as Python names them (the command line says its flags instead)
    with pytest.raises(ConfigError, match="^cleanup: must be True or False"):
        TransferConfig(cleanup="no")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="^strength: "):
        TransferConfig(strength=None)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="^strength: keyframe times are seconds from 0"):
        TransferConfig(strength="-1:0,2:1")
    for text in ("0:0,2:1,", "0:0,,2:1"):
        with pytest.raises(ConfigError, match="no empty keyframe"):
            TransferConfig(strength=text)
    with pytest.raises(ConfigError, match="^second_weight: values must lie"):
        transfer(content, style_clip, model=model, second_style=style_clip, second_weight=1.5)
    with pytest.raises(ConfigError, match="^second_weight: second_style is given without its share"):
        transfer(content, style_clip, model=model, second_style=style_clip)
    with pytest.raises(TypeError, match="part_styles must map body part names to styles"):
        transfer(content, style_clip, model=model, part_styles=[("arms", style_clip)])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"part_styles\['arms'\]: give a clip"):
        transfer(content, style_clip, model=model, part_styles={"arms": None})  # type: ignore[dict-item]
    with pytest.raises(ConfigError, match="left-arm both kept"):
        transfer(content, style_clip, model=model, part_styles={"arms": style_clip}, keep_part="left-arm")
    with pytest.raises(TypeError, match=r"read_bvh's \(motion, layout\)\?\): pass its motion"):
        transfer((content, None), style_clip, model=model)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="model must be a StyleModel or a model file's path"):
        transfer(content, style_clip, model=3)  # type: ignore[arg-type]
    result = transfer(content, style_clip, model=model, strength=0.0)
    with pytest.raises(TypeError, match="pass result.motion"):
        write_bvh(tmp_path / "out.bvh", result)  # type: ignore[arg-type]
    with pytest.raises(UsageError, match="for binary glTF name the file .glb and use elastyle.write_clip"):
        write_bvh(tmp_path / "out.glb", result.motion)
    with pytest.raises(TypeError, match="the layout must be the BvhLayout read with the clip"):
        write_bvh(tmp_path / "out.bvh", result.motion, "x")  # type: ignore[arg-type]
    assert not list(tmp_path.iterdir())
    write_clip(tmp_path / "out.glb", result.motion)  # the format by the name
    assert (tmp_path / "out.glb").read_bytes()[:4] == b"glTF"


def test_options_in_python_types(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    """Parts as a list, numbers as numpy scalars, the model as a path: what a Python caller has at hand."""
    as_list = TransferConfig(keep_part=["legs", "right-arm"], patch_s=np.float32(0.75))  # type: ignore[arg-type]
    assert as_list.keep_part == "legs,right-arm" and as_list.kept_parts == ("legs", "right-arm")
    assert type(as_list.patch_s) is float  # numpy's numbers as Python's: the explain record stays JSON
    by_path = transfer(content, style_clip, as_list, model=elastyle.model.file.default_model_path())
    json.dumps(by_path.explain)
    keyframed = TransferConfig(strength=Schedule((0.0, 2.0), (0.0, 1.0)))  # type: ignore[arg-type]
    assert keyframed.strength_schedule == Schedule((0.0, 2.0), (0.0, 1.0))
    unchanged = transfer(content, style_clip, model=model, strength=np.float64(0.0))
    assert np.array_equal(unchanged.motion.rotations, content.rotations)


def test_read_bvh_takes_paths_as_text_or_bytes_and_nothing_else(walk_clip, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "walk.bvh"
    path.write_bytes(walk_clip.data())
    text_path, _ = read_bvh(str(path))
    bytes_path, _ = read_bvh(os.fsencode(path))
    assert np.array_equal(text_path.rotations, bytes_path.rotations)
    with pytest.raises(TypeError, match="takes a file's path.*parse_bvh"):
        read_bvh(path.read_bytes())  # the file's text, not its name
    with pytest.raises(TypeError, match="takes a file's path"):
        read_bvh(None)  # type: ignore[arg-type]


def test_a_second_weight_without_a_second_style_is_refused(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """Before, the share was silently ignored."""
    with pytest.raises(ConfigError, match="no second_style is given"):
        transfer(content, style_clip, model=model, second_weight=0.5)
    transfer(content, style_clip, model=model, second_weight=0.0, strength=0.0)  # a zero share is no share


def test_the_config_documents_every_field() -> None:
    """help(TransferConfig) lists each field with its default, range or choices and meaning (before, they
    were only in the command line's --help)."""
    from dataclasses import fields

    doc = TransferConfig.__doc__ or ""
    for spec in fields(TransferConfig):
        assert f"    {spec.name} = {spec.default!r}" in doc, spec.name
    assert "    patch_s = 1.0 (0, 60]: patch length, seconds" in doc
    assert "    method = 'elastic' (elastic, rigid, wct, adain): " in doc


def test_clips_print_briefly(content: Motion) -> None:
    """A clip's repr says what it is in one line (before, kilobytes of arrays in every error and test log)."""
    assert (
        repr(content)
        == "Motion(267 frames at 30 fps, Skeleton(22 joints: joint_Root, Hips, Spine, Chest, ...))"
    )


def test_a_prepared_library_brings_its_model_and_its_clips(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """A library prepared with one model is used with it (before: silently with the shipped model, a wrong
    result, or a bare numpy error for another shape); given another model that encodes otherwise, or
    options its clips contradict (mirror_style=False with mirrored clips), a ConfigError says so."""
    from dataclasses import replace

    other = replace(model, feature_mean=model.feature_mean + 0.05)  # the same shape, another encoding
    library = prepare_style(other, [style_clip])
    assert library.model is other
    own = transfer(content, library).motion
    np.testing.assert_array_equal(own.rotations, transfer(content, library, model=other).motion.rotations)
    shipped = transfer(content, style_clip).motion  # the shipped model's: another output
    assert own.num_frames != shipped.num_frames or not np.allclose(own.rotations, shipped.rotations)
    with pytest.raises(ConfigError, match="prepared with another model"):
        transfer(content, library, model=model)
    with pytest.raises(
        ConfigError, match="mirror_style=False, but the style library was prepared with mirrored"
    ):
        transfer(content, prepare_style(model, [style_clip]), mirror_style=False)
    with pytest.raises(ConfigError, match="reverse_style=True, but the style library was prepared without"):
        transfer(content, prepare_style(model, [style_clip]), reverse_style=True)
    unmirrored = prepare_style(model, [style_clip], mirror_style=False)
    assert not any(unmirrored.mirrored)
    transfer(content, unmirrored)  # the default options accept a library prepared without mirrors


def test_writing_in_the_layout_of_another_skeleton_is_an_elastyle_error(
    content: Motion, walk_clip, tmp_path: Path
) -> None:  # type: ignore[no-untyped-def]
    """A layout from a file of another joint count: a SkeletonMismatchError (an ElastyleError, one line on
    the command line) before anything is written; it was a bare ValueError."""
    from elastyle import BvhLayout, SkeletonMismatchError

    _, layout = walk_clip.read()
    other = BvhLayout(layout.channels[:-1], layout.frame_time_s)  # a file of one joint fewer
    target = tmp_path / "out.bvh"
    with pytest.raises(SkeletonMismatchError, match="the layout is a file's of 21 joints, the clip has 22"):
        write_bvh(target, content, other)
    assert not target.exists()


def test_the_explain_record_on_the_content_clock_and_with_its_settings(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """With timing='content' each patch's output time is its content time (it was the style clock's: a last
    patch at 7.0 s of an 8.9 s output); style starts in seconds too; the timing, strength and a transition
    recorded; a style clip shorter than a patch in a library, a short --style-part clip and short patches
    noted in the record (they were silent, or printed and not recorded)."""
    from elastyle import prepare_style

    record = transfer(content, style_clip, model=model, timing="content", strength="0:0,2:1").explain
    rows = record["styles"][0]["patches"]
    assert all(row["output_start_s"] == row["content_start_s"] for row in rows)
    assert all(
        row["style_start_s"] == round(row["style_start_frame"] / record["model_fps"], 4) for row in rows
    )
    assert record["timing"] == "content" and record["strength"] == "0:0,2:1"
    # every option, so two records of different outputs tell them apart (decode, cleanup, smoothing ...)
    assert {spec.name for spec in fields(TransferConfig)} <= set(record)
    assert record["decode"] == "residual" and record["cleanup"] is True
    walked = transfer(
        content, style_clip, model=model, second_style=style_clip, second_weight="2:0,3:1"
    ).explain
    assert walked["second_weight"] == {"times_s": [2.0, 3.0], "values": [0.0, 1.0]}
    short = style_clip.slice(0, 15)  # half a second
    library = prepare_style(model, [short, style_clip], names=["short", "long"])
    notes = transfer(content, library).explain["notes"]
    assert any(note.startswith("note: short: shorter than a patch") for note in notes)
    parted = transfer(content, style_clip, model=model, part_styles={"arms": [short]}).explain["notes"]
    assert any("style0: the style clips are at most 0.50 s long" in note for note in parted)
    tiny = transfer(content, style_clip, model=model, patch_s=0.2).explain["notes"]
    assert any(note.startswith("warning: --patch-s 0.2: windows under 0.5 s") for note in tiny)


def test_a_patch_too_short_to_stretch_is_noted(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    """A patch of a few frames, or a stretch under a frame, reaches no other whole length: only the patch's
    own is tried, so the output keeps the content's timing, and a note says so (a probe found it silent)."""
    tiny = transfer(content, style_clip, model=model, patch_s=0.001)
    assert any(
        note.startswith("note: --patch-s 0.001: patches of 4 frames") and "keeps the content's timing" in note
        for note in tiny.explain["notes"]
    )
    assert tiny.motion.num_frames == content.num_frames
    slight = transfer(content, style_clip, model=model, stretch=0.001).explain["notes"]
    assert any(note.startswith("note: --stretch has no effect here (a patch of 30 frames") for note in slight)
    default = transfer(content, style_clip, model=model).explain["notes"]
    assert not any("whole length" in note or "no other length" in note for note in default)


def test_options_the_method_does_not_read_are_noted(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    """Options set that change nothing for the method (a timing or placement for the statistics methods, a
    stretch for rigid, a stretch step wider than the range) are noted; the default options are not."""
    notes = transfer(content, style_clip, model=model, method="wct", timing="content").explain["notes"]
    assert any(note.startswith("note: --timing has no effect here (--method wct") for note in notes)
    notes = transfer(content, style_clip, model=model, method="rigid", stretch=0.5).explain["notes"]
    assert any(note.startswith("note: --stretch has no effect here (--method rigid") for note in notes)
    notes = transfer(content, style_clip, model=model, stretch_step_s=5).explain["notes"]
    assert any(note.startswith("note: --stretch-step-s has no effect here") for note in notes)
    # each measured byte-identical to the option's absence (a probe found them unsaid)
    for options, said in (
        (
            {"decode": "plain", "residual_smooth_s": 5.0},
            "--residual-smooth-s has no effect here (--decode plain",
        ),
        (
            {"cleanup": False, "root_follows_legs": 0.0},
            "--root-follows-legs has no effect here (--no-cleanup",
        ),
        ({"placement": "fixed", "timing": "content"}, "--timing has no effect here (--placement fixed"),
        ({"method": "adain", "whiten_floor": 1e-4}, "--whiten-floor has no effect here (--method adain"),
        (
            {"keep_part": "arms", "arm_rhythm_above": 0.01},
            "--arm-rhythm-above has no effect here (--keep-part",
        ),
    ):
        notes = transfer(content, style_clip, model=model, **options).explain["notes"]
        assert any(note.startswith(f"note: {said}") for note in notes), (options, notes)
    assert not any(
        "no effect" in note for note in transfer(content, style_clip, model=model).explain["notes"]
    )


def test_a_library_prints_as_a_summary_and_a_bad_size_limit_is_said(
    dataset_clips, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:  # type: ignore[no-untyped-def]
    # print(library) dumped some 10 KB of arrays; ELASTYLE_CACHE_MB=abc was ignored without a word
    from elastyle.io.files import megabytes_from_environment
    from elastyle.steps.library import prepare_style

    style = clip_named(dataset_clips, "dataset-2_walk_elderly_010").read()[0]
    text = repr(prepare_style(None, [style], ["elderly.bvh"]))
    assert text.startswith("StyleLibrary(2 clip(s)") and "elderly.bvh" in text and len(text) < 200, text
    monkeypatch.setenv("ELASTYLE_CACHE_MB", "abc")
    with caplog.at_level("WARNING", logger="elastyle"):
        assert megabytes_from_environment("ELASTYLE_CACHE_MB", 1024) == 1024 * 2**20
    assert "ELASTYLE_CACHE_MB=abc is not a number of megabytes" in caplog.text


def test_a_skeleton_built_of_lists_transfers_as_the_one_read(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """Before, a list of names failed every transfer with a bare StopIteration, and lists of parents or
    offsets with an AttributeError."""
    skeleton = content.skeleton
    built = elastyle.Skeleton(list(skeleton.names), skeleton.parents.tolist(), skeleton.offsets.tolist())
    assert built.names == skeleton.names and built.parents.dtype == np.int64
    from_lists = Motion(built, content.rotations.tolist(), content.translations.tolist(), content.fps)
    expected = transfer(content, style_clip, model=model).motion
    styled = transfer(from_lists, style_clip, model=model).motion
    np.testing.assert_array_equal(styled.rotations, expected.rotations)
    np.testing.assert_array_equal(styled.translations, expected.translations)
    # whole numbers given as floats are joint indices too
    assert (
        elastyle.Skeleton(skeleton.names, skeleton.parents.astype(float), skeleton.offsets).parents.dtype
        == np.int64
    )


def test_a_skeleton_or_clip_that_cannot_be_is_refused_where_it_is_built(content: Motion) -> None:
    skeleton = content.skeleton
    offsets = skeleton.offsets.copy()
    offsets[4, 1] = np.nan
    with pytest.raises(ValueError, match=f"offsets must be finite numbers: joint '{skeleton.names[4]}'"):
        elastyle.Skeleton(skeleton.names, skeleton.parents, offsets)
    with pytest.raises(ValueError, match="parents must be joint indices"):
        elastyle.Skeleton(skeleton.names, skeleton.parents + 0.5, skeleton.offsets)
    twice = (skeleton.names[0], *skeleton.names[:-1])
    with pytest.raises(ValueError, match=f"joint names must be unique: '{skeleton.names[0]}' names 2 joints"):
        elastyle.Skeleton(twice, skeleton.parents, skeleton.offsets)
    for fps in (float("inf"), float("nan"), 0.0, "30", None, True, np.array([30.0])):
        with pytest.raises(ValueError, match="fps must be a positive finite number"):
            Motion(skeleton, content.rotations, content.translations, fps)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="fps must be a positive finite number, got 0"):
        content.resample(0)
    # names a BVH file cannot hold, a unit that is no length, End Sites of another skeleton
    for name in ("", "  ", "Left\nArm"):
        with pytest.raises(ValueError, match="joint names must be non-empty and on one line: joint 1"):
            elastyle.Skeleton(
                (skeleton.names[0], name, *skeleton.names[2:]), skeleton.parents, skeleton.offsets
            )
    for unit in (0, -1.0, float("nan"), float("inf"), "cm", True):
        with pytest.raises(ValueError, match="unit_cm must be a positive finite number"):
            elastyle.Skeleton(skeleton.names, skeleton.parents, skeleton.offsets, unit_cm=unit)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"end_sites must be \(22, 3\)"):
        elastyle.Skeleton(skeleton.names, skeleton.parents, skeleton.offsets, end_sites=[[1.0, 2.0, 3.0]])
    # values that are no real numbers are refused; whole numbers and half precision are read as float64
    for dtype in (bool, complex, object):
        with pytest.raises(ValueError, match=f"rotations must be real numbers, got {np.dtype(dtype)}"):
            Motion(skeleton, content.rotations.astype(dtype), content.translations, content.fps)
    whole = Motion(
        skeleton, np.zeros(content.rotations.shape, int), np.rint(content.translations).astype(int), 30
    )
    half = Motion(skeleton, content.rotations.astype(np.float16), content.translations, content.fps)
    assert whole.rotations.dtype == whole.translations.dtype == half.rotations.dtype == np.float64
    with pytest.raises(ValueError, match="renamed takes one name per joint \\(22\\), got 1 names"):
        content.renamed(["a"])


def test_a_skeleton_is_immutable_so_an_output_can_share_it(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """Before, scaling an output's offsets in place (to metres) changed the content's skeleton too."""
    own = elastyle.Skeleton(content.skeleton.names, content.skeleton.parents, content.skeleton.offsets.copy())
    mine = Motion(own, content.rotations, content.translations, content.fps)  # (the fixtures' stay untouched)
    output = transfer(mine, style_clip, model=model, strength=0).motion
    assert output.skeleton is own
    for array in (output.skeleton.offsets, output.skeleton.parents, output.skeleton.end_sites):
        with pytest.raises(ValueError, match="read-only"):
            array[...] = 0
    import pickle

    unpickled = pickle.loads(pickle.dumps(output.skeleton))  # as a batch's worker process gets it
    assert not any(a.flags.writeable for a in (unpickled.offsets, unpickled.parents, unpickled.end_sites))
    assert mine.renamed(name for name in own.names).skeleton.names == own.names  # any sequence of names
    offsets = np.ones((content.skeleton.num_joints, 3))
    built = elastyle.Skeleton(content.skeleton.names, content.skeleton.parents, offsets)
    offsets[0] = 5.0  # the caller's array stays the caller's
    assert np.all(built.offsets == 1.0)
    assert repr(model).startswith("StyleModel(") and len(repr(model)) < 200


def test_helpers_say_what_they_take(model, content: Motion, style_clip: Motion, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(TypeError, match="mirror takes a Motion"):
        elastyle.mirror("walk.bvh")  # type: ignore[arg-type]
    skeleton = content.skeleton
    with pytest.raises(ValueError, match=r"local_rotations must be \(T, 22, 3\), got \(22, 3\)"):
        elastyle.forward_kinematics(skeleton, content.rotations[0], content.translations[0])
    with pytest.raises(ValueError, match="joints must be indices from 0 to 21, got \\[-1\\]"):
        elastyle.forward_kinematics(skeleton, content.rotations, content.translations, [-1])
    # one clip's name as a string; names and flags of other types refused
    assert prepare_style(model, style_clip, names="proud").names[0] == "proud"
    with pytest.raises(ConfigError, match="style names must be strings"):
        prepare_style(model, style_clip, names=[1])  # type: ignore[list-item]
    with pytest.raises(ConfigError, match="mirror_style must be True or False, got 'no'"):
        prepare_style(model, style_clip, mirror_style="no")  # type: ignore[arg-type]
    # one path given as a string or Path is that path (a string had been read letter by letter: '/' first)
    folder = tmp_path / "clips"
    folder.mkdir()
    write_bvh(folder / "walk.bvh", content.slice(0, 40))
    for spec in (str(folder), folder):
        assert [Path(clip.name).name for clip in elastyle.find_clips(spec)] == ["walk.bvh"]


def test_the_files_macos_writes_beside_clips_are_not_clips(content: Motion, tmp_path: Path) -> None:
    """A folder or zip made on a Mac holds `._walk.bvh` (and, zipped, `__MACOSX/...`) beside `walk.bvh`:
    they were read as clips, and a style library or a batch failed on 'binary data'."""
    import zipfile

    folder = tmp_path / "clips"
    (folder / "__MACOSX").mkdir(parents=True)
    write_bvh(folder / "walk.bvh", content.slice(0, 40))
    for metadata in (
        folder / "._walk.bvh",
        folder / "__MACOSX" / "._walk.bvh",
        folder / "__MACOSX" / "walk.bvh",
    ):
        metadata.write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X")
    (folder / "folder.bvh").mkdir()  # a folder named like a clip is no clip either
    archive = tmp_path / "clips.zip"
    with zipfile.ZipFile(archive, "w") as packed:
        for path in sorted(folder.rglob("*")):
            packed.write(path, path.relative_to(tmp_path))
    for spec in (folder, archive, f"{folder}/**/*.bvh"):
        found = elastyle.find_clips([spec])
        assert [Path(clip.member or clip.name).name for clip in found] == ["walk.bvh"], spec
        assert "__MACOSX" not in (found[0].member or found[0].name)


def test_clips_no_reader_takes_are_not_written(content: Motion, tmp_path: Path) -> None:
    """A clip without frames, or a BVH of a skeleton with two roots: files that read back as errors were written."""
    for name in ("empty.bvh", "empty.glb"):
        with pytest.raises(BvhError, match=f"{name}: the clip has no frames; nothing written"):
            write_clip(tmp_path / name, content.slice(0, 0))
    skeleton = elastyle.Skeleton(["Hips", "Spine", "Prop"], [-1, 0, -1], [[0, 90, 0], [0, 10, 0], [50, 0, 0]])
    two_roots = Motion(skeleton, np.zeros((3, 3, 3)), np.tile(skeleton.offsets, (3, 1, 1)), 30)
    with pytest.raises(BvhError, match=r"this skeleton has 2 roots \(Hips, Prop\); nothing written"):
        write_bvh(tmp_path / "two.bvh", two_roots)
    write_clip(tmp_path / "two.glb", two_roots)  # glTF holds several roots
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.glb"]


def test_a_style_clip_without_frames_is_too_short(model, content: Motion, style_clip: Motion) -> None:  # type: ignore[no-untyped-def]
    """Before, an empty style clip (an out-of-range slice) raised numpy's IndexError from deep inside."""
    empty = style_clip.slice(0, 0)
    for call in (
        lambda: transfer(content, empty, model=model),
        lambda: transfer(content, [style_clip, empty], model=model),
        lambda: transfer(content, style_clip, model=model, second_style=empty, second_weight=0.5),
        lambda: transfer(content, style_clip, model=model, part_styles={"arms": empty}),
        lambda: prepare_style(model, empty),
    ):
        with pytest.raises(elastyle.ClipTooShortError, match="style[01]: a style clip without frames"):
            call()


def test_transfers_in_threads_give_the_same_bytes_and_leave_the_blas_threads_as_they_were(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """Each call limits BLAS to one thread and restores the limit after. Calls overlapping in a user's
    threads fought over the process's one limit: some ran on two BLAS threads (outputs off by 1e-7), and a
    limit of one stayed on the process after the last had ended."""
    from concurrent.futures import ThreadPoolExecutor

    from threadpoolctl import threadpool_info

    library = prepare_style(model, style_clip)
    contents = [content.slice(start, start + 90) for start in range(0, 60, 6)]
    expected = [transfer(clip, library, model=model).motion for clip in contents]

    def blas_threads() -> list[int]:
        return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]

    before = blas_threads()
    for _ in range(3):
        with ThreadPoolExecutor(4) as pool:
            styled = list(pool.map(lambda clip: transfer(clip, library, model=model).motion, contents))
        assert blas_threads() == before
        for got, want in zip(styled, expected):
            np.testing.assert_array_equal(got.rotations, want.rotations)
            np.testing.assert_array_equal(got.translations, want.translations)


def test_a_child_forked_while_a_thread_transfers_can_transfer(
    model, content: Motion, style_clip: Motion
) -> None:  # type: ignore[no-untyped-def]
    """Calls run one at a time under a process-wide lock: a child forked while another thread held it
    inherited it held, by a thread the child does not have, and its first transfer waited for ever."""
    import threading
    import time

    from elastyle.core.threads import one_blas_thread

    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform")
    library = prepare_style(model, style_clip)
    holding, release = threading.Event(), threading.Event()

    @one_blas_thread
    def hold() -> None:  # a transfer under way in another thread
        holding.set()
        release.wait(30)

    thread = threading.Thread(target=hold)
    thread.start()
    assert holding.wait(10)
    child = os.fork()
    if child == 0:  # pragma: no cover (the child's outcome is its exit code)
        try:
            transfer(content.slice(0, 60), library, model=model)
            os._exit(0)
        except BaseException:
            os._exit(1)
    release.set()
    thread.join()
    deadline = time.monotonic() + 60
    while True:
        done, status = os.waitpid(child, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(child, 9)
            os.waitpid(child, 0)
            pytest.fail("the forked child's transfer never ended")
        time.sleep(0.05)
    assert os.waitstatus_to_exitcode(status) == 0
