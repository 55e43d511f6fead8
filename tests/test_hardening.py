"""Hardening: special files and oversized inputs refused, values checked, inputs never overwritten, one
winner among racing writers, no temporary file left for good, nothing non-finite written."""

from __future__ import annotations

import json
import multiprocessing
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastyle import BvhError, read_bvh, write_bvh
from elastyle.core.motion import Motion
from elastyle.errors import OutputError
from elastyle.io.dataset import ClipRef
from elastyle.io.files import write_bytes_atomic
from tests.conftest import THREE_CHANNEL_BVH, clip_named

GOOD = THREE_CHANNEL_BVH


def _cli(
    *args: str, env: dict[str, str] | None = None, timeout: float = 60
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "elastyle.cli", *args],
        capture_output=True, text=True, timeout=timeout, env={**os.environ, **(env or {})},
    )  # fmt: skip


def _one_line_naming(result: subprocess.CompletedProcess[str], name: str, words: str) -> None:
    line = result.stderr.strip()
    assert "\n" not in line and "Traceback" not in line, result.stderr
    assert name in line and words in line, line


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this system")
@pytest.mark.parametrize("role", ["content", "style", "model"])
def test_a_pipe_is_refused_not_waited_on(tmp_path: Path, role: str) -> None:
    pipe = tmp_path / "pipe.bvh"
    os.mkfifo(pipe)
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    content, style = (pipe, good) if role == "content" else (good, pipe if role == "style" else good)
    extra = ["--model", str(pipe)] if role == "model" else []
    result = _cli(
        "transfer", str(content), "--style", str(style), "-o", str(tmp_path / "o.bvh"), *extra, timeout=20
    )
    assert result.returncode == 1
    _one_line_naming(result, "pipe.bvh", "not a regular file")


def test_a_device_is_refused() -> None:
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero here")
    result = _cli("info", "/dev/zero", timeout=20)
    assert result.returncode == 1
    _one_line_naming(result, "/dev/zero", "not a regular file")


def test_size_limit_and_its_override(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    result = _cli("info", str(good), env={"ELASTYLE_MAX_INPUT_MB": "0.0001"})
    assert result.returncode == 1
    _one_line_naming(result, "good.bvh", "ELASTYLE_MAX_INPUT_MB")
    assert _cli("info", str(good), env={"ELASTYLE_MAX_INPUT_MB": "1"}).returncode == 0


def test_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    plain, marked = tmp_path / "plain.bvh", tmp_path / "marked.bvh"
    plain.write_text(GOOD)
    marked.write_bytes(b"\xef\xbb\xbf" + GOOD.encode())
    np.testing.assert_array_equal(read_bvh(marked)[0].rotations, read_bvh(plain)[0].rotations)


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("1 20 0 90", "1 20 0 3.5e38", "value beyond"),
        ("Frame Time: 0.0083333", "Frame Time: 1e-320", "frame time must lie between"),
        ("OFFSET 0 10 0", "OFFSET 0 3.5e38 0", "value beyond"),
    ],
)
def test_values_out_of_range_are_refused(tmp_path: Path, old: str, new: str, words: str) -> None:
    assert old in GOOD
    bad = tmp_path / "bad.bvh"
    bad.write_text(GOOD.replace(old, new, 1))
    with pytest.raises(BvhError, match=words):
        read_bvh(bad)


def test_a_thousand_joints_deep_hierarchy_reads(tmp_path: Path) -> None:
    depth = 1000
    text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    text += "".join(
        f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for k in range(1, depth)
    )
    text += "End Site\n{\nOFFSET 0 1 0\n}\n" + "}\n" * depth
    text += "MOTION\nFrames: 2\nFrame Time: 0.033333\n" + (" ".join(["0"] * (3 + 3 * depth)) + "\n") * 2
    deep = tmp_path / "deep.bvh"
    deep.write_text(text)
    for args in (["info", str(deep)], ["convert", str(deep), "-o", str(tmp_path / "again.bvh")],
                 ["convert", str(deep), "-o", str(tmp_path / "again.glb")]):  # fmt: skip
        result = _cli(*args)
        assert result.returncode == 0, result.stderr
    motion = read_bvh(deep)[0]
    again = read_bvh(tmp_path / "again.bvh")[0]
    assert again.skeleton.names == motion.skeleton.names
    np.testing.assert_allclose(again.positions(), motion.positions(), atol=1e-9)
    assert motion.skeleton.num_joints == depth
    assert motion.positions()[0, -1, 1] == pytest.approx(depth - 1)


