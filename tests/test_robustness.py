"""Every bad input through the CLI: exit code, one line on stderr naming the file, and no output file.

Also: random mutations of real dataset files only ever give a clean `BvhError` or a valid motion, and
the same transfer gives byte-identical files, also across processes.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from elastyle import BvhError, Motion, read_bvh, write_bvh
from elastyle.core.threads import usable_cores
from elastyle.io.bvh_read import parse_bvh
from elastyle.io.dataset import ClipRef
from tests.conftest import THREE_CHANNEL_BVH, clip_named

GOOD = THREE_CHANNEL_BVH


def _cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "elastyle.cli", *args], capture_output=True, text=True, cwd=cwd
    )


# (name, file content as bytes, expected words in the message)
BAD_FILES: list[tuple[str, bytes, str]] = [
    ("empty", b"", "empty file"),
    ("binary", bytes(range(256)) * 4, "binary data"),
    ("latin1", "HIERARCHY\nROOT h\xe9\n{\n".encode("latin-1"), "ends inside HIERARCHY"),
    ("truncated-hierarchy", GOOD[:200].encode(), "ends inside HIERARCHY"),
    ("truncated-motion", GOOD[: GOOD.index("Frame Time")].encode(), "Frame Time"),
    ("truncated-row", GOOD[:-20].encode(), "row has"),
    ("frame-count", GOOD.replace("Frames: 3", "Frames: 5").encode(), "Frames: 5"),
    (
        "too-many-values",
        GOOD.replace("0 20 0 0 0 0 0", "0 20 0 0 0 0 0 1 2", 1).encode(),
        "row has 23 values",
    ),
    ("non-numeric", GOOD.replace("1 20 0 90", "1 20 0 abc").encode(), "not a number"),
    ("nan", GOOD.replace("1 20 0 90", "1 20 0 NaN").encode(), "NaN or infinite"),
    ("inf", GOOD.replace("1 20 0 90", "1 20 0 inf").encode(), "NaN or infinite"),
    ("unknown-channel", GOOD.replace("Xposition", "Wposition").encode(), "unknown channel"),
    ("duplicate-joint", GOOD.replace("JOINT RightLeg", "JOINT LeftLeg").encode(), "duplicate joint name"),
    ("zero-frames", GOOD.replace("Frames: 3", "Frames: 0").encode(), "no frames"),
    ("negative-frames", GOOD.replace("Frames: 3", "Frames: -5").encode(), "no frames (Frames: -5)"),
    (
        "frames-undercounted",
        GOOD.replace("Frames: 3", "Frames: 2").encode(),
        "more rows than the Frames line",
    ),
    (
        "bad-frame-time",
        GOOD.replace("Frame Time: 0.0083333", "Frame Time: 0").encode(),
        "frame time must lie between",
    ),
]


@pytest.mark.parametrize(("name", "content", "message"), BAD_FILES, ids=[b[0] for b in BAD_FILES])
@pytest.mark.parametrize("command", ["info", "convert"])
def test_bad_bvh_files_through_the_cli(
    tmp_path: Path, name: str, content: bytes, message: str, command: str
) -> None:
    bad = tmp_path / f"{name}.bvh"
    bad.write_bytes(content)
    out = tmp_path / "out.bvh"
    args = [command, str(bad)] + (["-o", str(out)] if command == "convert" else [])
    result = _cli(*args)
    assert result.returncode == 1, result.stderr
    line = result.stderr.strip()
    assert "\n" not in line and "Traceback" not in line
    assert f"{name}.bvh" in line and message in line, line
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.bvh")]  # no temporary left


def test_bad_bvh_as_transfer_content_and_style(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    bad = tmp_path / "broken.bvh"
    bad.write_text(GOOD.replace("1 20 0 90", "1 20 0 nan"))
    out = tmp_path / "out.bvh"
    for args in (["transfer", str(bad), "--style", walk], ["transfer", walk, "--style", str(bad)]):
        result = _cli(*args, "-o", str(out))
        assert result.returncode == 1 and "broken.bvh:" in result.stderr and "NaN" in result.stderr
        assert not out.exists()


def test_path_problems(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    empty = tmp_path / "empty"
    empty.mkdir()
    cases: list[tuple[list[str], str]] = [
        (["info", str(tmp_path / "missing.bvh")], "no such file"),
        (["info", str(empty)], "no BVH clips found"),
        (["convert", str(tmp_path), "-o", str(tmp_path / "x.bvh")], "is a directory"),
        (["convert", str(good), "-o", str(tmp_path / "no" / "such" / "x.bvh")], "does not exist"),
        (["convert", str(good), "-o", str(good), "--force"], "would overwrite"),
        (["transfer", str(good), "--style", str(good), "-o", str(tmp_path / "a.bvh"), "--model", str(tmp_path / "m.npz")],
         "no such model file"),
    ]  # fmt: skip
    for args, message in cases:
        result = _cli(*args)
        assert result.returncode == 1, (args, result.stderr)
        assert message in result.stderr and result.stderr.count("\n") == 1, result.stderr


def test_non_utf8_file_name(tmp_path: Path) -> None:
    name = os.fsdecode(b"caf\xe9.bvh")
    path = tmp_path / name
    path.write_text(GOOD)
    result = subprocess.run([sys.executable, "-m", "elastyle.cli", "info", str(path)], capture_output=True)
    assert result.returncode == 0 and b"frames:   3" in result.stdout


def test_usage_errors_exit_2(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    result = _cli("transfer", str(good), "-o", str(tmp_path / "x.bvh"))  # no --style
    assert result.returncode == 2
    result = _cli(
        "transfer", str(good), "--style", str(good), "--strength", "2", "-o", str(tmp_path / "x.bvh")
    )
    assert result.returncode == 2 and "--strength" in result.stderr


@pytest.mark.parametrize(
    "args, named",
    [
        (["transfer", "a.bvh", "-o", "x.bvh"], "--style"),
        (["transfer", "a.bvh", "--style", "a.bvh", "-o", "x.bvh", "--units", "km"], "--units"),
        (["frobnicate"], "frobnicate"),
        (["transfer", "a.bvh", "--style", "a.bvh", "-o", "x.bvh", "--bogus"], "elastyle transfer --help"),
    ],
)
def test_usage_errors_are_one_line(args: list[str], named: str) -> None:
    result = _cli(*args)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and named in result.stderr and "--help" in result.stderr, (
        result.stderr
    )


def test_verbose_works_after_the_command_too(tmp_path: Path) -> None:
    missing = str(tmp_path / "missing.bvh")
    for args in (["--verbose", "info", missing], ["info", missing, "--verbose"]):
        result = _cli(*args)
        assert result.returncode == 1 and "Traceback" in result.stderr, args
    assert "Traceback" not in _cli("info", missing).stderr


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--patch-s", "inf"], "--patch-s"),
        (["--patch-s", "0"], "--patch-s"),
        (["--stretch", "1"], "--stretch"),
        (["--stretch-step-s", "-1"], "--stretch-step-s"),
        (["--smooth-s", "nan"], "--smooth-s"),
        (["--smooth-s", "1e6"], "--smooth-s"),
        (["--residual-smooth-s", "-0.1"], "--residual-smooth-s"),
        (["--strength", "0:0,nan:1"], "--strength"),
        (["--blend", "0.5"], "--blend"),
        (["--at", "2"], "--at"),
        (["--over", "1"], "--over"),
        (["--method", "magic"], "--method"),
        (["--strength=-1:0,2:1"], "--strength: keyframe times are seconds from 0"),
        (["--strength", "0:0,2:1,"], "--strength: cannot read"),
        (["--keep-part", "tail"], "--keep-part: unknown body part"),
        (["--style", ""], "--style: an empty path"),
        (["--model", ""], "--model: an empty path"),
        (["--explain", ""], "--explain: an empty path"),
    ],
)
def test_every_wrong_option_exits_2_before_reading_anything(
    tmp_path: Path, flags: list[str], named: str
) -> None:
    """One validation for every option: exit 2, the flag named, no file read (the clips do not exist)."""
    result = _cli("transfer", "missing.bvh", "--style", "missing.bvh", *flags, "-o", str(tmp_path / "x.bvh"))
    assert result.returncode == 2, result.stderr
    assert named in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "x.bvh").exists()


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--perturb-augment", "1.5"], "--perturb-augment"),
        (["--reverse-augment", "-0.1"], "--reverse-augment"),
        (["--perturb-scale", "-1"], "--perturb-scale"),
    ],
)
def test_wrong_training_shares_exit_2(tmp_path: Path, flags: list[str], named: str) -> None:
    result = _cli("train", "missing.zip", "-o", str(tmp_path / "m.npz"), "--steps", "1", *flags)
    assert result.returncode == 2, result.stderr
    assert named in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "m.npz").exists()


def test_every_config_field_is_a_transfer_flag() -> None:
    """TransferConfig is the one declaration of the options: each field has a flag of its name."""
    from dataclasses import fields

    from elastyle import TransferConfig

    help_text = _cli("transfer", "--help").stdout
    for spec in fields(TransferConfig):
        flag = spec.name.replace("_", "-")
        default_on = spec.default is True
        option = f"--no-{flag}" if default_on else f"--{flag}"
        assert re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", help_text), option


def test_config_rejects_bad_values_from_python_too() -> None:
    from elastyle import ConfigError, TransferConfig

    with pytest.raises(ConfigError, match="^stretch: must lie in"):  # named as Python names it
        TransferConfig(stretch=1.5)
    with pytest.raises(ConfigError, match="unknown transfer option 'strenght'"):
        TransferConfig.of(strenght=0.5)


def test_model_files_through_the_cli(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, x=np.zeros(2))
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, format_version=np.array([{"evil": 1}], dtype=object))
    truncated = tmp_path / "truncated.npz"
    from elastyle.model.file import default_model_path

    truncated.write_bytes(default_model_path().read_bytes()[:5000])
    for model, message in (
        (foreign, "no format_version"),
        (pickled, "not an elastyle model"),
        (truncated, "not an elastyle model"),
    ):
        result = _cli("transfer", walk, "--style", walk, "-o", str(tmp_path / "o.bvh"), "--model", str(model))
        assert result.returncode == 1 and message in result.stderr, result.stderr
        assert "Traceback" not in result.stderr
    # a checkpoint (here one that is not even an archive) is named as one, by `info` and `transfer` alike
    checkpoint = tmp_path / "m.npz.ckpt"
    checkpoint.write_text("an unfinished training")
    for command in (("info",), ("transfer", walk, "--style", walk, "-o", str(tmp_path / "o.bvh"), "--model")):
        result = _cli(*command, str(checkpoint))
        assert result.returncode == 1 and "a training checkpoint, not a model" in result.stderr, result.stderr
        assert "Traceback" not in result.stderr


def test_skeleton_mismatches_list_the_joints(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    tiny = tmp_path / "tiny.bvh"
    tiny.write_text(GOOD)
    out = tmp_path / "o.bvh"
    as_style = _cli("transfer", walk, "--style", str(tiny), "-o", str(out))
    assert (
        as_style.returncode == 1
        and "tiny.bvh" in as_style.stderr
        and "tiny.bvh: skeleton differs from the model" in as_style.stderr
        and "only in this clip: pelvis" in as_style.stderr
    )
    mixed = _cli("transfer", walk, "--style", walk, "--style", str(tiny), "-o", str(out))
    assert mixed.returncode == 1 and "only in the model: joint_Root" in mixed.stderr
    assert not out.exists()


def test_other_frame_rate_is_resampled_with_a_note(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005")
    style = clip_named(dataset_clips, "dataset-2_walk_active_010")
    fast = tmp_path / "style60.bvh"
    assert _cli("convert", style.name, "-o", str(fast), "--fps", "60").returncode == 0
    out = tmp_path / "o.bvh"
    result = _cli("transfer", walk.name, "--style", str(fast), "-o", str(out))
    assert result.returncode == 0 and "resampled" in result.stderr
    reference = tmp_path / "reference.bvh"
    assert _cli("transfer", walk.name, "--style", style.name, "-o", str(reference)).returncode == 0
    # the 60 fps style is brought to the model's 30 fps: the same transfer as from the 30 fps original
    np.testing.assert_allclose(read_bvh(out)[0].positions(), read_bvh(reference)[0].positions(), atol=0.01)


def test_still_t_pose_and_single_frame(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walk, layout = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()
    from elastyle import Motion

    still = Motion(walk.skeleton, np.zeros_like(walk.rotations), walk.translations.copy(), walk.fps)
    still_path = tmp_path / "still.bvh"
    write_bvh(still_path, still, layout)
    out = tmp_path / "o.bvh"
    assert _cli("transfer", str(still_path), "--style", walk and clip_named(dataset_clips, "dataset-2_walk_active_010").name,
                "-o", str(out)).returncode == 0  # fmt: skip
    assert _cli("transfer", clip_named(dataset_clips, "dataset-2_walk_normal_010").name, "--style", str(still_path),
                "-o", str(tmp_path / "o2.bvh")).returncode == 0  # fmt: skip
    single = tmp_path / "single.bvh"
    write_bvh(single, walk.slice(0, 1), layout)
    assert _cli("info", str(single)).returncode == 0
    result = _cli("transfer", str(single), "--style", str(still_path), "-o", str(tmp_path / "o3.bvh"))
    assert result.returncode == 1 and "at least 2" in result.stderr


def test_failed_write_keeps_the_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from elastyle import OutputError

    motion, layout = parse_bvh(GOOD.encode(), "good.bvh")
    out = tmp_path / "out.bvh"
    out.write_text("precious")

    def fail(*args: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OutputError, match="No space left on device"):
        write_bvh(out, motion, layout, force=True)
    assert out.read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bvh"]


def test_an_output_and_its_explain_record_are_written_both_or_neither(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, dataset_clips: list[ClipRef]
) -> None:
    """The disk filling up while the explain record is written: the output had been written already and the
    command failed, so running it again said the output exists. Now neither is written, and no temporary
    file is left."""
    from elastyle.cli import main

    content = clip_named(dataset_clips, "dataset-2_walk_normal_010").name
    style = clip_named(dataset_clips, "dataset-2_walk_active_010").name
    out, record = tmp_path / "o.bvh", tmp_path / "o.json"
    if not Path("/proc/self/fd").is_dir():
        pytest.skip("needs /proc to tell which file is being written")
    real_fsync = os.fsync

    def full_at_the_record(handle: int) -> None:  # the output's file syncs, the record's finds the disk full
        if Path(os.readlink(f"/proc/self/fd/{handle}")).name.startswith(".o.json."):
            raise OSError(28, "No space left on device")
        real_fsync(handle)

    monkeypatch.setattr(os, "fsync", full_at_the_record)
    assert main(["transfer", content, "--style", style, "-o", str(out), "--explain", str(record)]) == 1
    assert list(tmp_path.iterdir()) == []
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert main(["transfer", content, "--style", style, "-o", str(out), "--explain", str(record)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.bvh", "o.json"]


@pytest.mark.parametrize("force", [False, True])
def test_files_written_together_are_undone_where_a_later_one_cannot_be_put_in_place(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, force: bool
) -> None:
    """An output put in place, then its record's name refused: the output is removed again, or with force
    the file it replaced is put back; no temporary file is left."""
    from elastyle import OutputError
    from elastyle.io.files import write_files_atomic

    output, record = tmp_path / "o.bvh", tmp_path / "o.json"
    if force:
        output.write_text("the user's output")
        record.write_text("the user's record")
    real_link, real_replace = os.link, os.replace

    def refused_at_the_record(real):  # type: ignore[no-untyped-def]
        def put(source: object, target: object) -> None:
            if Path(str(target)) == record:
                raise OSError(28, "No space left on device")
            real(source, target)

        return put

    monkeypatch.setattr(os, "link", refused_at_the_record(real_link))
    monkeypatch.setattr(os, "replace", refused_at_the_record(real_replace))
    with pytest.raises(OutputError, match=r"o\.json: write failed: No space left on device"):
        write_files_atomic([(output, b"new output", ()), (record, b"new record", ())], force=force)
    if force:
        assert output.read_text() == "the user's output" and record.read_text() == "the user's record"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["o.bvh", "o.json"]
    else:
        assert list(tmp_path.iterdir()) == []


def test_written_file_has_the_users_usual_mode(tmp_path: Path) -> None:
    motion, layout = parse_bvh(GOOD.encode(), "good.bvh")
    umask = os.umask(0o027)
    try:
        write_bvh(tmp_path / "out.bvh", motion, layout)
    finally:
        os.umask(umask)
    assert (tmp_path / "out.bvh").stat().st_mode & 0o777 == 0o640
    assert [p.name for p in tmp_path.iterdir()] == ["out.bvh"]


Mutation = Callable[[list[str]], list[str]]


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_dataset_files_give_clean_errors(data: st.DataObject, walk_clip: ClipRef) -> None:
    text = _walk_text(walk_clip)
    lines = text.split("\n")
    kind = data.draw(
        st.sampled_from(["truncate", "delete-token", "duplicate-token", "swap-lines", "random-bytes"])
    )
    if kind == "truncate":
        mutated = text[: data.draw(st.integers(0, len(text)))].encode()
    elif kind in ("delete-token", "duplicate-token"):
        index = data.draw(st.integers(0, len(lines) - 1))
        tokens = lines[index].split()
        if tokens:
            k = data.draw(st.integers(0, len(tokens) - 1))
            tokens = tokens[:k] + tokens[k + 1 :] if kind == "delete-token" else tokens[: k + 1] + tokens[k:]
        lines[index] = " ".join(tokens)
        mutated = "\n".join(lines).encode()
    elif kind == "swap-lines":
        i, j = data.draw(st.integers(0, len(lines) - 1)), data.draw(st.integers(0, len(lines) - 1))
        lines[i], lines[j] = lines[j], lines[i]
        mutated = "\n".join(lines).encode()
    else:
        raw = bytearray(text.encode())
        for _ in range(data.draw(st.integers(1, 20))):
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
        mutated = bytes(raw)
    try:
        motion, _ = parse_bvh(mutated, "mutated.bvh")
    except BvhError as error:
        assert str(error).startswith("mutated.bvh") and "\n" not in str(error)
        return
    assert np.all(np.isfinite(motion.rotations)) and np.all(np.isfinite(motion.translations))
    assert motion.num_frames >= 1


_TEXT_CACHE: dict[str, str] = {}


def _walk_text(clip: ClipRef) -> str:
    if clip.name not in _TEXT_CACHE:
        from elastyle.io.bvh_write import bvh_text

        motion, layout = clip.read()
        _TEXT_CACHE[clip.name] = bvh_text(motion.slice(0, 20), layout)
    return _TEXT_CACHE[clip.name]


@pytest.mark.slow
def test_same_transfer_is_byte_identical_across_processes(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    style = clip_named(dataset_clips, "dataset-2_walk_active_010").name
    outputs = []
    for k in range(2):
        out = tmp_path / f"o{k}.bvh"
        result = subprocess.run(
            [sys.executable, "-m", "elastyle.cli", "transfer", walk, "--style", style, "-o", str(out)],
            capture_output=True, text=True,
        )  # fmt: skip
        assert result.returncode == 0, result.stderr
        outputs.append(out.read_bytes())
    assert outputs[0] == outputs[1]


def test_an_empty_content_and_a_malformed_scheduler_are_usage_errors(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """An empty path (an unset shell variable) read as the current folder and transferred every clip under
    it; a scheduler address without a port was an internal error."""
    walk, proud = _dataset_copies(
        tmp_path / "clips", dataset_clips, ["dataset-2_walk_normal_005", "dataset-2_walk_active_010"]
    )
    result = _cli("transfer", "", "--style", str(proud), "-o", str(tmp_path / "out") + "/")
    assert result.returncode == 2 and "the content: an empty path" in result.stderr, result.stderr
    result = _cli(
        "transfer", str(walk), str(proud), "--style", str(proud), "-o", str(tmp_path / "out") + "/",
        "--scheduler", "nonsense",
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    assert (
        "--scheduler nonsense: not a scheduler's address" in result.stderr
        and "Traceback" not in result.stderr
    )
    assert not (tmp_path / "out").exists()


def test_a_stated_unit_that_makes_the_body_a_giant_is_questioned(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    walk, active = _dataset_copies(
        tmp_path / "clips", dataset_clips, ["dataset-2_walk_normal_005", "dataset-2_walk_active_010"]
    )
    result = _cli(
        "transfer", str(walk), "--style", str(active), "-o", str(tmp_path / "x.bvh"), "--units", "m"
    )
    assert result.returncode == 0 and "the body stands 146 m tall: is that its unit?" in result.stderr
    result = _cli(
        "transfer", str(walk), "--style", str(active), "-o", str(tmp_path / "y.bvh"), "--units", "cm"
    )
    assert result.returncode == 0 and "is that its unit" not in result.stderr


def _dataset_copies(folder: Path, dataset_clips: list[ClipRef], stems: list[str]) -> list[Path]:
    """Real dataset clips written to `folder` (a test's temporary folder, never the project)."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem in stems:
        path = folder / f"{stem}.bvh"
        path.write_bytes(clip_named(dataset_clips, stem).data())
        paths.append(path)
    return paths


def test_eval_refuses_wrong_arguments_before_any_work(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    data = str(tmp_path / "missing.zip")  # never read: each case is refused first
    for args, message in [
        (["--benchmark", data, "--pairs", "0"], "--pairs: must be at least 1"),
        (["--benchmark", data, "--pairs", "-1"], "--pairs: must be at least 1"),
        (["out.bvh", "--benchmark", data], "--benchmark takes one DATA"),  # two data folders, as a user gave
        (["out.bvh", "--content", "c.bvh", "--style", "s.bvh", "--benchmark", data], "not both"),
        (["out.bvh", "--content", "c.bvh", "--style", "s.bvh", "--out", str(tmp_path)], "needs --benchmark"),
        # the last of several used to be taken silently
        (
            ["out.bvh", "--content", "c.bvh", "--style", "a.bvh", "--style", "b.bvh"],
            "--style is given 2 times",
        ),
        (
            ["out.bvh", "--content", "c.bvh", "--content", "d.bvh", "--style", "s.bvh"],
            "--content is given 2 times",
        ),
        (["out.bvh", "--content", "c.bvh", "--style", ""], "--style is empty"),
    ]:
        result = _cli("eval", *args)
        assert result.returncode == 2 and message in result.stderr, (args, result.stderr)
    report = tmp_path / "report"
    report.mkdir()
    (report / "benchmark.md").write_text("mine")
    result = _cli("eval", "--benchmark", data, "--out", str(report))
    assert result.returncode == 1 and "benchmark.md: already exists" in result.stderr
    assert (report / "benchmark.md").read_text() == "mine"
    # a folder too small for the benchmark's classifiers: one line, no traceback
    few = tmp_path / "few"
    _dataset_copies(few, dataset_clips, ["dataset-2_walk_normal_005", "dataset-2_walk_active_010"])
    result = _cli("eval", "--benchmark", str(few), "--pairs", "1")
    assert result.returncode == 1 and "classifiers need training takes" in result.stderr, result.stderr
    assert result.stderr.count("elastyle: error:") == 1 and "Traceback" not in result.stderr
    # clips of another skeleton than the model's (the left arm dropped): one line naming a clip and what
    # differs (before, an IndexError from the classifiers)
    other = tmp_path / "other"
    other.mkdir()
    for stem in ("dataset-2_raise-up-both-hands_normal_005", "dataset-2_raise-up-both-hands_active_010"):
        write_bvh(other / f"{stem}.bvh", _without_left_arm(clip_named(dataset_clips, stem).read()[0]))
    result = _cli("eval", "--benchmark", str(other), "--pairs", "1")
    assert (
        result.returncode == 1
        and "skeleton differs from the model (only in the model: " in result.stderr
        and "Hand_L" in result.stderr
    )
    assert result.stderr.count("elastyle: error:") == 1 and "Traceback" not in result.stderr


def _without_left_arm(motion: Motion) -> Motion:
    """The clip on its skeleton without the left arm: another skeleton than the model's, which it cannot read."""
    from elastyle import Skeleton

    skeleton = motion.skeleton
    arm = ("Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L")
    keep = [j for j, name in enumerate(skeleton.names) if name not in arm]
    new_index = {old: new for new, old in enumerate(keep)}
    parents = np.array([new_index.get(int(skeleton.parents[j]), -1) for j in keep])
    subset = Skeleton(
        tuple(skeleton.names[j] for j in keep), parents, skeleton.offsets[keep], skeleton.end_sites[keep]
    )
    return Motion(subset, motion.rotations[:, keep], motion.translations[:, keep], motion.fps)


@pytest.mark.slow
def test_eval_benchmark_json_is_strict_json(tmp_path: Path, data_path: Path) -> None:
    """`eval --benchmark --json` prints the report as JSON (it printed the Markdown table), undefined
    figures as null."""
    import json

    result = _cli("eval", "--benchmark", str(data_path), "--pairs", "1", "--json")
    assert result.returncode == 0, result.stderr

    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} is not strict JSON")

    report = json.loads(result.stdout, parse_constant=refuse)
    assert {"pairs", "rows", "classifier_held_out_accuracy"} <= report.keys()


def test_content_folders_globs_and_a_refused_batch(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walks = _dataset_copies(
        tmp_path / "walks", dataset_clips, ["dataset-2_walk_normal_005", "dataset-2_walk_normal_010"]
    )
    style = _dataset_copies(tmp_path / "style", dataset_clips, ["dataset-2_walk_active_010"])[0]
    for spec, folder in ((str(tmp_path / "walks"), "a"), (str(tmp_path / "walks" / "*_010.bvh"), "b")):
        result = _cli("transfer", spec, "--style", str(style), "-o", f"{tmp_path / folder}/")
        assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == sorted(p.name for p in walks)
    assert [p.name for p in (tmp_path / "b").iterdir()] == [walks[1].name]
    # two contents that would share an output: refused naming both, and no output folder is left behind
    other = _dataset_copies(tmp_path / "other", dataset_clips, ["dataset-2_walk_normal_005"])[0]
    result = _cli("transfer", str(walks[0]), str(other), "--style", str(style), "-o", f"{tmp_path / 'c'}/")
    assert result.returncode == 1 and str(other) in result.stderr and str(walks[0]) in result.stderr
    assert not (tmp_path / "c").exists()


def test_a_batch_writes_an_explain_record_per_output(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    # a batch refused --explain altogether; a pipeline auditing one had to run every clip alone
    walks = _dataset_copies(
        tmp_path / "walks", dataset_clips, ["dataset-2_walk_normal_005", "dataset-2_walk_normal_010"]
    )
    style = _dataset_copies(tmp_path / "style", dataset_clips, ["dataset-2_walk_active_010"])[0]
    out, records = tmp_path / "out", tmp_path / "records"
    done = _cli("transfer", str(tmp_path / "walks"), "--style", str(style), "-o", f"{out}/", "--explain",
                f"{records}/", "--jobs", "2")  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in records.iterdir()) == sorted(w.stem + ".json" for w in walks)
    single = tmp_path / "single.json"
    alone = _cli("transfer", str(walks[1]), "--style", str(style), "-o", str(tmp_path / "single.bvh"),
                 "--explain", str(single))  # fmt: skip
    assert alone.returncode == 0, alone.stderr
    batch_record = json.loads((records / f"{walks[1].stem}.json").read_text())
    assert batch_record["output"] == str(out / f"{walks[1].stem}.bvh")
    assert batch_record["styles"] == json.loads(single.read_text())["styles"]  # the same record as alone
    refused = _cli("transfer", str(tmp_path / "walks"), "--style", str(style), "-o", f"{tmp_path / 'o2'}/",
                   "--explain", str(tmp_path / "ex.json"))  # fmt: skip
    assert refused.returncode == 2 and f"give a folder (--explain {tmp_path / 'ex'}/)" in refused.stderr


def test_demo_refuses_before_writing_anything(tmp_path: Path, data_path: Path) -> None:
    folder = tmp_path / "demo"
    folder.mkdir()
    (folder / "active_rigid.json").write_text("mine")
    result = _cli("demo", "--data", str(data_path), "-o", str(folder), "--no-render")
    assert result.returncode == 1 and "active_rigid.json: already exists" in result.stderr
    assert [p.name for p in folder.iterdir()] == ["active_rigid.json"]


def test_contradicting_transfer_options_exit_2(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    # two clips after one --style: the hint to repeat it (it was argparse's bare 'unrecognized arguments')
    result = _cli("transfer", str(good), "--style", str(good), str(good), "-o", str(tmp_path / "x.bvh"))
    assert (
        result.returncode == 2 and f"give each style clip its own --style (--style {good})" in result.stderr
    )
    for flags, message in [
        (["--style-part", f"left-arm={good}", "--keep-part", "arms"], "left-arm: both kept"),
        (["--skip-existing", "--force"], "not both"),
    ]:
        result = _cli("transfer", str(good), "--style", str(good), "-o", str(tmp_path / "x.bvh"), *flags)
        assert result.returncode == 2 and message in result.stderr, (flags, result.stderr)
    assert not (tmp_path / "x.bvh").exists()


def test_info_takes_several_clips(tmp_path: Path) -> None:
    for name in ("a.bvh", "b.bvh"):
        (tmp_path / name).write_text(GOOD)
    result = _cli("info", str(tmp_path / "a.bvh"), str(tmp_path / "b.bvh"))
    assert result.returncode == 0 and result.stdout.count("frames:   3") == 2


def test_train_refuses_wrong_values_and_outputs_before_training(tmp_path: Path) -> None:
    clip = tmp_path / "clip.bvh"
    clip.write_text(GOOD)
    model = str(tmp_path / "m.npz")
    for flags, message in [
        ([], "give a training budget"),
        (["--steps", "0"], "--steps must be at least 1"),
        (["--minutes", "0"], "--minutes must be a positive number"),
        (["--minutes", "nan"], "--minutes must be a positive number"),
        (["--steps", "5", "--batch-size", "0"], "--batch-size must be at least 1"),
        (["--steps", "5", "--kernel", "4"], "--kernel must be odd"),
        (["--steps", "5", "--lr", "-1"], "--lr must be a positive number"),
        (["--steps", "5", "--fps", "0"], "--fps must be a positive number"),
        (["--steps", "5", "--threads", "-1"], "--threads must be at least 1"),
        (["--steps", "5", "--window-s", "0"], "--window-s must be a positive number"),
        (["--steps", "5", "--position-loss", "-1"], "--position-loss must be 0 or more"),
    ]:
        result = _cli("train", str(clip), "-o", model, *flags)
        assert result.returncode == 2 and message in result.stderr, (flags, result.stderr)
    result = _cli("train", str(clip), "-o", str(clip), "--steps", "5", "--force")  # never over an input
    assert result.returncode == 2 and "give -o MODEL.npz" in result.stderr and clip.read_text() == GOOD
    (tmp_path / "m.npz.ckpt").write_text("an earlier training")
    result = _cli("train", str(clip), "-o", model, "--steps", "5")
    assert result.returncode == 1 and "continue it with --resume" in result.stderr
    result = _cli("train", str(clip), "-o", model, "--steps", "5", "--resume", str(tmp_path / "none.ckpt"))
    assert result.returncode == 1 and "no such checkpoint" in result.stderr
    assert not Path(model).exists()


@pytest.mark.slow
def test_train_gives_one_line_for_short_clips_and_foreign_checkpoints(tmp_path: Path) -> None:
    pytest.importorskip("torch", reason='training is an extra: pip install "elastyle[train]"')
    clip = tmp_path / "clip.bvh"
    clip.write_text(GOOD)  # 3 frames
    result = _cli("train", str(clip), "-o", str(tmp_path / "m.npz"), "--steps", "5")
    assert result.returncode == 1 and "no training clip has --kernel 15 frames" in result.stderr, (
        result.stderr
    )
    result = _cli("train", str(clip), "-o", str(tmp_path / "m.npz"), "--steps", "5", "--kernel", "1",
                  "--resume", str(clip))  # fmt: skip
    assert result.returncode == 1 and "not a training checkpoint" in result.stderr, result.stderr
    assert result.stderr.count("elastyle: error:") == 1 and "Traceback" not in result.stderr


def test_train_names_every_broken_clip_among_many_and_excludes_them_as_named(tmp_path: Path) -> None:
    """Two broken clips among many: both are named in one line (not one per run), and `--exclude` leaves them
    out under the name the error shows (with its extension or its folder: it had matched the bare name only)."""
    pytest.importorskip("torch", reason='training is an extra: pip install "elastyle[train]"')
    for take in range(1, 10):
        (tmp_path / f"clip_{take:03d}.bvh").write_text(GOOD)
    broken = tmp_path / "clip_011.bvh"  # a training take (numbers % 5 == 0 are held out)
    broken.write_text(GOOD.rstrip("\n").rsplit(" ", 3)[0] + "\n")  # its last row cut short
    wrong = tmp_path / "clip_012.bvh"
    wrong.write_text(GOOD.replace("0.0", "zero", 1))
    for take in (13, 14, 16, 17):  # more broken clips: every one is named, not the first few
        (tmp_path / f"clip_{take:03d}.bvh").write_text(GOOD.replace("0.0", "zero", 1))
    model = str(tmp_path / "m.npz")
    result = _cli("train", str(tmp_path), "-o", model, "--steps", "1", "--kernel", "1")
    assert result.returncode == 1 and "6 of 15 clip(s) could not be read" in result.stderr, result.stderr
    assert f"{broken}:" in result.stderr and f"{wrong}:" in result.stderr and "--exclude" in result.stderr
    assert all(f"clip_{take:03d}.bvh:" in result.stderr for take in (13, 14, 16, 17))
    assert result.stderr.count("elastyle: error:") == 1 and "internal error" not in result.stderr
    assert not Path(model).exists()
    cores = usable_cores()
    result = _cli("train", str(tmp_path), "-o", model, "--steps", "1", "--kernel", "1", "--threads", str(cores + 1),
                  "--exclude", "clip_011.bvh", "--exclude", f"{tmp_path.name}/clip_012.bvh",
                  "--exclude", "clip_01[3-7]")  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "clips: 6 of 15 left out by --exclude" in result.stderr
    assert f"--threads {cores + 1} on {cores} core(s)" in result.stderr  # more threads than cores slow it
    result = _cli("train", str(tmp_path), "-o", model, "--steps", "1", "--kernel", "1", "--threads", "1",
                  "--exclude", "clip_01[1-7]", "--exclude", "nothing_*", "--force")  # fmt: skip
    assert result.returncode == 0 and "--exclude nothing_* matches no clip" in result.stderr, result.stderr
    # one clip, a held-out take: trained on all the same, and said so
    result = _cli("train", str(tmp_path / "clip_005.bvh"), "-o", model, "--steps", "1", "--kernel", "1",
                  "--threads", "1", "--force")  # fmt: skip
    assert result.returncode == 0 and "every clip given is a held-out take" in result.stderr, result.stderr


def test_train_refuses_clips_of_one_skeleton_in_two_rest_poses(tmp_path: Path) -> None:
    pytest.importorskip("torch", reason='training is an extra: pip install "elastyle[train]"')
    (tmp_path / "clip_001.bvh").write_text(GOOD)
    other = tmp_path / "clip_002.bvh"  # the same joints, the spine pointing forward at rest
    other.write_text(
        GOOD.replace("JOINT spine\n  {\n    OFFSET 0 10 0", "JOINT spine\n  {\n    OFFSET 0 0 10")
    )
    assert other.read_text() != GOOD
    result = _cli("train", str(tmp_path), "-o", str(tmp_path / "m.npz"), "--steps", "1", "--kernel", "1")
    assert result.returncode == 1 and f"{other}: the joints of" in result.stderr, result.stderr
    assert "another rest pose" in result.stderr and result.stderr.count("elastyle: error:") == 1
    assert not (tmp_path / "m.npz").exists()


def test_calibrate_measures_held_out_takes_or_every_clip_given(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    import elastyle

    shipped = Path(elastyle.__file__).parent / "pretrained" / "bandai-namco-2.npz"
    clips = _dataset_copies(
        tmp_path / "mine", dataset_clips, ["dataset-2_walk_normal_001", "dataset-2_walk_active_002"]
    )
    result = _cli("calibrate", str(shipped), *map(str, clips), "-o", str(tmp_path / "m.npz"))
    assert result.returncode == 1 and "--all measures every clip given" in result.stderr
    result = _cli("calibrate", str(shipped), *map(str, clips), "-o", str(tmp_path / "m.npz"), "--all")
    assert result.returncode == 0 and "joint error median" in result.stderr, result.stderr
    assert (tmp_path / "m.npz").exists()


def test_a_content_of_another_skeleton_is_named_before_its_style(tmp_path: Path) -> None:
    content, style = tmp_path / "content.bvh", tmp_path / "style.bvh"
    content.write_text(GOOD)
    style.write_text(GOOD)
    result = _cli("transfer", str(content), "--style", str(style), "-o", str(tmp_path / "x.bvh"))
    assert result.returncode == 1 and f"{content}: skeleton differs from the model" in result.stderr


def test_content_paths_that_look_like_globs_and_resumed_single_outputs(
    tmp_path: Path, dataset_clips: list[ClipRef], data_path: Path
) -> None:
    walk = _dataset_copies(tmp_path, dataset_clips, ["dataset-2_walk_normal_005"])[0]
    bracketed = tmp_path / "take[1].bvh"  # a file name with glob characters is read as the file it names
    bracketed.write_bytes(walk.read_bytes())
    assert (
        _cli("transfer", str(bracketed), "--style", str(bracketed), "-o", str(tmp_path / "a.bvh")).returncode
        == 0
    )
    folder = f"{tmp_path / 'out'}/"
    assert _cli("transfer", str(walk), "--style", str(walk), "-o", folder).returncode == 0
    result = _cli("transfer", str(walk), "--style", str(walk), "-o", folder, "--skip-existing")
    assert result.returncode == 0 and "1 of 1 outputs exist and are skipped" in result.stderr, result.stderr
    if str(data_path).endswith(".zip"):  # a folder inside the archive names its clips
        from elastyle.cli.transfer import _content_clips

        assert len(_content_clips([f"{data_path}/bandai-namco-2/data"], [])) > 100


def test_a_resumed_batch_with_explain_records_leaves_half_written_pairs_and_says_so(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """An output without its explain record was skipped without a word, and a record without its output
    refused the whole batch; then it was counted as an output that exists, and the batch exited 0 without it."""
    names = ["dataset-2_walk_normal_005", "dataset-2_walk_normal_010", "dataset-2_walk_normal_015"]
    contents = _dataset_copies(tmp_path, dataset_clips, names)
    out, records = tmp_path / "out", tmp_path / "records"
    command = ["transfer", *map(str, contents), "--style", str(contents[0]), "-o", f"{out}/",
               "--explain", f"{records}/", "--jobs", "1"]  # fmt: skip
    assert _cli(*command).returncode == 0
    (records / f"{names[0]}.json").unlink()  # an output without its record
    (out / f"{names[1]}.bvh").unlink()  # a record without its output
    (out / f"{names[2]}.bvh").unlink()  # neither
    (records / f"{names[2]}.json").unlink()
    kept = (out / f"{names[0]}.bvh").read_bytes(), (records / f"{names[1]}.json").read_bytes()
    result = _cli(*command, "--skip-existing")
    assert result.returncode == 1, result.stderr  # an output is missing still
    assert f"{out / names[0]}.bvh exists but {records / names[0]}.json does not" in result.stderr
    assert f"{records / names[1]}.json exists but {out / names[1]}.bvh does not" in result.stderr
    assert "1 of 3 outputs exist and are skipped" in result.stderr
    assert result.stderr.strip().splitlines()[-1] == (
        f"elastyle: error: 1 output(s) not written, their explain records existing without them "
        f"({out / names[1]}.bvh): --force writes both anew"
    )
    assert (out / f"{names[2]}.bvh").exists() and (records / f"{names[2]}.json").exists()
    assert kept == ((out / f"{names[0]}.bvh").read_bytes(), (records / f"{names[1]}.json").read_bytes())


def test_a_batch_writing_inside_its_content_folder_does_not_read_its_own_outputs(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """A second run took the first one's outputs for contents ("... would both be written ...: rename
    one"), and a clip named twice (its folder and itself) was refused the same way."""
    clips = tmp_path / "clips"
    (clips / "walks").mkdir(parents=True)
    [walk] = _dataset_copies(clips / "walks", dataset_clips, ["dataset-2_walk_normal_005"])
    out = clips / "styled"
    command = [
        "transfer",
        str(clips),
        str(walk),
        "--style",
        str(walk),
        "-o",
        f"{out}/",
        "--explain",
        f"{out}/",
    ]
    first = _cli(*command)
    assert first.returncode == 0, first.stderr
    assert sorted(p.name for p in out.iterdir()) == [f"{walk.stem}.bvh", f"{walk.stem}.json"]
    again = _cli(*command, "--skip-existing")
    assert again.returncode == 0, again.stderr
    assert "1 clip(s) in the folder the outputs are written to" in again.stderr, again.stderr
    assert "1 of 1 outputs exist" in again.stderr
    assert _cli(*command, "--force").returncode == 0
    assert sorted(p.name for p in out.iterdir()) == [f"{walk.stem}.bvh", f"{walk.stem}.json"]
    # an output folder above the content folder reads the clips below it (only its own files are outputs)
    above = _cli("transfer", str(clips / "walks"), "--style", str(walk), "-o", f"{tmp_path}/")
    assert above.returncode == 0 and (tmp_path / f"{walk.stem}.bvh").exists(), above.stderr
    # a folder holding nothing but the outputs' is no content
    alone = _cli("transfer", str(out), "--style", str(walk), "-o", f"{out}/", "--force")
    assert alone.returncode == 2 and "are all the content found" in alone.stderr, alone.stderr


def test_an_unwritable_output_folder_is_refused_before_any_work(dataset_clips: list[ClipRef]) -> None:
    if not Path("/proc/self").is_dir():
        pytest.skip("needs /proc: a folder that exists but takes no new file")
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    style = clip_named(dataset_clips, "dataset-2_walk_elderly_010").name
    run = clip_named(dataset_clips, "dataset-2_run_normal_005").name
    for contents, out, folder in (
        ([walk], "/proc/elastyle-out.bvh", "/proc"),
        ([walk, run], "/proc/elastyle-out/", "/proc"),
    ):
        result = _cli("transfer", *contents, "--style", style, "-o", out)
        assert result.returncode == 1, result.stderr
        assert result.stderr.count("\n") == 1 and "transferred" not in result.stderr  # no transfer was run
        assert f"cannot write in {folder}" in result.stderr, result.stderr


def test_the_take_number_is_the_number_ending_any_file_name() -> None:
    from elastyle.io.dataset import ClipRef, is_held_out

    assert is_held_out(ClipRef("my_rig/walk_proud_005.bvh")) and is_held_out(ClipRef("take10.glb"))
    assert not is_held_out(ClipRef("my_rig/walk_proud_001.bvh")) and not is_held_out(ClipRef("take11.bvh"))
    assert is_held_out(ClipRef("dataset-2_walk_normal_005.bvh"))  # the dataset's own names as before
    names = [f"clip_{word}.bvh" for word in ("a", "b", "c", "d", "e", "f", "g", "h", "i", "j", "k", "l")]
    assert 0 < sum(is_held_out(ClipRef(name)) for name in names) < len(names)  # no number: by checksum


def test_one_number_ending_every_name_is_not_a_take() -> None:
    from elastyle.io.dataset import ClipRef, split_held_out

    dated = [
        ClipRef(f"{motion}_20240115.bvh") for motion in ("walk", "run", "jump", "wave", "bow", "sit", "kick")
    ]
    training, held_out = split_held_out(dated)
    assert training and held_out == [
        c for c in dated if c not in training
    ]  # by the names' hash, not all held out
    numbered = [ClipRef(f"walk_{take:03d}.bvh") for take in range(1, 11)]
    assert [c.name for c in split_held_out(numbered)[1]] == ["walk_005.bvh", "walk_010.bvh"]


def test_clip_labels_are_read_after_any_prefix() -> None:
    """The benchmark's labels come from names <content>_<style>_<take> after any prefix, so a user's own
    clips (hero_walk_proud_012.bvh) are benchmarked as the dataset's are (they were found to hold none)."""
    from elastyle.io.dataset import ClipRef, DatasetLabel, dataset_label

    assert dataset_label(ClipRef("dataset-2_walk_normal_005.bvh")) == DatasetLabel("walk", "normal", 5)
    assert dataset_label(ClipRef("rig/hero_walk-turn-left_normal_010.bvh")) == DatasetLabel(
        "walk-turn-left", "normal", 10
    )
    assert dataset_label(ClipRef("Hero_Walk_Proud_012.bvh")) == DatasetLabel("walk", "proud", 12)
    assert dataset_label(ClipRef("take10.bvh")) is None and dataset_label(ClipRef("walk_10.bvh")) is None


def test_eval_refuses_a_one_frame_clip_and_gives_undefined_figures_as_such(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """A clip of one frame has no speeds or steps: refused in one line (before, eval printed nan figures
    and exit 0). A figure a clip does not define (a standing wave has no cadence) is n/a, null in JSON."""
    import json

    walk, wave, style = _dataset_copies(
        tmp_path, dataset_clips,
        ["dataset-2_walk_normal_005", "dataset-2_wave-right-hand_normal_005", "dataset-2_walk_elderly_005"],
    )  # fmt: skip
    motion, layout = read_bvh(walk)
    single = tmp_path / "one_frame.bvh"
    write_bvh(single, motion.slice(0, 1), layout)
    for args in ([single, "--content", walk], [walk, "--content", single]):
        result = _cli("eval", *map(str, args), "--style", str(style))
        assert result.returncode == 1, result.stderr
        assert "one_frame.bvh: 1 frame(s); eval needs at least 2" in result.stderr
        assert "Traceback" not in result.stderr
    result = _cli("eval", str(wave), "--content", str(wave), "--style", str(style), "--json")
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout)  # strict JSON: no bare NaN
    assert figures["cadence_content_steps_s"] is None and figures["cadence_style_steps_s"] > 0
    text = _cli("eval", str(wave), "--content", str(wave), "--style", str(style))
    assert "n/a" in text.stdout and "nan" not in text.stdout
    # a one-second walk holds less than a step cycle, a content that holds still no jitter to compare with:
    # n/a (before, a cadence read from the clip's length and a jitter ratio of 1e12)
    short, still = tmp_path / "short.bvh", tmp_path / "still.bvh"
    write_bvh(short, motion.slice(0, 31), layout)
    index = np.zeros(60, dtype=np.int64)
    write_bvh(
        still,
        Motion(motion.skeleton, motion.rotations[index], motion.translations[index], motion.fps),
        layout,
    )
    figures = json.loads(
        _cli("eval", str(short), "--content", str(short), "--style", str(style), "--json").stdout
    )
    assert figures["cadence_content_steps_s"] is None and figures["timing_error"] is None
    figures = json.loads(
        _cli("eval", str(walk), "--content", str(still), "--style", str(style), "--json").stdout
    )
    assert figures["jitter_vs_content"] is None and figures["cadence_output_steps_s"] > 0


def test_convert_mirror_names_the_file_and_warns_of_a_side_without_its_partner(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """A clip with no left/right pairs is refused naming its file; one whose left hand was renamed (no
    partner for either hand) is mirrored with a warning naming both joints (before: silently, the hands
    reflected in place instead of swapped)."""
    (walk,) = _dataset_copies(tmp_path, dataset_clips, ["dataset-2_walk_normal_005"])
    renamed = tmp_path / "renamed.bvh"
    renamed.write_text(walk.read_text().replace("Hand_L", "Paw_L"))
    result = _cli("convert", str(renamed), "-o", str(tmp_path / "m.bvh"), "--mirror")
    assert result.returncode == 0, result.stderr
    assert "renamed.bvh: joint(s) Paw_L, Hand_R name a side but have no partner" in result.stderr
    plain = _cli("convert", str(walk), "-o", str(tmp_path / "w.bvh"), "--mirror")
    assert plain.returncode == 0 and "warning" not in plain.stderr
    sideless = tmp_path / "sideless.bvh"
    sideless.write_text(walk.read_text().replace("_L", "_A").replace("_R", "_B"))
    refused = _cli("convert", str(sideless), "-o", str(tmp_path / "s.bvh"), "--mirror")
    assert refused.returncode == 1 and "sideless.bvh: cannot mirror" in refused.stderr
    assert not (tmp_path / "s.bvh").exists()


def test_a_zip_where_one_clip_belongs_is_named_as_such(tmp_path: Path) -> None:
    """convert takes one clip: a zip archive given for it is answered with how to name a clip inside it
    (before: 'binary data, not a BVH text file', of an archive other commands read)."""
    import zipfile

    archive = tmp_path / "clips.zip"
    with zipfile.ZipFile(archive, "w") as out:
        out.writestr("clips/a.bvh", "HIERARCHY\n")
    result = _cli("convert", str(archive), "-o", str(tmp_path / "a.bvh"))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "clips.zip: a zip archive, not a BVH file: name one clip inside it" in result.stderr


def test_output_folders_that_are_files_all_failed_batches_and_a_skipped_single_output(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """-o FILE/ where FILE is a file: one line saying so (it was a raw '[Errno 17] File exists'); a batch
    whose every clip fails leaves no empty folder behind; --skip-existing leaves one content's existing
    output (it refused it: 'already exists')."""
    walk, style = _dataset_copies(
        tmp_path, dataset_clips, ["dataset-2_walk_normal_005", "dataset-2_walk_active_010"]
    )
    afile = tmp_path / "afile"
    afile.write_text("mine")
    for contents in ([walk], [walk, walk.with_name("other.bvh")]):
        result = _cli("transfer", *map(str, contents), "--style", str(style), "-o", f"{afile}/")
        assert result.returncode == 1 and f"{afile}: a file, not a folder" in result.stderr, result.stderr
    assert afile.read_text() == "mine"
    bad = [tmp_path / "bad1.bvh", tmp_path / "bad2.bvh"]
    for path in bad:
        path.write_text("HIERARCHY\nROOT Hips\n{\n")
    result = _cli("transfer", *map(str, bad), "--style", str(style), "-o", f"{tmp_path / 'out'}/")
    assert result.returncode == 1 and "0 of 2 clips transferred" in result.stderr, result.stderr
    assert not (tmp_path / "out").exists()
    result = _cli("transfer", str(bad[0]), "--style", str(style), "-o", f"{tmp_path / 'one'}/")
    assert result.returncode == 1 and not (tmp_path / "one").exists()
    existing = tmp_path / "existing.bvh"
    existing.write_text("mine")
    result = _cli("transfer", str(walk), "--style", str(style), "-o", str(existing), "--skip-existing")
    assert result.returncode == 0 and existing.read_text() == "mine", result.stderr


@pytest.mark.slow
def test_training_clips_of_one_skeleton_under_two_namings_train_together(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """A training folder whose clips are one skeleton, some exported with `mixamorig:` names: trained as one
    skeleton under the first clip's names, with a note (it was refused: 'skeleton differs'), as a transfer
    reads such clips."""
    stems = ["dataset-2_walk_normal_001", "dataset-2_walk_active_001", "dataset-2_run_normal_001"]
    folder = tmp_path / "clips"
    _dataset_copies(folder, dataset_clips, stems)
    renamed = folder / stems[-1].replace("normal", "renamed")
    text = (folder / f"{stems[-1]}.bvh").read_text()
    for name in read_bvh(folder / f"{stems[-1]}.bvh")[0].skeleton.names:
        text = re.sub(rf"(ROOT|JOINT) {re.escape(name)}\b", rf"\1 mixamorig:{name}", text)
    renamed.with_suffix(".bvh").write_text(text)
    model = tmp_path / "m.npz"
    result = _cli("train", str(folder), "-o", str(model), "--steps", "2")
    assert result.returncode == 0, result.stderr
    assert "name their joints otherwise than" in result.stderr and model.exists()


def test_a_bind_pose_before_the_motion_is_noted(
    dataset_clips: list[ClipRef],
    caplog: pytest.LogCaptureFixture,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # many exporters write the rig's bind pose as frame 0; it was read as a frame of the motion, a 176-degree
    # jump into the next, without a word (as a style clip it moved the chosen windows, the output 28 cm apart)
    from elastyle.pipeline import transfer

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0].slice(0, 90)
    style = clip_named(dataset_clips, "dataset-2_walk_elderly_010").read()[0]
    posed = Motion(
        walk.skeleton,
        np.concatenate([np.zeros_like(walk.rotations[:1]), walk.rotations]),
        np.concatenate([walk.translations[:1], walk.translations]),
        walk.fps,
    )
    with caplog.at_level("WARNING", logger="elastyle"):
        notes = transfer(posed, posed, content_name="posed.bvh", style_names=["posed_style.bvh"]).explain[
            "notes"
        ]
    assert any("posed.bvh: its first frame is a pose apart from its motion" in note for note in notes), notes
    assert "posed_style.bvh: its first frame is a pose apart" in caplog.text
    assert not any("pose apart" in note for note in transfer(walk, style).explain["notes"])
    # on the command line, said again when the style library comes from the cache (it was said only once)
    write_bvh(tmp_path / "posed_style.bvh", posed)
    write_bvh(tmp_path / "walk.bvh", walk)
    monkeypatch.setenv("ELASTYLE_CACHE", str(tmp_path / "cache"))
    for run in range(2):
        done = _cli("transfer", str(tmp_path / "walk.bvh"), "--style", str(tmp_path / "posed_style.bvh"),
                    "-o", str(tmp_path / f"out{run}.bvh"))  # fmt: skip
        assert done.returncode == 0 and "posed_style.bvh: its first frame is a pose apart" in done.stderr, run


def test_a_cache_setting_naming_a_file_is_said(
    tmp_path: Path, dataset_clips: list[ClipRef], monkeypatch: pytest.MonkeyPatch
) -> None:
    # ELASTYLE_CACHE naming a file: every library was encoded again, without a word
    walk = _dataset_copies(tmp_path, dataset_clips, ["dataset-2_walk_normal_005"])[0]
    (tmp_path / "cachefile").write_text("")
    monkeypatch.setenv("ELASTYLE_CACHE", str(tmp_path / "cachefile"))
    done = _cli("transfer", str(walk), "--style", str(walk), "-o", str(tmp_path / "out.bvh"))
    assert done.returncode == 0 and "cannot write the style cache in" in done.stderr, done.stderr
    assert done.stderr.count("cannot write the style cache") == 1
