"""The command line, as a user runs it: real clips in, files out, one-line errors, exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastyle import Motion, mirror, read_bvh, write_bvh
from elastyle.cli import main
from elastyle.io.dataset import ClipRef
from tests.conftest import THREE_CHANNEL_BVH, clip_named


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "elastyle.cli", *args], capture_output=True, text=True)


def _member(clip: ClipRef) -> str:
    return clip.name  # a path inside the zip archive or a file


@pytest.fixture
def walk(dataset_clips: list[ClipRef]) -> str:
    return _member(clip_named(dataset_clips, "dataset-2_walk_normal_005"))


@pytest.fixture
def style(dataset_clips: list[ClipRef]) -> str:
    return _member(clip_named(dataset_clips, "dataset-2_walk_exhausted_005"))


def test_info_prints_the_clip_facts(walk: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", walk]) == 0
    out = capsys.readouterr().out
    assert "joints:   22" in out and "30 fps" in out and "132 (6 per joint)" in out


def test_main_leaves_its_callers_kill_handler_as_it_was(walk: str) -> None:
    """A kill ends a command as Ctrl-C does, while it runs: main() inside a program gives the program's own
    handler back (it stayed, and a later kill raised KeyboardInterrupt in the program)."""
    import signal

    before = signal.getsignal(signal.SIGTERM)
    assert main(["info", walk]) == 0
    assert signal.getsignal(signal.SIGTERM) is before


def test_convert_resamples_and_mirrors(walk: str, tmp_path: Path, dataset_clips: list[ClipRef]) -> None:
    out = tmp_path / "mirrored60.bvh"
    assert main(["convert", walk, "-o", str(out), "--fps", "60", "--mirror"]) == 0
    text = out.read_text()
    assert "Frame Time: 0.0166667" in text
    expected = mirror(clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0]).resample(60)
    np.testing.assert_allclose(read_bvh(out)[0].positions(), expected.positions(), atol=1e-3)
    assert main(["convert", walk, "-o", str(out)]) == 1  # exists, no --force
    assert main(["convert", walk, "-o", str(out), "--force"]) == 0


def test_a_mirror_of_a_rotation_only_rig_stays_rotation_only(
    walk: str, tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """The mirror gave each joint the other side's offset, which a rig's left and right bones a little unlike
    leave apart from its own (the captured rig's by up to 0.4 mm, a studio rig's by more): every joint of a rig
    with rotation channels alone was written with position channels. A bone keeps its own offset, so the
    mirror stays on the rig, here one whose left leg is 2 % longer than its right."""
    from dataclasses import replace

    motion, layout = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()
    skeleton = motion.skeleton
    longer = [skeleton.names.index(name) for name in ("LowerLeg_L", "Foot_L", "Toes_L")]
    offsets = skeleton.offsets.copy()
    offsets[longer] *= 1.02
    translations = motion.translations.copy()
    translations[:, longer] = offsets[longer]
    motion = Motion(replace(skeleton, offsets=offsets), motion.rotations, translations, motion.fps)
    rotations_only = layout._replace(
        channels=(layout.channels[0], *(channels[3:] for channels in layout.channels[1:])),
        first_values=(),
    )
    rig = tmp_path / "rig.bvh"
    write_bvh(rig, motion, rotations_only)  # the root and the moving pelvis keep their position channels
    assert rig.read_text().count("CHANNELS 6") == 2
    out = tmp_path / "mirrored.bvh"
    assert main(["convert", str(rig), "-o", str(out), "--mirror"]) == 0
    assert out.read_text().count("CHANNELS 6") == 2
    mirrored = read_bvh(out)[0]
    np.testing.assert_allclose(mirrored.skeleton.offsets, offsets, atol=1e-5)  # as written, 6 decimals
    # the pose mirrored: each joint where its partner's reflection lies, but for the bones' lengths
    partner = skeleton.mirror_pairs()
    reflected = motion.positions()[:, partner] * np.array([-1.0, 1.0, 1.0])
    assert np.abs(mirrored.positions() - reflected).max() < 2.0  # cm: 2 % of a leg


def test_strength_zero_writes_the_contents_own_numbers(
    walk: str, style: str, tmp_path: Path, dataset_clips: list[ClipRef]
) -> None:
    """At strength 0 the output file holds the content file's numbers (its angles wrap at 180 degrees where
    it crosses them; before, 413 of its values were written a turn apart)."""
    out = tmp_path / "unchanged.bvh"
    assert main(["transfer", walk, "--style", style, "-o", str(out), "--strength", "0"]) == 0

    def numbers(text: str) -> np.ndarray:
        rows = text.split("Frame Time:")[1].split("\n", 1)[1].strip().split("\n")
        return np.array([[float(value) for value in row.split()] for row in rows])

    content = clip_named(dataset_clips, "dataset-2_walk_normal_005").data().decode()
    np.testing.assert_array_equal(numbers(out.read_text()), numbers(content))


def test_transfer_writes_bvh_and_explain(walk: str, style: str, tmp_path: Path, caplog) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "tired.bvh"
    explain = tmp_path / "tired.json"
    with caplog.at_level("INFO", logger="elastyle"):
        assert main(["transfer", walk, "--style", style, "-o", str(out), "--explain", str(explain)]) == 0
    assert f"wrote {explain} (the explain record)" in caplog.text  # said, as the clip is
    assert out.read_text().startswith("HIERARCHY")
    record = json.loads(explain.read_text())
    assert record["method"] == "elastic" and record["styles"][0]["patches"]
    written = read_bvh(str(out))[0]
    assert (record["output_frames"], record["output_fps"]) == (written.num_frames, written.fps)


def test_how_a_style_clip_is_read_is_said_and_recorded(
    walk: str, style: str, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A style clip under other joint names: the note on its reading is printed once and is in the explain
    record, from a fresh library and from the cache alike."""
    motion = read_bvh(style)[0]
    renamed = tmp_path / "renamed style.bvh"
    write_bvh(renamed, motion.renamed([f"bone{j}" for j in range(motion.skeleton.num_joints)]))
    for run in range(2):  # encoded, then read from the cache
        explain = tmp_path / f"run{run}.json"
        caplog.clear()
        with caplog.at_level("WARNING", logger="elastyle"):
            command = ["transfer", walk, "--style", str(renamed), "-o", str(tmp_path / f"run{run}.bvh")]
            assert main([*command, "--explain", str(explain)]) == 0
        said = [r.getMessage() for r in caplog.records if r.getMessage().startswith(f"note: {renamed}:")]
        assert len(said) == 1 and "joint names differ from the model's" in said[0]
        assert said == [
            n for n in json.loads(explain.read_text())["notes"] if n.startswith(f"note: {renamed}:")
        ]