def test_nothing_non_finite_is_written(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    motion, layout = read_bvh(good)
    rotations = motion.rotations.copy()
    rotations[1, 2, 0] = np.nan
    broken = Motion(motion.skeleton, rotations, motion.translations, motion.fps)
    out = tmp_path / "out.bvh"
    with pytest.raises(BvhError, match="NaN or infinite"):
        write_bvh(out, broken, layout)
    assert not out.exists() and list(tmp_path.iterdir()) == [good]


def test_a_model_with_a_nan_weight_is_refused_on_load(tmp_path: Path) -> None:
    from elastyle.model.file import default_model_path

    with np.load(default_model_path()) as archive:
        arrays = {key: archive[key] for key in archive.files}
    arrays["weight_conv1"] = arrays["weight_conv1"].copy()
    arrays["weight_conv1"][0, 0, 0] = np.nan
    model = tmp_path / "nan.npz"
    np.savez(model, **arrays)
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    result = _cli(
        "transfer", str(good), "--style", str(good), "-o", str(tmp_path / "o.bvh"), "--model", str(model)
    )
    assert result.returncode == 1
    _one_line_naming(result, "nan.npz", "weight_conv1 holds NaN")
    assert not (tmp_path / "o.bvh").exists()


@pytest.mark.slow
def test_force_never_overwrites_an_input(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    content, style = tmp_path / "content.bvh", tmp_path / "style.bvh"
    content.write_bytes(clip_named(dataset_clips, "dataset-2_walk_normal_005").data())
    style.write_bytes(clip_named(dataset_clips, "dataset-2_walk_active_010").data())
    before = {p: p.read_bytes() for p in (content, style)}
    out = tmp_path / "out.bvh"
    cases = [
        ["-o", str(style)],
        ["-o", str(content)],
        ["-o", str(out), "--explain", str(content)],
        ["-o", str(out), "--explain", str(out)],
        ["-o", str(tmp_path / ".." / tmp_path.name / "style.bvh")],
    ]
    for case in cases:
        result = _cli("transfer", str(content), "--style", str(style), *case, "--force")
        assert result.returncode == 1, (case, result.stderr)
        _one_line_naming(result, "", "would overwrite")
    assert {p: p.read_bytes() for p in before} == before
    assert not out.exists()


def _race(path: str, tag: str, start: multiprocessing.synchronize.Event, wins: multiprocessing.Queue) -> None:  # type: ignore[type-arg]
    start.wait()
    try:
        write_bytes_atomic(path, tag.encode() * 50_000)
        wins.put(tag)
    except OutputError:
        wins.put("")


def test_of_two_racing_writers_exactly_one_wins(tmp_path: Path) -> None:
    context = multiprocessing.get_context("fork" if sys.platform != "win32" else "spawn")
    for trial in range(20):
        target = tmp_path / f"out{trial}.bvh"
        start, wins = context.Event(), context.Queue()
        writers = [context.Process(target=_race, args=(str(target), tag, start, wins)) for tag in "ab"]
        for writer in writers:
            writer.start()
        start.set()
        for writer in writers:
            writer.join()
        winners = [w for w in (wins.get(), wins.get()) if w]
        assert len(winners) == 1, trial
        assert target.read_bytes() == winners[0].encode() * 50_000
    assert not [p for p in tmp_path.iterdir() if p.suffix == ".tmp"]


def test_a_killed_writers_temporary_file_is_removed_by_the_next_write(tmp_path: Path) -> None:
    target = tmp_path / "out.bvh"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    stale = tmp_path / f".out.bvh.{int(dead.stdout)}.0123abcd.tmp"
    stale.write_text("half a file")
    other = tmp_path / "keep.tmp"
    other.write_text("not ours")
    write_bytes_atomic(target, b"whole")
    assert not stale.exists() and other.exists() and target.read_bytes() == b"whole"


@pytest.mark.parametrize(
    "contents, output, words",
    [(1, "", "-o/--output is empty"), (2, "two.bvh", "need an output folder")],
)
def test_output_mistakes_exit_2(tmp_path: Path, contents: int, output: str, words: str) -> None:
    clips = [tmp_path / f"good{k}.bvh" for k in range(contents)]  # two files: one named twice is read once
    for clip in clips:
        clip.write_text(GOOD)
    result = subprocess.run(
        [sys.executable, "-m", "elastyle.cli", "transfer", *map(str, clips), "--style", str(clips[0]), "-o", output],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2 and words in result.stderr, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [clip.name for clip in clips]


def test_convert_refuses_an_absurd_frame_rate(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    result = _cli("convert", str(good), "-o", str(tmp_path / "o.bvh"), "--fps", "1e12")
    assert result.returncode == 2 and "--fps" in result.stderr


def test_a_skeleton_mismatch_says_how_to_get_a_model(tmp_path: Path) -> None:
    good = tmp_path / "good.bvh"
    good.write_text(GOOD)
    result = _cli("transfer", str(good), "--style", str(good), "-o", str(tmp_path / "o.bvh"))
    assert result.returncode == 1
    _one_line_naming(result, "good.bvh", "elastyle train")
    assert "--model" in result.stderr


@pytest.mark.slow
def test_a_shortened_patch_is_noted_and_recorded(tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005")
    style_text = clip_named(dataset_clips, "dataset-2_walk_active_010").data().decode()
    head, frames = style_text.split("Frame Time:")
    rows = frames.split("\n")

    def style_of(frame_count: int) -> Path:
        path = tmp_path / f"style_{frame_count}.bvh"
        path.write_text(
            head.replace(head.split("Frames:")[1].split("\n")[0], f" {frame_count}")
            + "Frame Time:"
            + "\n".join(rows[: frame_count + 1])
            + "\n"
        )
        return path

    explain = tmp_path / "o.json"
    result = _cli(  # 28 frames: nearly a patch
        "transfer",
        walk.name,
        "--style",
        str(style_of(28)),
        "-o",
        str(tmp_path / "o.bvh"),
        "--explain",
        str(explain),
    )
    assert result.returncode == 0, result.stderr
    assert re.search(r"note: \S*style_28.bvh: the style clips are at most 0.93 s long", result.stderr)
    record = json.loads(explain.read_text())
    assert record["styles"][0]["patch_s_used"] == pytest.approx(28 / 30, abs=1e-3)
    assert record["notes"] and "instead of --patch-s 1" in record["notes"][0]
    # a longer patch asked: the same clip is as short against a default patch, so the same note (it was a
    # warning under --patch-s 2)
    result = _cli(
        "transfer", walk.name, "--style", str(style_of(28)), "-o", str(tmp_path / "p2.bvh"), "--patch-s", "2"
    )
    assert result.returncode == 0 and re.search(
        r"note: \S*style_28.bvh: the style clips are at most 0.93 s", result.stderr
    )
    # a style clip under 0.9 of a patch, less than a stride (its windows make the feet slide: a walk given 20
    # frames of another skated 15 to 38 cm/s) or far less: a warning that says what it costs, not a note
    for frame_count, seconds in ((20, "0.67"), (5, "0.17")):
        result = _cli("transfer", walk.name, "--style", str(style_of(frame_count)), "-o", str(tmp_path / "t.bvh"),
                      "--force")  # fmt: skip
        assert result.returncode == 0 and re.search(
            rf"warning: \S*style_{frame_count}.bvh: the style clips are at most {seconds} s long",
            result.stderr,
        )
        assert "give a style clip at least as long as --patch-s" in result.stderr
    # a long patch asked of a style clip a little longer than a default one: a note, not the warning that its
    # windows are short (it said so of 13 s windows under --patch-s 60)
    result = _cli("transfer", walk.name, "--style", str(style_of(40)), "-o", str(tmp_path / "l.bvh"), "--patch-s",
                  "60", "--force")  # fmt: skip
    assert result.returncode == 0 and re.search(
        r"note: \S*style_40.bvh: the style clips are at most 1.33 s", result.stderr
    )
    assert "windows this short" not in result.stderr, result.stderr


@pytest.mark.slow
def test_the_same_bytes_at_one_and_two_blas_threads_cached_or_not(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    style = clip_named(dataset_clips, "dataset-2_walk_active_010").name
    outputs = []
    for threads, cache in (("1", "--no-cache"), ("2", "--no-cache"), ("2", "--force"), ("1", "--force")):
        out = tmp_path / f"out_{threads}{cache}.bvh"
        env = {name: threads for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
        env["ELASTYLE_CACHE"] = str(tmp_path / "cache")
        result = _cli("transfer", walk, "--style", style, "-o", str(out), cache, env=env)
        assert result.returncode == 0, result.stderr
        outputs.append(out.read_bytes())
    assert all(o == outputs[0] for o in outputs)


def test_the_style_cache_keeps_under_its_limit_dropping_the_least_recently_used(tmp_path: Path) -> None:
    from elastyle.steps.cache import prune_cache

    folder = tmp_path / "libraries"
    folder.mkdir()
    for index in range(5):  # 1 MB each, oldest first
        entry = folder / f"{index}.npz"
        entry.write_bytes(b"\0" * 2**20)
        os.utime(entry, (1000 + index, 1000 + index))
    os.utime(folder / "0.npz")  # just used: the most recent now
    prune_cache(folder, int(2.5 * 2**20), keep=folder / "4.npz")
    assert sorted(p.name for p in folder.iterdir()) == ["0.npz", "4.npz"]


@pytest.mark.slow
def test_a_cache_that_cannot_be_written_does_not_fail_a_transfer(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the cache folder should be")
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    out = tmp_path / "out.bvh"
    result = _cli("transfer", walk, "--style", walk, "-o", str(out), env={"ELASTYLE_CACHE": str(blocked)})
    assert result.returncode == 0, result.stderr
    assert out.exists()


def test_a_cache_entry_of_another_width_is_encoded_again(
    tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    import numpy as np

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    env = {"ELASTYLE_CACHE": str(tmp_path / "cache")}
    first = _cli("transfer", walk, "--style", walk, "-o", str(tmp_path / "a.bvh"), env=env)
    assert first.returncode == 0, first.stderr
    (entry,) = (tmp_path / "cache" / "libraries").iterdir()
    with np.load(entry) as archive:
        arrays = dict(archive)
    width = arrays["actions"].shape[1]  # 17 on this rig
    arrays["actions"] = np.zeros((len(arrays["actions"]), width - 4))  # as an older version's held
    np.savez(entry, **arrays)
    again = _cli("transfer", walk, "--style", walk, "-o", str(tmp_path / "b.bvh"), env=env)
    assert again.returncode == 0, again.stderr
    assert (tmp_path / "a.bvh").read_bytes() == (tmp_path / "b.bvh").read_bytes()


@pytest.mark.parametrize("damage", [b"", b"PK\x03\x04", "half", "header"])
def test_a_damaged_cache_entry_is_encoded_again(
    tmp_path: Path, dataset_clips: list[ClipRef], damage: bytes | str
) -> None:
    """An entry left empty or cut short (a full disk, a killed process) is read as a miss and replaced:
    before, every later transfer with that style failed with an internal error."""
    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").name
    env = {"ELASTYLE_CACHE": str(tmp_path / "cache")}
    first = _cli("transfer", walk, "--style", walk, "-o", str(tmp_path / "a.bvh"), env=env)
    assert first.returncode == 0, first.stderr
    (entry,) = (tmp_path / "cache" / "libraries").iterdir()
    whole = entry.read_bytes()
    if damage == "header":  # one byte of an array's header garbled (a tokenizer error in numpy's reader)
        at = whole.index(b"{'descr'")
        entry.write_bytes(whole[:at] + b"{'descr':(" + whole[at + 10 :])
    else:
        entry.write_bytes(whole[: len(whole) // 2] if damage == "half" else damage)  # type: ignore[arg-type]
    again = _cli("transfer", walk, "--style", walk, "-o", str(tmp_path / "b.bvh"), env=env)
    assert again.returncode == 0, again.stderr
    assert (tmp_path / "a.bvh").read_bytes() == (tmp_path / "b.bvh").read_bytes()
    assert entry.read_bytes() == whole  # the entry written again


def test_an_unreadable_size_limit_is_said_once(tmp_path: Path) -> None:
    """An ELASTYLE_MAX_INPUT_MB that is no number of megabytes: one warning for the command, however many
    files it reads (it came once per file read, 5 times for one transfer), and the default limit is used."""
    clips = []
    for name in ("a", "b", "c"):
        clips.append(tmp_path / f"{name}.bvh")
        clips[-1].write_text(GOOD)
    result = _cli("info", *map(str, clips), env={"ELASTYLE_MAX_INPUT_MB": "abc"})
    assert result.returncode == 0, result.stderr
    assert result.stderr.count("ELASTYLE_MAX_INPUT_MB=abc is not a number of megabytes") == 1, result.stderr