def test_transfer_batch_into_folder(
    walk: str, style: str, dataset_clips: list[ClipRef], tmp_path: Path
) -> None:
    second = _member(clip_named(dataset_clips, "dataset-2_walk_normal_010"))
    assert main(["transfer", walk, second, "--style", style, "-o", str(tmp_path), "--method", "rigid"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "dataset-2_walk_normal_005.bvh",
        "dataset-2_walk_normal_010.bvh",
    ]


def test_batch_reports_a_bad_clip_and_finishes_the_others(
    walk: str, style: str, dataset_clips: list[ClipRef], tmp_path: Path
) -> None:
    bad = tmp_path / "bad.bvh"
    bad.write_text(THREE_CHANNEL_BVH)
    second = _member(clip_named(dataset_clips, "dataset-2_walk_normal_010"))
    out = tmp_path / "batch"
    result = run("transfer", walk, str(bad), second, "--style", style, "-o", f"{out}/")
    assert result.returncode == 1
    assert [line for line in result.stderr.splitlines() if "error" in line] == [
        f"elastyle: error: {bad}: skeleton differs from the model (only in the model: joint_Root, Hips, Spine, Chest, "
        "Neck, Head, Shoulder_L, UpperArm_L ...; only in this clip: pelvis, spine, LeftLeg, LeftFoot, RightLeg, RightFoot); "
        "for this skeleton, train a model on its clips with 'elastyle train CLIPS -o model.npz --recipe shipped "
        "--minutes 20' and pass it with --model model.npz"
    ]
    assert sorted(p.name for p in out.iterdir()) == [
        "dataset-2_walk_normal_005.bvh",
        "dataset-2_walk_normal_010.bvh",
    ]


def test_transfer_transition_and_blend(
    walk: str, style: str, dataset_clips: list[ClipRef], tmp_path: Path
) -> None:
    other = _member(clip_named(dataset_clips, "dataset-2_walk_active_005"))
    common = [walk, "--style", style, "--no-cleanup"]
    single, change, blend = (tmp_path / f"{name}.bvh" for name in ("single", "change", "blend"))
    assert main(["transfer", *common, "-o", str(single)]) == 0
    assert main(["transfer", *common, "--then-style", other, "--at", "2", "--over", "2", "-o", str(change),
                 "--explain", str(tmp_path / "change.json")]) == 0  # fmt: skip
    assert main(["transfer", *common, "--blend-style", other, "--blend", "0.3", "-o", str(blend),
                 "--explain", str(tmp_path / "blend.json")]) == 0  # fmt: skip
    for record in ("change.json", "blend.json"):  # both styles searched
        assert len(json.loads((tmp_path / record).read_text())["styles"]) == 2
    positions = {path: read_bvh(path)[0].positions() for path in (single, change, blend)}

    def largest_gap(a: Path, b: Path, frames: slice) -> float:
        return float(np.abs(positions[a][frames] - positions[b][frames]).max())

    # before the change at 2 s the output is the first style's, frame for frame; later it is not
    assert (
        largest_gap(change, single, slice(0, 45)) < 1e-3 < 1.0 < largest_gap(change, single, slice(90, 200))
    )
    assert largest_gap(blend, single, slice(0, 45)) > 1.0  # a blend acts from the start


def test_errors_are_one_line_with_exit_codes(walk: str, tmp_path: Path) -> None:
    bad = tmp_path / "bad.bvh"
    bad.write_text(THREE_CHANNEL_BVH.replace("1 20 0 90", "1 20 0 oops"))
    out = tmp_path / "out.bvh"
    result = run("transfer", str(bad), "--style", walk, "-o", str(out))
    assert result.returncode == 1
    assert result.stderr.strip().count("\n") == 0
    assert "bad.bvh:" in result.stderr and "not a number" in result.stderr
    assert not out.exists()
    tiny = tmp_path / "tiny.bvh"
    tiny.write_text(THREE_CHANNEL_BVH)
    mismatch = run("transfer", str(tiny), "--style", walk, "-o", str(out))
    assert mismatch.returncode == 1 and "only in the model" in mismatch.stderr
    assert not out.exists()
    usage = run("transfer", walk, "--style", walk, "--then-style", walk, "-o", str(out))
    assert usage.returncode == 2 and "--at" in usage.stderr
    missing = run("info", str(tmp_path / "nope.bvh"))
    assert missing.returncode == 1 and "no such file" in missing.stderr
    both = run(
        "transfer", str(tmp_path / "nope.bvh"), "--style", str(tmp_path / "nostyle.bvh"), "-o", str(out)
    )
    assert (
        both.returncode == 1
        and both.stderr.strip()
        == f"elastyle: error: {tmp_path / 'nope.bvh'}: no such file, folder or archive"
    )
    assert "Traceback" not in missing.stderr + mismatch.stderr + result.stderr


def test_output_equal_to_input_is_refused(tmp_path: Path) -> None:
    clip = tmp_path / "clip.bvh"
    clip.write_text(THREE_CHANNEL_BVH)
    result = run("convert", str(clip), "-o", str(clip), "--force")
    assert result.returncode == 1 and "would overwrite" in result.stderr
    assert clip.read_text() == THREE_CHANNEL_BVH


def test_off_switches_say_they_turn_off(capsys: pytest.CaptureFixture[str]) -> None:
    """A flag that turns a default-on step off says so, rather than describing the step as if it added it."""
    with pytest.raises(SystemExit):
        main(["transfer", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for flag in ("--no-mirror-style", "--no-cleanup"):
        assert f"{flag} turn off what is on by default:" in text
    # each number's allowed range beside its default, as the README says (the checks enforced them unsaid)
    assert "--patch-s PATCH_S patch length, seconds (default: 1; allowed (0, 60])" in text
    assert "(default: 0.25; allowed [0, 1))" in text


def test_eval_refuses_clips_of_another_skeleton(walk: str, style: str, tmp_path: Path) -> None:
    """eval compares the output with its content joint by joint: another skeleton is a one-line error
    naming the file, not an internal error or a meaningless bone error."""
    other = tmp_path / "other.bvh"
    other.write_text(THREE_CHANNEL_BVH)
    for args, named in (
        (["eval", str(other), "--content", walk, "--style", style], other),
        (["eval", walk, "--content", str(other), "--style", style], walk),
        (["eval", walk, "--content", walk, "--style", str(other)], other),
    ):
        result = run(*args)
        assert result.returncode == 1 and result.stderr.strip().count("\n") == 0, result.stderr
        assert f"{named}: skeleton differs from the content" in result.stderr


def test_a_style_clip_too_short_for_a_patch_is_named(walk: str, tmp_path: Path) -> None:
    clip = read_bvh(walk)[0]
    short = tmp_path / "short.bvh"
    write_bvh(short, Motion(clip.skeleton, clip.rotations[:3], clip.translations[:3], clip.fps))
    out = tmp_path / "out.bvh"
    result = run("transfer", walk, "--style", str(short), "-o", str(out))
    assert result.returncode == 1 and not out.exists()
    assert result.stderr.strip() == (
        f"elastyle: error: {short}: too short for a patch (3 frame(s) at 30 fps at most; patches need at least 4)"
    )


def test_a_change_of_style_outside_the_clip_is_reported(walk: str, style: str, tmp_path: Path) -> None:
    out = tmp_path / "out.bvh"
    before = run("transfer", walk, "--style", style, "--then-style", style, "--at", "-3", "-o", str(out))
    assert before.returncode == 2 and "--at is a time in the content, from 0 s" in before.stderr
    after = run("transfer", walk, "--style", style, "--then-style", style, "--at", "100", "-o", str(out))
    assert (
        after.returncode == 0
        and "starts at 100 s, after the clip's end (8.90 s): it does not show" in after.stderr
    )


def test_a_missing_clip_inside_an_archive_is_no_such_file(walk: str, style: str, tmp_path: Path) -> None:
    if ".zip" not in walk:
        pytest.skip("the dataset is a folder here, not an archive")
    missing = walk.replace("walk_normal_005", "walk_nothere")
    result = run("transfer", missing, "--style", style, "-o", str(tmp_path / "out.bvh"))
    assert result.returncode == 1 and result.stderr.strip().startswith(
        f"elastyle: error: {missing}: no such file"
    )


def test_a_repeated_keep_part_adds_its_parts() -> None:
    from elastyle.cli import build_parser
    from elastyle.cli.options import config_from_args
    from elastyle.steps.config import TransferConfig

    def kept(*flags: str) -> str:
        args = build_parser().parse_args(["transfer", "c.bvh", "--style", "s.bvh", "-o", "o.bvh", *flags])
        return config_from_args(TransferConfig, args).keep_part

    assert kept() == ""
    assert kept("--keep-part", "legs") == "legs"
    assert kept("--keep-part", "legs", "--keep-part", "arms") == "legs,arms"
    assert kept("--keep-part", "legs,spine", "--keep-part", "left-arm") == "legs,spine,left-arm"


def test_train_recipes_set_what_no_flag_gives() -> None:
    from dataclasses import asdict

    from elastyle.cli import build_parser
    from elastyle.cli.train import train_config
    from elastyle.model.file import load_model
    from elastyle.training.config import TrainConfig

    def config(*flags: str) -> TrainConfig:
        return train_config(
            build_parser().parse_args(["train", "clips/", "-o", "m.npz", "--steps", "9", *flags])
        )

    assert config() == TrainConfig(steps=9)  # the report's recipe: TrainConfig's own defaults
    shipped = asdict(config("--recipe", "shipped"))
    recorded = load_model().metadata["train_config"]  # what the shipped model was trained with
    for name in ("model", "batch_size", "learning_rate", "lr_schedule", "window_s", "reverse_augment",
                 "speed_augment", "perturb_augment", "perturb_scale", "position_loss"):  # fmt: skip
        assert shipped[name] == recorded[name], name
    overridden = config("--recipe", "shipped", "--latent", "48", "--lr", "5e-4")
    assert overridden.model.latent_channels == 48 and overridden.learning_rate == 5e-4
    assert not overridden.model.tied and overridden.batch_size == 32  # the rest stays the recipe's
    assert config("--untied").model.tied is False and config().model.tied is True


def test_a_name_the_archive_lacks_is_answered_with_its_nearest_and_a_batch_names_skip_existing(
    walk: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Guessing a dataset clip's name wrong (its style left out) names the archive's nearest; a batch whose
    outputs partly exist says --skip-existing writes the rest."""
    wrong = walk.replace("walk_normal_005", "walk_005")
    assert main(["info", wrong]) == 1
    assert "nearest in it: bandai-namco-2/data/dataset-2_walk_normal_005.bvh" in capsys.readouterr().err
    other = walk.replace("walk_normal_005", "walk_normal_010")
    (tmp_path / "dataset-2_walk_normal_005.bvh").write_text("taken")
    assert main(["transfer", walk, other, "--style", walk, "-o", str(tmp_path), "--no-cache"]) == 1
    assert "--skip-existing" in capsys.readouterr().err


def test_info_on_a_folder_describes_every_clip_it_can_read(
    walk: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An unreadable clip in a folder is named and the others are still described (info stopped at it)."""
    from elastyle.io.dataset import read_clip

    motion, layout = read_clip(walk)
    for name in ("a.bvh", "c.bvh"):
        write_bvh(tmp_path / name, motion.slice(0, 10), layout)
    (tmp_path / "b.bvh").write_text("")
    assert main(["info", str(tmp_path)]) == 1
    said = capsys.readouterr()
    assert f"{tmp_path / 'a.bvh'}\n" in said.out and f"{tmp_path / 'c.bvh'}\n" in said.out
    assert "b.bvh: empty file" in said.err and "1 of 3 clips could not be read" in said.err


def test_info_describes_a_model_file(capsys: pytest.CaptureFixture[str]) -> None:
    """`elastyle info MODEL.npz` prints the model's shape, skeleton, training and held-out figures (a model
    file read as a clip was refused as binary data)."""
    from elastyle.model.file import default_model_path, load_model

    path = str(default_model_path())
    assert main(["info", path]) == 0
    printed = capsys.readouterr().out
    model = load_model(path)
    assert f"latent {model.autoencoder.config.latent_channels}" in printed
    assert f"joints:   {model.skeleton.num_joints} (" in printed
    median = model.metadata["held_out_joint_error_cm"]["median"]
    assert f"held out: joint error median {median:g} cm" in printed


def test_a_transfer_does_not_import_numpy_ma(walk: str, style: str, tmp_path: Path) -> None:
    """numpy.ma (about 20 ms of a command's start-up) is imported by np.median and numpy's interpolating
    percentiles on their first call: the transfer takes its medians from core.stats instead."""
    script = (
        "import sys; from elastyle.cli import main; "
        f"main(['transfer', {walk!r}, '--style', {style!r}, '-o', {str(tmp_path / 'o.bvh')!r}]); "
        "print('numpy.ma' in sys.modules)"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == "False"


def test_the_median_is_numpys() -> None:
    from elastyle.core.stats import median

    values = np.random.default_rng(0).standard_normal((9, 4))
    for rows in (values, values[:8], values[:1]):
        np.testing.assert_array_equal(median(rows, axis=0), np.median(rows, axis=0))
        np.testing.assert_array_equal(median(rows.T, axis=1), np.median(rows.T, axis=1))


def test_a_style_clip_in_metres_is_said_to_be_read_so_also_from_the_cache(
    walk: str, dataset_clips: list[ClipRef], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A content whose unit is guessed gets a note; a style clip's was read in silence (and a style in another
    unit than the user thinks is as likely). Its note is kept with the cached library and said again."""
    monkeypatch.setenv("ELASTYLE_CACHE", str(tmp_path / "cache"))
    style = clip_named(dataset_clips, "dataset-2_walk_exhausted_005").read()[0].slice(0, 90).scaled(0.01)
    write_bvh(tmp_path / "metres.bvh", style)
    for attempt in ("encoded", "from the cache"):
        result = run(
            "transfer",
            walk,
            "--style",
            str(tmp_path / "metres.bvh"),
            "-o",
            str(tmp_path / "out.bvh"),
            "--force",
        )
        assert result.returncode == 0, result.stderr
        assert "metres.bvh: length unit guessed as m" in result.stderr, (attempt, result.stderr)
